// The six-pairing versor solver against Kabsch/Umeyama (Eigen::umeyama, SVD) on the same
// correspondences: time per correspondence and rotation error under noise, in one run.
//
// Fair setup: a correspondence is two oriented points per side. Umeyama gets four points per
// side, the two points and the two points offset along their normals by the pair distance d
// (gripper normals flipped, as at a contact), and solves one point order; "both orders" runs it
// twice, as the versor solver considers both orders. The versor solver gets the oriented pair.
#include <pairgrasp/versor.hpp>

#include <Eigen/Geometry>
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

using namespace pairgrasp;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

struct Corr {
  Vector3d gp0, gp1, gn0, gn1, tp0, tp1, tn0, tn1;
  Matrix3d R;
  Vector3d t;
};

Matrix3d random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix();
}

// Exact correspondences from random rigid transforms; `sigma` perturbs the target normals (rad)
// and points (sigma * d, metres). Pairs are well conditioned (normals >= 30 degrees apart and
// from the line, not nearly symmetric) so that both methods have one right answer.
std::vector<Corr> make_corrs(std::size_t n, double sigma, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  auto unit = [&] { return Vector3d(g(rng), g(rng), g(rng)).normalized(); };
  auto vec = [&](double s) { return Vector3d(s * g(rng), s * g(rng), s * g(rng)); };
  std::vector<Corr> out;
  while (out.size() < n) {
    Corr c;
    c.gp0 = vec(0.05);
    c.gp1 = vec(0.05);
    c.gn0 = unit();
    c.gn1 = unit();
    const Vector3d u = (c.gp1 - c.gp0).normalized();
    if ((c.gp1 - c.gp0).norm() < 0.02 || c.gn0.cross(c.gn1).norm() < 0.5 || c.gn0.cross(u).norm() < 0.5 ||
        c.gn1.cross(u).norm() < 0.5 || std::abs(u.dot(c.gn0 + c.gn1)) < 0.3)
      continue;
    c.R = random_rotation(rng);
    c.t = vec(0.1);
    const double d = (c.gp1 - c.gp0).norm();
    c.tp0 = c.R * c.gp0 + c.t + vec(sigma * d);
    c.tp1 = c.R * c.gp1 + c.t + vec(sigma * d);
    c.tn0 = (-(c.R * c.gn0) + vec(sigma)).normalized();
    c.tn1 = (-(c.R * c.gn1) + vec(sigma)).normalized();
    out.push_back(c);
  }
  return out;
}

PairPoseOptions solver_options(double sigma) {
  PairPoseOptions o;
  o.angle_tolerance = std::max(0.05, 10 * sigma);
  return o;
}

Matrix3d versor_solve(const Corr& c, const PairPoseOptions& o, PairPoseResult& r) {
  solve_pair_pose(c.gp0, c.gp1, c.gn0, c.gn1, c.tp0, c.tp1, c.tn0, c.tn1, o, r);
  return r.candidates.empty() ? Matrix3d::Identity() : r.candidates.front().rotation;
}

Eigen::Matrix4d umeyama_solve(const Corr& c, bool swapped) {
  const double d = (c.gp1 - c.gp0).norm();
  Eigen::Matrix<double, 3, 4> src, dst;
  src << c.gp0, c.gp1, c.gp0 - d * c.gn0, c.gp1 - d * c.gn1;  // flipped gripper normals
  if (!swapped)
    dst << c.tp0, c.tp1, c.tp0 + d * c.tn0, c.tp1 + d * c.tn1;
  else
    dst << c.tp1, c.tp0, c.tp1 + d * c.tn1, c.tp0 + d * c.tn0;
  return Eigen::umeyama(src, dst, false);
}

// Rotation angle between a and b from |a - b|_F = 2 sqrt(2) sin(angle / 2) (accurate near 0,
// unlike acos of the trace).
double rot_err_deg(const Matrix3d& a, const Matrix3d& b) {
  const double s = std::min(1.0, (a - b).norm() / (2.0 * std::sqrt(2.0)));
  return 2.0 * std::asin(s) * 180.0 / M_PI;
}

const std::vector<Corr>& exact_set() {
  static const std::vector<Corr> s = make_corrs(4096, 0.0, 1);
  return s;
}

void BM_VersorSolve(benchmark::State& state) {
  const auto& cs = exact_set();
  PairPoseResult r;
  const PairPoseOptions o = solver_options(0.0);
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(versor_solve(cs[k], o, r));
    k = (k + 1) % cs.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_VersorSolve);

// As the Aligner calls it: only fully agreeing candidates (min_agreement = 3), which lets the
// solver reject a point order early from its dot products.
void BM_VersorSolveFullAgreement(benchmark::State& state) {
  const auto& cs = exact_set();
  PairPoseResult r;
  PairPoseOptions o = solver_options(0.0);
  o.min_agreement = 3;
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(versor_solve(cs[k], o, r));
    k = (k + 1) % cs.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_VersorSolveFullAgreement);

void BM_UmeyamaOneOrder(benchmark::State& state) {
  const auto& cs = exact_set();
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(umeyama_solve(cs[k], false));
    k = (k + 1) % cs.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_UmeyamaOneOrder);

void BM_UmeyamaBothOrders(benchmark::State& state) {
  const auto& cs = exact_set();
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(umeyama_solve(cs[k], false));
    benchmark::DoNotOptimize(umeyama_solve(cs[k], true));
    k = (k + 1) % cs.size();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_UmeyamaBothOrders);

// Keeps the per-iteration CPU time of every benchmark for the ratio printed at the end.
class Recorder : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> ns;
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs)
      if (r.run_type == Run::RT_Iteration && r.iterations > 0)
        ns[r.benchmark_name()] = r.GetAdjustedCPUTime() * benchmark::GetTimeUnitMultiplier(benchmark::kNanosecond) /
                                 benchmark::GetTimeUnitMultiplier(r.time_unit);
    ConsoleReporter::ReportRuns(runs);
  }
};

void accuracy_table() {
  std::printf("\nRotation error (degrees) of the best candidate vs the true rotation, 2000 correspondences each\n");
  std::printf("%-10s %14s %14s %14s %14s\n", "sigma", "versor median", "versor p95", "umeyama median",
              "umeyama p95");
  for (double sigma : {0.0, 1e-4, 1e-3, 1e-2, 3e-2}) {
    const auto cs = make_corrs(2000, sigma, 7);
    const PairPoseOptions o = solver_options(sigma);
    PairPoseResult r;
    std::vector<double> ev, eu;
    for (const auto& c : cs) {
      ev.push_back(rot_err_deg(versor_solve(c, o, r), c.R));
      eu.push_back(rot_err_deg(umeyama_solve(c, false).topLeftCorner<3, 3>(), c.R));
    }
    std::sort(ev.begin(), ev.end());
    std::sort(eu.begin(), eu.end());
    auto q = [](const std::vector<double>& v, double f) { return v[static_cast<std::size_t>(f * (v.size() - 1))]; };
    std::printf("%-10g %14.3g %14.3g %14.3g %14.3g\n", sigma, q(ev, 0.5), q(ev, 0.95), q(eu, 0.5), q(eu, 0.95));
  }
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  Recorder rec;
  benchmark::RunSpecifiedBenchmarks(&rec);
  const auto v = rec.ns.find("BM_VersorSolve"), vf = rec.ns.find("BM_VersorSolveFullAgreement"), u1 = rec.ns.find("BM_UmeyamaOneOrder"),
             u2 = rec.ns.find("BM_UmeyamaBothOrders");
  if (v != rec.ns.end() && u1 != rec.ns.end() && u2 != rec.ns.end()) {
    std::printf("\nTime per correspondence (CPU): versor %.0f ns (both point orders, all candidates), "
                "umeyama %.0f ns one order / %.0f ns both orders\n",
                v->second, u1->second, u2->second);
    std::printf("Ratio umeyama/versor: %.2f (one order), %.2f (both orders)\n", u1->second / v->second,
                u2->second / v->second);
    if (vf != rec.ns.end())
      std::printf("Versor with min_agreement = 3 (as the Aligner uses it): %.0f ns, ratio umeyama (both orders) / "
                  "versor %.2f\n",
                  vf->second, u2->second / vf->second);
  }
  accuracy_table();
  benchmark::Shutdown();
  return 0;
}
