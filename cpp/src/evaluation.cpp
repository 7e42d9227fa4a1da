// Scoring a grasp (close, check, contacts, epsilon) and fine-tuning it by local random search.
#include <pairgrasp/evaluation.hpp>

#include "random_internal.hpp"
#include "thread_pool.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>

namespace pairgrasp {

using detail::uniform;
using detail::uniform01;
using detail::unit_vector;

TorqueReference torque_reference(const Mesh& mesh) {
  TorqueReference r;
  r.center = mesh.center_of_mass;
  for (Eigen::Index v = 0; v < mesh.vertices.rows(); ++v)
    r.radius = std::max(r.radius, (Eigen::Vector3d(mesh.vertices.row(v).transpose()) - r.center).norm());
  if (!r.center.allFinite() || !(r.radius > 0.0) || !std::isfinite(r.radius))
    throw std::invalid_argument("target: cannot derive the torque reference (centre of mass / vertex distance)");
  return r;
}

std::vector<int> reduce_contacts(const Points& points, const std::vector<int>& links, int per_link) {
  if (per_link < 1) throw std::invalid_argument("per_link: expected an integer >= 1, got " + std::to_string(per_link));
  if (links.size() != static_cast<std::size_t>(points.rows()))
    throw std::invalid_argument("links: expected " + std::to_string(points.rows()) + " link indices, got " +
                                std::to_string(links.size()));
  std::map<int, std::vector<int>> groups;  // per link, in order of first appearance is not needed
  for (std::size_t i = 0; i < links.size(); ++i) groups[links[i]].push_back(static_cast<int>(i));
  std::vector<int> keep;
  for (const auto& [link, idx] : groups) {
    if (static_cast<int>(idx.size()) <= per_link) {
      keep.insert(keep.end(), idx.begin(), idx.end());
      continue;
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i : idx) mean += points.row(i).transpose();
    mean /= static_cast<double>(idx.size());
    std::vector<double> d(idx.size());
    for (std::size_t k = 0; k < idx.size(); ++k) d[k] = (points.row(idx[k]).transpose() - mean).squaredNorm();
    for (int s = 0; s < per_link; ++s) {
      const std::size_t j = static_cast<std::size_t>(std::max_element(d.begin(), d.end()) - d.begin());
      keep.push_back(idx[j]);
      for (std::size_t k = 0; k < idx.size(); ++k)
        if (d[k] >= 0.0) d[k] = std::min(d[k], (points.row(idx[k]) - points.row(idx[j])).squaredNorm());
      d[j] = -1.0;
    }
  }
  std::sort(keep.begin(), keep.end());
  return keep;
}

std::pair<Points, Points> reduced_contacts(const Contacts& contacts, int per_link) {
  const std::vector<int> keep = reduce_contacts(contacts.points, contacts.links, per_link);
  std::pair<Points, Points> out{Points(static_cast<Eigen::Index>(keep.size()), 3),
                                Points(static_cast<Eigen::Index>(keep.size()), 3)};
  for (std::size_t i = 0; i < keep.size(); ++i) {
    out.first.row(static_cast<Eigen::Index>(i)) = contacts.points.row(keep[i]);
    out.second.row(static_cast<Eigen::Index>(i)) = contacts.normals.row(keep[i]);
  }
  return out;
}

namespace {

GraspEvaluation evaluate_checked(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                                 const EvaluateOptions& options, const TorqueReference& ref) {
  GraspEvaluation e;
  e.wrist = wrist;
  e.start_dofs = dofs;
  if (options.close) {
    CloseOptions co;
    co.measure = false;  // the start was checked by the caller, and the clearance is not reported
    CloseResult cr = close_fingers(checker, wrist, dofs, co);
    e.dofs = std::move(cr.dofs);
    e.check = std::move(cr.check);
    e.closing = std::move(cr.reasons);
  } else {
    e.dofs = dofs;
    e.check = checker.check(wrist, dofs);
  }
  e.contacts = find_contacts(checker, wrist, e.dofs);
  e.pruned = e.check.pruned;
  e.depth = e.check.depth;
  e.target_depth = e.check.target_depth;
  e.reason = e.check.reason;
  if (e.pruned) {
    e.quality.n_contacts = static_cast<int>(e.contacts.points.rows());
    e.quality.reason = "pruned: " + e.reason;
    e.quality.volume_exact = false;
    return e;
  }
  QualityOptions q = options.quality;
  Points points = e.contacts.points, normals = e.contacts.normals;
  if (options.contacts_per_link > 0 && points.rows() > 0) {
    // A search, which needs no hull volume of a grasp that is not force-closure.
    q.open_volume = false;
    std::tie(points, normals) = reduced_contacts(e.contacts, options.contacts_per_link);
  }
  if (options.score) {
    e.quality = grasp_quality(points, normals, ref.center, ref.radius, q);
  } else {
    e.quality.n_contacts = static_cast<int>(points.rows());
    e.quality.epsilon_bound = epsilon_upper_bound(wrench_matrix(points, normals, ref.center, ref.radius, q.contact));
    e.quality.epsilon_computed = false;
    e.quality.volume_exact = false;
    e.quality.reason = "not scored";
  }
  return e;
}

TorqueReference reference_of(const GraspChecker& checker, const EvaluateOptions& options) {
  return options.reference ? *options.reference : torque_reference(checker.target());
}

void check_options(const EvaluateOptions& options, const TorqueReference& ref) {
  if (options.contacts_per_link < 0)
    throw std::invalid_argument("contacts_per_link: expected an integer >= 1 (or 0 for every contact), got " +
                                std::to_string(options.contacts_per_link));
  // The quality options are checked once, before any closing (grasp_quality throws for bad ones).
  grasp_quality(Points(0, 3), Points(0, 3), ref.center, ref.radius, options.quality);
}

}  // namespace

GraspEvaluation evaluate_grasp(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                               const EvaluateOptions& options) {
  check_rigid(wrist, "wrist_pose");
  checker.hand().link_poses(dofs);  // "dofs: ..." for a bad vector
  const TorqueReference ref = reference_of(checker, options);
  check_options(options, ref);
  return evaluate_checked(checker, wrist, dofs, options, ref);
}

bool better_grasp(const GraspEvaluation& a, const GraspEvaluation& b) {
  if (a.pruned) return false;
  if (b.pruned) return true;
  return std::make_tuple(a.quality.force_closure, a.quality.epsilon, a.quality.volume) >
         std::make_tuple(b.quality.force_closure, b.quality.epsilon, b.quality.volume);
}

namespace {

/// fine_tune() from `start` when given (the evaluation of (wrist, dofs)), else from the start
/// closed and scored here.
FineTuneResult fine_tune_from(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                              const GraspEvaluation* start, const FineTuneOptions& options) {
  const Hand& hand = checker.hand();
  check_rigid(wrist, "wrist_pose");
  hand.link_poses(dofs);
  const Eigen::Index d = dofs.size();
  const Eigen::VectorXd steps = options.steps.size() ? options.steps : hand.dof_step();
  if (steps.size() != d)
    throw std::invalid_argument("step: expected " + std::to_string(d) + " values, got " + std::to_string(steps.size()));
  if (!steps.allFinite() || (steps.array() < 0.0).any()) throw std::invalid_argument("step: expected finite values >= 0");
  if (!std::isfinite(options.translation) || options.translation < 0.0)
    throw std::invalid_argument("translation: expected a finite length >= 0 (m), got " + std::to_string(options.translation));
  if (!std::isfinite(options.angle) || options.angle < 0.0)
    throw std::invalid_argument("angle: expected a finite angle >= 0 (rad), got " + std::to_string(options.angle));
  if (options.iterations < 0)
    throw std::invalid_argument("iterations: expected an integer >= 0, got " + std::to_string(options.iterations));
  EvaluateOptions eo = options.evaluate;
  eo.close = true;
  const TorqueReference ref = reference_of(checker, eo);
  eo.reference = ref;
  check_options(eo, ref);

  FineTuneResult out;
  out.start = start ? *start : evaluate_checked(checker, wrist, dofs, eo, ref);
  const Points& cp = out.start.contacts.points;
  const Eigen::Vector3d pivot = cp.rows() ? Eigen::Vector3d(cp.colwise().mean().transpose()) : wrist.translation();
  const Eigen::VectorXd lower = hand.dof_lower(), upper = hand.dof_upper();

  // Every trial is drawn first, in order, so that the result does not depend on the threads.
  std::mt19937_64 rng(options.seed);
  const int n = options.iterations;
  std::vector<Pose> poses(n);
  std::vector<Eigen::VectorXd> qs(n);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d dir = unit_vector(rng);
    const Eigen::Vector3d t = dir * options.translation * std::cbrt(uniform01(rng));
    const Eigen::Vector3d axis = unit_vector(rng);
    const Eigen::Matrix3d r = Eigen::AngleAxisd(uniform(rng, -options.angle, options.angle), axis).toRotationMatrix();
    Eigen::VectorXd q(d);
    for (Eigen::Index i = 0; i < d; ++i) q[i] = std::clamp(dofs[i] + uniform(rng, -0.5, 0.5) * steps[i], lower[i], upper[i]);
    Pose w = Pose::Identity();
    w.linear() = r * wrist.linear();
    w.translation() = r * (wrist.translation() - pivot) + pivot + t;
    poses[k] = w;
    qs[k] = std::move(q);
  }
  // A trial matters only if it beats the start: below the start's epsilon its hull is skipped
  // (its force closure and a lower bound of its epsilon, or the full hull, still decide it).
  if (!out.start.pruned && out.start.quality.force_closure && out.start.quality.epsilon_computed)
    eo.quality.min_epsilon = std::max(eo.quality.min_epsilon, out.start.quality.epsilon);
  // A trial that starts with a link penetrating stays pruned whatever the closing does (that link
  // never moves), so it is not closed.
  std::vector<GraspEvaluation> trials(n);
  detail::parallel_for(static_cast<std::size_t>(n), options.threads, [&](std::size_t k) {
    if (checker.penetrating(poses[k], hand.link_poses(qs[k]))) {
      trials[k].wrist = poses[k];
      trials[k].start_dofs = trials[k].dofs = qs[k];
      trials[k].pruned = true;
      trials[k].reason = "penetrating before closing";
      trials[k].quality.reason = "pruned: " + trials[k].reason;
      trials[k].quality.volume_exact = false;
      return;
    }
    trials[k] = evaluate_checked(checker, poses[k], qs[k], eo, ref);
  });

  const GraspEvaluation* best = out.start.pruned ? nullptr : &out.start;
  for (const GraspEvaluation& t : trials) {
    if (!t.pruned) ++out.kept;
    if (best == nullptr ? !t.pruned : better_grasp(t, *best)) {
      best = &t;
      ++out.improvements;
    }
  }
  out.trials = n;
  if (best) {
    out.improved = best != &out.start;
    out.best = *best;
  } else {
    out.reason = "start pruned (" + out.start.reason + ") and none of " + std::to_string(n) + " trials was unpruned";
  }
  return out;
}

}  // namespace

FineTuneResult fine_tune(const GraspChecker& checker, const Pose& wrist, const Eigen::VectorXd& dofs,
                         const FineTuneOptions& options) {
  return fine_tune_from(checker, wrist, dofs, nullptr, options);
}

FineTuneResult fine_tune(const GraspChecker& checker, const GraspEvaluation& start, const FineTuneOptions& options) {
  if (!start.quality.epsilon_computed)
    throw std::invalid_argument("start: its epsilon is a bound, not computed (a search skipped its hull)");
  return fine_tune_from(checker, start.wrist, start.start_dofs, &start, options);
}

}  // namespace pairgrasp
