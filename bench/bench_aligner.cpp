// Aligner time per DOF sample on each bundled target, for the Barrett hand's 7-point (one sample
// per active link) constellation and an area-sampled constellation (2 cm spacing).
//
// Each target is tessellated at the edge suggest_edge() picks for a pair budget of 2e6 pairs
// with d_max = the hand's largest sample distance over a coarse DOF grid, and indexed with its
// paint file's free faces. DOF samples are spread over the hand's full 0.25 rad grid (every
// k-th grid point). align: one DOF sample per iteration on one thread; align_many: all samples
// on every core.
#include <pairgrasp/aligner.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/paint.hpp>
#include <pairgrasp/pair_index.hpp>

#include <benchmark/benchmark.h>

#include <chrono>
#include <ctime>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#ifndef PAIRGRASP_MODEL_DIR
#define PAIRGRASP_MODEL_DIR "models"
#endif

using namespace pairgrasp;

namespace {

const std::vector<std::string> kTargets{"box", "mug", "flask"};
constexpr int kSamples = 24;
constexpr double kAreaSpacing = 0.02;

const Hand& hand() {
  static const Hand h = Hand::load(std::string(PAIRGRASP_MODEL_DIR) + "/barrett/barrett.json");
  return h;
}

// Every DOF vector of the hand's step grid, in row-major order.
std::vector<Eigen::VectorXd> dof_grid(const Hand& h, double step_scale) {
  const Eigen::VectorXd lo = h.dof_lower(), hi = h.dof_upper(), st = h.dof_step() * step_scale;
  std::vector<int> n(lo.size());
  for (Eigen::Index k = 0; k < lo.size(); ++k) n[k] = 1 + static_cast<int>((hi[k] - lo[k]) / st[k] + 1e-9);
  std::vector<Eigen::VectorXd> out;
  std::vector<int> idx(lo.size(), 0);
  for (;;) {
    Eigen::VectorXd q(lo.size());
    for (Eigen::Index k = 0; k < lo.size(); ++k) q[k] = std::min(hi[k], lo[k] + idx[k] * st[k]);
    out.push_back(q);
    Eigen::Index k = lo.size() - 1;
    while (k >= 0 && ++idx[k] == n[k]) idx[k--] = 0;
    if (k < 0) break;
  }
  return out;
}

const std::vector<Eigen::VectorXd>& dof_samples() {
  static const std::vector<Eigen::VectorXd> s = [] {
    const auto grid = dof_grid(hand(), 1.0);
    std::vector<Eigen::VectorXd> out;
    const std::size_t stride = grid.size() / kSamples;
    for (int k = 0; k < kSamples; ++k) out.push_back(grid[k * stride + stride / 2]);
    return out;
  }();
  return s;
}

ConstellationMode mode_of(int m) { return m == 0 ? ConstellationMode::PerLink : ConstellationMode::Area; }

const std::vector<Constellation>& constellations(int mode) {
  static std::map<int, std::vector<Constellation>> cache;
  auto it = cache.find(mode);
  if (it == cache.end()) {
    std::vector<Constellation> cs;
    for (const auto& q : dof_samples()) cs.push_back(hand().constellation(q, mode_of(mode), kAreaSpacing));
    it = cache.emplace(mode, std::move(cs)).first;
  }
  return it->second;
}

double hand_d_max() {
  static const double d = [] {
    double best = 0;
    for (const auto& q : dof_grid(hand(), 2.0))
      for (int mode : {0, 1}) {
        const auto c = hand().constellation(q, mode_of(mode), kAreaSpacing);
        for (Eigen::Index i = 0; i < c.points.rows(); ++i)
          for (Eigen::Index j = i + 1; j < c.points.rows(); ++j)
            best = std::max(best, (c.points.row(i) - c.points.row(j)).norm());
      }
    return best + 0.01;
  }();
  return d;
}

struct Target {
  std::optional<PairIndex> index;
  double edge = 0;
  long facets = 0;
};

const Target& target(const std::string& name) {
  static std::map<std::string, Target> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    const std::string base = std::string(PAIRGRASP_MODEL_DIR) + "/targets/" + name;
    const Mesh mesh = load_mesh(base + ".stl");
    const Mask free = load_paint(base + ".paint.json", mesh);
    PairIndexOptions o;
    o.d_max = hand_d_max();
    o.max_pairs = 2'000'000;
    TargetIndex ti = build_target_index(mesh, 0.0, free, o);
    Target t;
    t.edge = ti.facets.edge;
    t.facets = static_cast<long>(ti.facets.points.rows());
    t.index.emplace(std::move(ti.index));
    it = cache.emplace(name, std::move(t)).first;
  }
  return it->second;
}

struct Summary {
  double ms_per_sample = 0;      // wall
  double cpu_ms_per_sample = 0;  // process CPU (one thread)
  double correspondences = 0;
  double solved = 0;             // correspondences that reached the pose solver
  double voted = 0;              // solver candidates that voted
  double poses = 0;
  AlignTimes phases;             // mean per sample
};
// Key: "<target> <mode>" -> [0] prefilter off (the solver-only path), [1] on (the default).
std::map<std::string, std::map<int, Summary>> summary;

void BM_Align(benchmark::State& state, const std::string& name, int mode, bool prefilter) {
  const Target& t = target(name);
  AlignerOptions o;
  o.threads = 1;
  o.prefilter = prefilter;
  const Aligner aligner(*t.index, o);
  const auto& cs = constellations(mode);
  std::size_t k = 0;
  double corr = 0, solved = 0, voted = 0, poses = 0, n = 0;
  AlignTimes phases;
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  for (auto _ : state) {
    const auto r = aligner.align(cs[k].points, cs[k].normals);
    corr += static_cast<double>(r.stats.correspondences);
    solved += static_cast<double>(r.stats.correspondences_used - r.stats.prefiltered);
    voted += static_cast<double>(r.stats.candidates);
    phases.query += r.times.query;
    phases.prefilter += r.times.prefilter;
    phases.solve += r.times.solve;
    phases.rotation_votes += r.times.rotation_votes;
    phases.positions += r.times.positions;
    poses += static_cast<double>(r.poses.size());
    n += 1;
    k = (k + 1) % cs.size();
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_secs = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  state.SetItemsProcessed(state.iterations());
  state.counters["correspondences"] = corr / n;
  state.counters["samples_P"] = static_cast<double>(cs[0].points.rows());
  state.counters["facets"] = static_cast<double>(t.facets);
  state.counters["pairs"] = static_cast<double>(t.index->size());
  for (double* x : {&phases.query, &phases.prefilter, &phases.solve, &phases.rotation_votes, &phases.positions})
    *x /= n;
  summary[name + (mode == 0 ? " per_link" : " area")][prefilter ? 1 : 0] = {
      1e3 * secs / n, 1e3 * cpu_secs / n, corr / n, solved / n, voted / n, poses / n, phases};
}

void BM_AlignMany(benchmark::State& state, const std::string& name, int mode) {
  const Target& t = target(name);
  const Aligner aligner(*t.index);  // all cores
  const auto& cs = constellations(mode);
  for (auto _ : state) benchmark::DoNotOptimize(aligner.align_many(cs));
  state.SetItemsProcessed(state.iterations() * static_cast<long>(cs.size()));
}

}  // namespace

int main(int argc, char** argv) {
  for (const auto& name : kTargets) {
    for (bool pf : {false, true}) {
      const std::string suffix = pf ? "" : "/no_prefilter";
      benchmark::RegisterBenchmark(("BM_Align/" + name + "/per_link" + suffix).c_str(), BM_Align, name, 0, pf)
          ->Unit(benchmark::kMillisecond)
          ->MinTime(1.0);
      benchmark::RegisterBenchmark(("BM_Align/" + name + "/area" + suffix).c_str(), BM_Align, name, 1, pf)
          ->Unit(benchmark::kMillisecond)
          ->Iterations(kSamples / 4);
    }
    benchmark::RegisterBenchmark(("BM_AlignMany/" + name + "/per_link").c_str(), BM_AlignMany, name, 0)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime()
        ->Iterations(2);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  std::printf("\nAligner, one thread, Barrett hand (%u cores available), d_max %.3f m:\n",
              std::thread::hardware_concurrency(), hand_d_max());
  std::printf("%-18s %4s %7s %7s %9s %7s %11s %7s %7s %10s %10s\n", "target/mode", "P", "edge mm", "facets",
              "pairs", "B/pair", "corr/sample", "solved", "voted", "ms before", "ms now");
  for (const auto& [key, by] : summary) {
    const Target& t = target(key.substr(0, key.find(' ')));
    const int mode = key.find("area") == std::string::npos ? 0 : 1;
    const auto off = by.find(0), on = by.find(1);
    const Summary& any = on != by.end() ? on->second : off->second;
    std::printf("%-18s %4ld %7.2f %7ld %9zu %7.1f %11.0f %7.0f %7.0f", key.c_str(),
                static_cast<long>(constellations(mode)[0].points.rows()), 1e3 * t.edge, t.facets, t.index->size(),
                double(t.index->nbytes()) / double(t.index->size()), any.correspondences, any.solved, any.voted);
    std::printf(" %10s", off != by.end() ? std::to_string(off->second.ms_per_sample).substr(0, 7).c_str() : "-");
    std::printf(" %10s", on != by.end() ? std::to_string(on->second.ms_per_sample).substr(0, 7).c_str() : "-");
    if (off != by.end() && on != by.end())
      std::printf("  (x%.1f faster)", off->second.ms_per_sample / on->second.ms_per_sample);
    std::printf("\n");
  }
  std::printf("\n'before': AlignerOptions::prefilter off (every correspondence solved through solve_pair_pose);\n"
              "'now': the default. B/pair: PairIndex::nbytes() / size() (pairs, features, geometry, tree, points).\n");
  std::printf("\nPhases, ms per sample (AlignResult::times):\n%-18s %-7s %8s %9s %8s %9s %9s %8s\n", "target/mode",
              "path", "query", "prefilter", "solve", "rot.votes", "positions", "total");
  for (const auto& [key, by] : summary)
    for (const auto& [pf, s] : by)
      std::printf("%-18s %-7s %8.3f %9.3f %8.3f %9.3f %9.3f %8.3f\n", key.c_str(), pf ? "now" : "before",
                  s.phases.query, s.phases.prefilter, s.phases.solve, s.phases.rotation_votes, s.phases.positions,
                  s.phases.total());
  benchmark::Shutdown();
  return 0;
}
