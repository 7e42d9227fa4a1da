// Robust grasp quality: force closure and epsilon under sampled wrist and friction perturbations.
#include <pairgrasp/robust.hpp>

#include "random_internal.hpp"
#include "thread_pool.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pairgrasp {

namespace {

// Backing off a perturbed start pose that penetrates: 0.5 mm steps along the approach axis, at most
// 3 mm (three standard deviations of the default wrist offset).
constexpr int kBackoffSteps = 6;
constexpr double kBackoffStep = 0.0005;

void check_robust(const RobustOptions& o, double mu) {
  if (o.samples < 1) throw std::invalid_argument("samples: expected an integer >= 1, got " + std::to_string(o.samples));
  auto finite = [](const char* name, double v, double lo, double hi) {
    if (!std::isfinite(v) || v < lo || v > hi)
      throw std::invalid_argument(std::string(name) + ": expected a finite number in [" + std::to_string(lo) + ", " +
                                  std::to_string(hi) + "], got " + std::to_string(v));
  };
  finite("translation_sigma", o.translation_sigma, 0.0, 1e3);
  finite("rotation_sigma", o.rotation_sigma, 0.0, 3.14159265358979323846);
  finite("friction_spread", o.friction_spread, 0.0, 1.0);
  finite("quantile", o.quantile, 0.0, 1.0);
  finite("mu", mu, 0.0, 1e6);
}

}  // namespace

std::vector<Pose> robust_perturbations(const Pose& wrist, double mu, const RobustOptions& options,
                                       std::vector<double>& frictions) {
  check_rigid(wrist, "wrist_pose");
  check_robust(options, mu);
  std::mt19937_64 rng(options.seed);
  std::vector<Pose> poses(static_cast<std::size_t>(options.samples));
  frictions.assign(poses.size(), mu);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const Eigen::Vector3d axis = detail::unit_vector(rng);
    const double angle = options.rotation_sigma * detail::normal(rng);
    Eigen::Vector3d t;
    for (int a = 0; a < 3; ++a) t[a] = options.translation_sigma * detail::normal(rng);
    frictions[k] = mu * detail::uniform(rng, 1.0 - options.friction_spread, 1.0 + options.friction_spread);
    Pose p = Pose::Identity();
    p.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix() * wrist.linear();
    p.translation() = wrist.translation() + t;
    poses[k] = p;
  }
  return poses;
}

RobustQuality robust_quality(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& start_dofs,
                             const RobustOptions& options) {
  checker.hand().link_poses(start_dofs);  // "dofs: ..." for a bad vector
  std::vector<double> mus;
  const std::vector<Pose> poses = robust_perturbations(wrist, options.evaluate.quality.contact.mu, options, mus);
  EvaluateOptions eo = options.evaluate;
  eo.close = true;
  if (!eo.reference) eo.reference = torque_reference(checker.target());
  if (eo.contacts_per_link < 0)
    throw std::invalid_argument("contacts_per_link: expected an integer >= 0, got " + std::to_string(eo.contacts_per_link));
  // Bad quality options throw here, before any sample is closed.
  grasp_quality(Points(0, 3), Points(0, 3), eo.reference->center, eo.reference->radius, eo.quality);
  const std::size_t n = poses.size();
  const Eigen::Vector3d approach = checker.hand().approach();
  const std::vector<Pose> links = checker.hand().link_poses(start_dofs, true);
  std::vector<GraspQuality> q(n);
  std::vector<char> pruned(n, 0), backed(n, 0);
  detail::parallel_for(n, options.threads, [&](std::size_t k) {
    // A perturbed hand that would start inside the target stops where it first touches on its way in.
    Pose w = poses[k];
    bool clear = !checker.pruned(w, links);
    for (int i = 0; i < kBackoffSteps && !clear; ++i) {
      w.translation() -= kBackoffStep * (w.linear() * approach);
      backed[k] = 1;
      if (i + 1 < kBackoffSteps) clear = !checker.pruned(w, links);
    }
    // Still penetrating: pruned after closing too (a penetrating link never moves), so not closed.
    if (!clear && checker.penetrating(w, links)) {
      pruned[k] = 1;
      return;
    }
    EvaluateOptions ek = eo;
    ek.quality.contact.mu = mus[k];
    const GraspEvaluation e = evaluate_grasp(checker, w, start_dofs, ek);
    pruned[k] = e.pruned;
    q[k] = e.quality;
  });
  RobustQuality out;
  out.samples = static_cast<int>(n);
  out.epsilons.assign(n, 0.0);
  int closed = 0;
  double sum = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    out.pruned += pruned[k];
    out.backed_off += backed[k];
    out.epsilons[k] = pruned[k] ? 0.0 : q[k].epsilon;
    closed += !pruned[k] && q[k].force_closure ? 1 : 0;
    sum += out.epsilons[k];
  }
  out.force_closure_probability = static_cast<double>(closed) / static_cast<double>(n);
  out.mean_epsilon = sum / static_cast<double>(n);
  std::vector<double> sorted = out.epsilons;
  const auto k = static_cast<std::size_t>(std::floor(options.quantile * static_cast<double>(n - 1)));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(k), sorted.end());
  out.epsilon = sorted[k];
  return out;
}

}  // namespace pairgrasp
