// PairIndex: hierarchy query against a brute-force scan of the same stored features, index build
// time, bytes per stored pair and matches per query at the default tolerances, at 10^5, 10^6 and
// 10^7 stored pairs. Prints the speed-ups measured in this run after the benchmark table, then
// the unit-facet counts, area CVs and times of the bundled targets.
//
// Point sets: a bumpy sphere of radius 5 cm (radial noise 5 %) with normals tilted by noise of
// 0.3 (about 17 degrees), and d_max = 0.2 m: beyond the diameter, as for a Barrett hand on a
// hand-sized target, so every pair is stored and N = sqrt(2 M) points give M pairs.
// Queries: the features of random stored pairs moved by Gaussian noise of one tolerance per
// component (what a matching gripper pair looks like), tolerances (2.5 mm, 0.05, 0.05).
#include <pairgrasp/facets.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/paint.hpp>
#include <pairgrasp/pair_index.hpp>

#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <random>
#include <vector>

using namespace pairgrasp;

namespace {

const Eigen::Vector3d kTolerance(0.0025, 0.05, 0.05);
constexpr int kQueries = 512;

struct Case {
  std::unique_ptr<PairIndex> index;
  std::vector<Eigen::Vector3d> queries;
  double build_seconds = 0.0;
  double mean_matches = 0.0;  // over all the queries
};

struct Figures {
  double build_s = -1, query_us = -1, brute_us = -1, count_us = -1, matches = -1, bytes_per_pair = -1;
  std::size_t pairs = 0;
};

std::map<long, Case> g_cases;
std::map<long, Figures> g_figures;

void sphere_cloud(long pairs, Points& p, Points& n) {
  const long count = long(std::ceil(0.5 + std::sqrt(0.25 + 2.0 * double(pairs))));
  std::mt19937_64 rng(42);
  std::normal_distribution<double> g;
  p.resize(count, 3);
  n.resize(count, 3);
  for (long i = 0; i < count; ++i) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    p.row(i) = (0.05 * (1.0 + 0.05 * g(rng)) * d).transpose();
    n.row(i) = (d + 0.3 * Eigen::Vector3d(g(rng), g(rng), g(rng))).normalized().transpose();
  }
}

PairIndexOptions options() {
  PairIndexOptions o;
  o.d_max = 0.2;
  o.max_pairs = 50'000'000;
  return o;
}

Case& get_case(long pairs) {
  auto it = g_cases.find(pairs);
  if (it != g_cases.end()) return it->second;
  Points p, n;
  sphere_cloud(pairs, p, n);
  Case c;
  const auto t0 = std::chrono::steady_clock::now();
  c.index = std::make_unique<PairIndex>(p, n, Mask(), options());
  c.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  std::uniform_int_distribution<long> pick(0, long(c.index->size()) - 1);
  for (int q = 0; q < kQueries; ++q) {
    Eigen::Vector3d f = c.index->features().row(pick(rng)).cast<double>().transpose();
    for (int a = 0; a < 3; ++a) f[a] += g(rng) * kTolerance[a];
    c.queries.push_back(f);
    c.mean_matches += double(c.index->count(f, kTolerance)) / kQueries;
  }
  return g_cases.emplace(pairs, std::move(c)).first->second;
}

// The comparison: a scan of every stored feature with the same test as the hierarchy.
void brute_force(const PairIndex& idx, const Eigen::Vector3d& c, const Eigen::Vector3d& t,
                 std::vector<std::uint32_t>& out) {
  const float* f = idx.features().data();
  const std::size_t m = idx.size();
  for (std::size_t k = 0; k < m; ++k, f += 3)
    if (std::abs(double(f[0]) - c[0]) <= t[0] && std::abs(double(f[1]) - c[1]) <= t[1] &&
        std::abs(double(f[2]) - c[2]) <= t[2])
      out.push_back(std::uint32_t(k));
}

void BM_Build(benchmark::State& state) {
  Points p, n;
  sphere_cloud(state.range(0), p, n);
  std::size_t pairs = 0, bytes = 0;
  double seconds = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    PairIndex idx(p, n, Mask(), options());
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    pairs = idx.size();
    bytes = idx.nbytes();
    benchmark::DoNotOptimize(idx.features().data());
  }
  Figures& f = g_figures[state.range(0)];
  f.build_s = seconds / double(state.iterations());
  f.pairs = pairs;
  f.bytes_per_pair = double(bytes) / double(pairs);
  state.counters["pairs"] = double(pairs);
  state.counters["points"] = double(p.rows());
  state.counters["bytes_per_pair"] = f.bytes_per_pair;
  state.counters["pairs_per_s"] = benchmark::Counter(double(pairs), benchmark::Counter::kIsIterationInvariantRate);
}

template <class Run>
void query_loop(benchmark::State& state, Run run, double Figures::*slot) {
  Case& c = get_case(state.range(0));
  std::vector<std::uint32_t> out;
  std::size_t q = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    out.clear();
    benchmark::DoNotOptimize(run(*c.index, c.queries[q++ % c.queries.size()], out));
    benchmark::DoNotOptimize(out.data());
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Figures& f = g_figures[state.range(0)];
  f.*slot = 1e6 * seconds / double(state.iterations());
  f.matches = c.mean_matches;
  state.counters["matches_per_query"] = f.matches;
  state.counters["pairs"] = double(c.index->size());
}

void BM_Query(benchmark::State& state) {
  query_loop(
      state,
      [](const PairIndex& idx, const Eigen::Vector3d& c, std::vector<std::uint32_t>& out) {
        idx.query(c, kTolerance, out);
        return out.size();
      },
      &Figures::query_us);
}

void BM_Count(benchmark::State& state) {
  query_loop(
      state, [](const PairIndex& idx, const Eigen::Vector3d& c, std::vector<std::uint32_t>&) { return idx.count(c, kTolerance); },
      &Figures::count_us);
}

void BM_BruteForce(benchmark::State& state) {
  query_loop(
      state,
      [](const PairIndex& idx, const Eigen::Vector3d& c, std::vector<std::uint32_t>& out) {
        brute_force(idx, c, kTolerance, out);
        return out.size();
      },
      &Figures::brute_us);
}

BENCHMARK(BM_Build)->Arg(100'000)->Arg(1'000'000)->Arg(10'000'000)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Query)->Arg(100'000)->Arg(1'000'000)->Arg(10'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Count)->Arg(100'000)->Arg(1'000'000)->Arg(10'000'000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_BruteForce)->Arg(100'000)->Arg(1'000'000)->Arg(10'000'000)->Unit(benchmark::kMicrosecond);

// A real target for scale: the bundled mug at h = 5 mm (the design's example).
void mug_line() {
  try {
    const Mesh mesh = load_mesh(std::string(PAIRGRASP_MODEL_DIR) + "/targets/mug.stl");
    const UnitFacets f = tessellate(mesh, 0.005);
    const PairIndex idx(f.points, f.normals, f.free, options());
    std::mt19937_64 rng(3);
    std::uniform_int_distribution<long> pick(0, long(idx.size()) - 1);
    std::normal_distribution<double> g;
    double matches = 0;
    for (int q = 0; q < 256; ++q) {
      Eigen::Vector3d c = idx.features().row(pick(rng)).cast<double>().transpose();
      for (int a = 0; a < 3; ++a) c[a] += g(rng) * kTolerance[a];
      matches += double(idx.count(c, kTolerance));
    }
    std::printf("mug.stl at h = 5 mm: %ld facets, %zu pairs, %.1f bytes/pair, %.0f matches/query\n",
                long(f.points.rows()), idx.size(), double(idx.nbytes()) / double(idx.size()), matches / 256);
  } catch (const std::exception& e) {
    std::printf("mug.stl: skipped (%s)\n", e.what());
  }
}

// Unit facets of the bundled targets (with their paint): count, area CV, time.
void tessellation_lines() {
  std::printf("\nUnit facets of the bundled targets (edge = largest extent / k):\n");
  std::printf("%-10s %6s %9s %8s %7s %9s\n", "target", "k", "edge_mm", "facets", "cv", "time_s");
  for (const char* name : {"box", "mug", "flask"}) {
    try {
      const std::string base = std::string(PAIRGRASP_MODEL_DIR) + "/targets/" + name;
      const Mesh mesh = load_mesh(base + ".stl");
      const Mask paint = load_paint(base + ".paint.json", mesh);
      const double extent = (mesh.vertices.colwise().maxCoeff() - mesh.vertices.colwise().minCoeff()).maxCoeff();
      for (double k : {25.0, 40.0, 80.0}) {
        const auto t0 = std::chrono::steady_clock::now();
        const UnitFacets f = tessellate(mesh, extent / k, paint);
        const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const double mean = f.areas.mean();
        const double cv = std::sqrt((f.areas.array() - mean).square().mean()) / mean;
        std::printf("%-10s %6.0f %9.2f %8ld %7.3f %9.3f\n", name, k, 1000 * extent / k, long(f.points.rows()), cv, dt);
      }
    } catch (const std::exception& e) {
      std::printf("%-10s skipped (%s)\n", name, e.what());
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  std::printf("\nPairIndex summary, tolerances (%.4g m, %.3g, %.3g), measured in this run:\n", kTolerance[0],
              kTolerance[1], kTolerance[2]);
  std::printf("%10s %9s %10s %12s %11s %11s %11s %10s\n", "pairs", "build_s", "bytes/pair", "matches/qry",
              "query_us", "count_us", "brute_us", "speed-up");
  for (const auto& [size, f] : g_figures) {
    const double speedup = f.query_us > 0 && f.brute_us > 0 ? f.brute_us / f.query_us : NAN;
    std::printf("%10ld %9.3f %10.2f %12.0f %11.1f %11.1f %11.1f %9.1fx\n", size, f.build_s, f.bytes_per_pair,
                f.matches, f.query_us, f.count_us, f.brute_us, speedup);
  }
  mug_line();
  tessellation_lines();
  return 0;
}
