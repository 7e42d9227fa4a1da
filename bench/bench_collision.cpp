// Penetration pruning throughput: GraspChecker::check_many (all cores) against serial check()
// calls on the same candidates, for the Barrett hand on the bundled targets (box, mug, flask).
// Also reports the checker's build time, the share of candidates pruned, and the closing time,
// and compares the distance-field check with the exact one (use_distance_field = false) on the
// same poses: these candidates and as many near-contact poses (a random link point put 3 mm inside
// .. 2 mm outside a random target surface point), time per check, ratio and differing decisions;
// and the same for closing (close_fingers) and contacts (find_contacts) on the kept candidates.
//
// Candidates: the palm faces the target's centre from a random direction, its top 0..120 mm in
// front of the target's extent along that direction, with a random roll and random DOFs within
// the limits (flexions in the open third): a mix of kept and pruned poses. The model directory is
// PAIRGRASP_MODEL_DIR (environment, else compile time); PAIRGRASP_FIELD_CELL (metres, environment)
// sets the distance fields' cell of the checker under test (default CheckOptions::field_cell).
#include <pairgrasp/collision.hpp>
#include <pairgrasp/grasp.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#ifndef PAIRGRASP_MODEL_DIR
#define PAIRGRASP_MODEL_DIR "models"
#endif

using namespace pairgrasp;

namespace {

constexpr int kCandidates = 256;
const char* kTargets[] = {"box", "mug", "flask"};

std::string model_dir() {
  const char* env = std::getenv("PAIRGRASP_MODEL_DIR");
  return env ? env : PAIRGRASP_MODEL_DIR;
}

struct Scene {
  std::unique_ptr<GraspChecker> checker;
  std::unique_ptr<GraspChecker> exact;  // use_distance_field = false
  std::vector<Pose> near_wrists;
  std::vector<Eigen::VectorXd> near_dofs;
  std::vector<Pose> wrists;
  std::vector<Eigen::VectorXd> dofs;
  double build_seconds = 0.0;
};

// The options of the checker under test: the defaults, the field cell from PAIRGRASP_FIELD_CELL.
CheckOptions checker_options() {
  CheckOptions options;
  if (const char* cell = std::getenv("PAIRGRASP_FIELD_CELL")) {
    char* end = nullptr;
    options.field_cell = std::strtod(cell, &end);
    if (end == cell || *end != '\0' || !(options.field_cell > 0.0) || !std::isfinite(options.field_cell))
      throw std::invalid_argument(std::string("PAIRGRASP_FIELD_CELL: expected a length > 0 in metres, got '") + cell + "'");
  }
  return options;
}

Scene& scene(const std::string& name) {
  static std::map<std::string, Scene> scenes;
  auto it = scenes.find(name);
  if (it != scenes.end()) return it->second;
  Scene& s = scenes[name];
  const Hand hand = Hand::load(model_dir() + "/barrett/barrett.json");
  const Mesh target = load_mesh(model_dir() + "/targets/" + name + ".stl");
  const auto t0 = std::chrono::steady_clock::now();
  const CheckOptions options = checker_options();
  s.checker = std::make_unique<GraspChecker>(hand, target, Mask(), std::vector<Obstacle>{}, options);
  s.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  std::mt19937_64 rng(11);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Vector3d centre = target.bounds.center();
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
  for (int k = 0; k < kCandidates; ++k) {
    const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    // Wrist z (approach) points from the palm at -dir*dist towards the centre.
    Pose w = Pose::Identity();
    w.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), -dir).toRotationMatrix() *
                 Eigen::AngleAxisd(6.283185307179586 * u(rng), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    // The palm top (0.075 above the wrist) 0..120 mm in front of the target's extent along dir.
    double support = 0.0;
    for (Eigen::Index v = 0; v < target.vertices.rows(); ++v)
      support = std::max(support, (Eigen::Vector3d(target.vertices.row(v).transpose()) - centre).dot(dir));
    w.translation() = centre + dir * (support + 0.12 * u(rng) + 0.075);
    // Spread anywhere, flexions in the open third of their range (as aligned, before closing).
    Eigen::VectorXd q(lo.size());
    for (Eigen::Index i = 0; i < q.size(); ++i) q[i] = lo[i] + (hi[i] - lo[i]) * u(rng) * (i == 0 ? 1.0 : 0.33);
    s.wrists.push_back(w);
    s.dofs.push_back(q);
  }
  CheckOptions exact;
  exact.use_distance_field = false;
  s.exact = std::make_unique<GraspChecker>(hand, target, Mask(), std::vector<Obstacle>{}, exact);
  // Near contact: a random point of a random link 3 mm inside .. 2 mm outside a random target point.
  auto on_surface = [&](const Mesh& m, Eigen::Vector3d* normal) {
    const Eigen::Index f = std::min<Eigen::Index>(static_cast<Eigen::Index>(u(rng) * m.faces.rows()), m.faces.rows() - 1);
    double a = u(rng), b = u(rng);
    if (a + b > 1.0) a = 1.0 - a, b = 1.0 - b;
    const Eigen::Vector3d p0 = m.vertices.row(m.faces(f, 0)).transpose(), p1 = m.vertices.row(m.faces(f, 1)).transpose(),
                          p2 = m.vertices.row(m.faces(f, 2)).transpose();
    if (normal) *normal = (p1 - p0).cross(p2 - p0).normalized();
    return Eigen::Vector3d(p0 + a * (p1 - p0) + b * (p2 - p0));
  };
  for (int k = 0; k < kCandidates; ++k) {
    Eigen::VectorXd q(lo.size());
    for (Eigen::Index i = 0; i < q.size(); ++i) q[i] = lo[i] + (hi[i] - lo[i]) * u(rng);
    const std::size_t l = std::min<std::size_t>(static_cast<std::size_t>(u(rng) * hand.links().size()), hand.links().size() - 1);
    Pose w = Pose::Identity();
    w.linear() = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    const Eigen::Vector3d y = hand.link_poses(q)[l] * on_surface(hand.links()[l].mesh, nullptr);
    Eigen::Vector3d n;
    const Eigen::Vector3d x = on_surface(target, &n);
    w.translation() = x + n * (-0.003 + 0.005 * u(rng)) - w.linear() * y;
    s.near_wrists.push_back(w);
    s.near_dofs.push_back(q);
  }
  return s;
}

// Seconds per serial check over the poses (best of 3 passes) and the results.
double time_checks(const GraspChecker& c, const std::vector<Pose>& w, const std::vector<Eigen::VectorXd>& q,
                   bool exact_depth, std::vector<CheckResult>& out) {
  double best = 1e30;
  for (int pass = 0; pass < 3; ++pass) {
    out.clear();
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < w.size(); ++k) out.push_back(c.check(w[k], q[k], exact_depth));
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return best / static_cast<double>(w.size());
}

int differing(const std::vector<CheckResult>& a, const std::vector<CheckResult>& b) {
  int n = 0;
  for (std::size_t k = 0; k < a.size(); ++k)
    n += a[k].pruned != b[k].pruned || a[k].penetrating != b[k].penetrating ||
         a[k].obstacle_collision != b[k].obstacle_collision || a[k].touches_occluded != b[k].touches_occluded ||
         a[k].collision != b[k].collision;
  return n;
}

void print_field_comparison() {
  std::printf("\nDistance field (cell %.2f mm) against exact check, serial, %d poses per set\n",
              1e3 * scene(kTargets[0]).checker->options().field_cell, kCandidates);
  std::printf("%-6s %-12s %-6s %12s %12s %8s %7s %9s %9s\n", "target", "poses", "depth", "exact us", "field us",
              "ratio", "differ", "field MB", "build s");
  for (const char* t : kTargets) {
    Scene& s = scene(t);
    for (int set = 0; set < 2; ++set)
      for (bool exact_depth : {true, false}) {
        const auto& w = set ? s.near_wrists : s.wrists;
        const auto& q = set ? s.near_dofs : s.dofs;
        std::vector<CheckResult> a, b;
        const double te = time_checks(*s.exact, w, q, exact_depth, a);
        const double tf = time_checks(*s.checker, w, q, exact_depth, b);
        std::printf("%-6s %-12s %-6s %12.1f %12.1f %8.1f %7d %9.2f %9.3f\n", t, set ? "near-contact" : "candidates",
                    exact_depth ? "exact" : "stop", 1e6 * te, 1e6 * tf, te / tf, differing(a, b),
                    s.checker->distance_field_bytes() / 1e6, s.checker->distance_field_seconds());
      }
  }
}

bool same_contacts(const Contacts& a, const Contacts& b) {
  return a.points == b.points && a.target_points == b.target_points && a.normals == b.normals &&
         a.distances == b.distances && a.faces == b.faces && a.links == b.links && a.occluded_count == b.occluded_count;
}

// Closing (close_fingers) and the contacts of the closed grasp, exact against field, on the
// candidates the exact check keeps: time per call, closings whose reasons or final decisions
// differ, the largest difference of the closed DOFs, and contact sets that differ.
void print_close_comparison() {
  std::printf("\nClosing and contacts, distance field against exact, serial, candidates kept by the check\n");
  std::printf("%-6s %6s %12s %12s %8s %9s %10s %11s %11s %8s %8s\n", "target", "kept", "close ex ms", "close fd ms",
              "ratio", "differ", "max dq", "contact ex", "contact fd", "ratio", "differ");
  for (const char* t : kTargets) {
    Scene& s = scene(t);
    std::vector<int> kept;
    for (int k = 0; k < kCandidates; ++k)
      if (!s.exact->check(s.wrists[k], s.dofs[k]).pruned) kept.push_back(k);
    std::vector<CloseResult> a, b;
    auto t0 = std::chrono::steady_clock::now();
    for (int k : kept) a.push_back(close_fingers(*s.exact, s.wrists[k], s.dofs[k]));
    const double te = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t0 = std::chrono::steady_clock::now();
    for (int k : kept) b.push_back(close_fingers(*s.checker, s.wrists[k], s.dofs[k]));
    const double tf = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    int differ = 0;
    double dq = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      differ += a[i].reasons != b[i].reasons || a[i].check.pruned != b[i].check.pruned ||
                a[i].check.penetrating != b[i].check.penetrating || a[i].check.collision != b[i].check.collision;
      dq = std::max(dq, (a[i].dofs - b[i].dofs).cwiseAbs().maxCoeff());
    }
    // Contacts at the exactly closed DOFs, both ways.
    std::vector<Contacts> ca, cb;
    t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < kept.size(); ++i) ca.push_back(find_contacts(*s.exact, s.wrists[kept[i]], a[i].dofs));
    const double tce = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < kept.size(); ++i) cb.push_back(find_contacts(*s.checker, s.wrists[kept[i]], a[i].dofs));
    const double tcf = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    int cdiffer = 0;
    for (std::size_t i = 0; i < kept.size(); ++i) cdiffer += !same_contacts(ca[i], cb[i]);
    const double n = std::max<double>(1.0, static_cast<double>(kept.size()));
    std::printf("%-6s %6zu %12.2f %12.2f %8.1f %9d %10.2g %11.3f %11.3f %8.1f %8d\n", t, kept.size(), 1e3 * te / n,
                1e3 * tf / n, te / tf, differ, dq, 1e3 * tce / n, 1e3 * tcf / n, tce / tcf, cdiffer);
  }
}

void BM_CheckSerial(benchmark::State& state, const char* name) {
  Scene& s = scene(name);
  for (auto _ : state)
    for (int k = 0; k < kCandidates; ++k) benchmark::DoNotOptimize(s.checker->check(s.wrists[k], s.dofs[k]));
  state.SetItemsProcessed(state.iterations() * kCandidates);
}

void BM_CheckMany(benchmark::State& state, const char* name) {
  Scene& s = scene(name);
  for (auto _ : state) benchmark::DoNotOptimize(s.checker->check_many(s.wrists, s.dofs, 0));
  state.SetItemsProcessed(state.iterations() * kCandidates);
}

void BM_CloseKept(benchmark::State& state, const char* name) {
  Scene& s = scene(name);
  std::vector<int> kept;
  for (int k = 0; k < kCandidates; ++k)
    if (!s.checker->check(s.wrists[k], s.dofs[k]).pruned) kept.push_back(k);
  if (kept.empty()) {
    state.SkipWithError("no kept candidate");
    return;
  }
  std::size_t i = 0;
  for (auto _ : state) {
    const int k = kept[i++ % kept.size()];
    benchmark::DoNotOptimize(close_fingers(*s.checker, s.wrists[k], s.dofs[k]));
  }
  state.SetItemsProcessed(state.iterations());
}

void register_all() {
  for (const char* t : kTargets) {
    benchmark::RegisterBenchmark((std::string("BM_CheckSerial/") + t).c_str(), BM_CheckSerial, t)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark((std::string("BM_CheckMany/") + t).c_str(), BM_CheckMany, t)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark((std::string("BM_CloseKept/") + t).c_str(), BM_CloseKept, t)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
  }
}

// Keeps the real time per iteration of every benchmark for the ratios printed at the end.
class Recorder : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> seconds;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs)
      if (r.run_type == Run::RT_Iteration && r.iterations > 0)
        seconds[r.run_name.function_name] = r.real_accumulated_time / static_cast<double>(r.iterations);
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace

int run(int argc, char** argv) {
  checker_options();  // a malformed PAIRGRASP_FIELD_CELL fails before any benchmark runs
  register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  Recorder rec;
  benchmark::RunSpecifiedBenchmarks(&rec);
  std::printf("\nBarrett hand, %d candidates per target, %u hardware threads\n", kCandidates,
              std::thread::hardware_concurrency());
  std::printf("%-6s %8s %9s %11s %14s %14s %8s %12s\n", "target", "faces", "build s", "pruned %",
              "serial cand/s", "many cand/s", "speedup", "close ms");
  for (const char* t : kTargets) {
    const auto serial = rec.seconds.find(std::string("BM_CheckSerial/") + t);
    const auto many = rec.seconds.find(std::string("BM_CheckMany/") + t);
    if (serial == rec.seconds.end() || many == rec.seconds.end()) continue;
    Scene& s = scene(t);
    int pruned = 0;
    for (const auto& r : s.checker->check_many(s.wrists, s.dofs, 0)) pruned += r.pruned;
    const auto close = rec.seconds.find(std::string("BM_CloseKept/") + t);
    std::printf("%-6s %8ld %9.3f %11.1f %14.0f %14.0f %8.2f %12.2f\n", t,
                static_cast<long>(s.checker->target().faces.rows()), s.build_seconds, 100.0 * pruned / kCandidates,
                kCandidates / serial->second, kCandidates / many->second, serial->second / many->second,
                close == rec.seconds.end() ? 0.0 : 1e3 * close->second);
  }
  print_field_comparison();
  print_close_comparison();
  benchmark::Shutdown();
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_collision: error: %s\n", e.what());
    return 1;
  }
}
