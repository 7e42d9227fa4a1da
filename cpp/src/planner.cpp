// GraspPlanner (parameters, index, aligner, checker) and plan_samples (align -> pipeline -> grasps).
#include <pairgrasp/planner.hpp>

#include <pairgrasp/error.hpp>
#include <pairgrasp/features.hpp>
#include <pairgrasp/graspable.hpp>

#include "pair_index_internal.hpp"
#include "thread_pool.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>

namespace pairgrasp {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void check_value(const char* name, const std::optional<double>& v, bool zero_ok) {
  if (v && (!std::isfinite(*v) || *v < 0.0 || (!zero_ok && *v == 0.0)))
    throw std::invalid_argument(std::string(name) + ": expected a finite length " + (zero_ok ? ">= 0" : "> 0") +
                                " (m), got " + std::to_string(*v));
}

// Every combination of one value per axis, the last axis varying fastest.
std::vector<Eigen::VectorXd> cartesian(const std::vector<std::vector<double>>& axes) {
  std::vector<Eigen::VectorXd> out;
  std::vector<std::size_t> idx(axes.size(), 0);
  for (;;) {
    Eigen::VectorXd q(static_cast<Eigen::Index>(axes.size()));
    for (std::size_t d = 0; d < axes.size(); ++d) q[static_cast<Eigen::Index>(d)] = axes[d][idx[d]];
    out.push_back(q);
    std::size_t d = axes.size();
    while (d > 0 && ++idx[d - 1] == axes[d - 1].size()) idx[--d] = 0;
    if (d == 0) return out;
  }
}

// Every DOF at its lower limit, middle and upper limit (one value when the range is empty).
std::vector<Eigen::VectorXd> corner_samples(const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
  std::vector<std::vector<double>> axes;
  for (Eigen::Index d = 0; d < lo.size(); ++d) {
    std::vector<double> v{lo[d], (lo[d] + hi[d]) / 2.0, hi[d]};
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    axes.push_back(v);
  }
  return cartesian(axes);
}

double largest_span(const Points& p) {
  double s = 0.0;
  for (Eigen::Index i = 0; i < p.rows(); ++i)
    for (Eigen::Index j = i + 1; j < p.rows(); ++j) s = std::max(s, (p.row(i) - p.row(j)).squaredNorm());
  return std::sqrt(s);
}

// Whether per-link samples i and j have their normals along the line joining them.
bool antipodal_pair(const Constellation& c, Eigen::Index i, Eigen::Index j) {
  Eigen::Vector3d d = (c.points.row(j) - c.points.row(i)).transpose();
  const double n = d.norm();
  if (n < 1e-9) return true;
  d /= n;
  return std::abs(c.normals.row(i).dot(d)) >= 0.95 && std::abs(c.normals.row(j).dot(d)) >= 0.95;
}

// A parallel jaw: two per-link samples (at mid-range) whose normals face each other along the line.
bool is_jaw(const Constellation& c) {
  if (c.points.rows() != 2) return false;
  const Eigen::Vector3d d = (c.points.row(1) - c.points.row(0)).transpose();
  return d.norm() > 1e-9 && c.normals.row(0).dot(d.normalized()) >= 0.95 && -c.normals.row(1).dot(d.normalized()) >= 0.95;
}

// (mode, antipodal): see ConstellationChoice.
std::pair<ConstellationMode, bool> choose_mode(const Hand& hand, ConstellationChoice choice) {
  if (choice == ConstellationChoice::PerLink) return {ConstellationMode::PerLink, false};
  if (choice == ConstellationChoice::Area) return {ConstellationMode::Area, false};
  const Eigen::VectorXd mid = (hand.dof_lower() + hand.dof_upper()) / 2.0;
  const Constellation c = hand.constellation(mid, ConstellationMode::PerLink);
  if (choice == ConstellationChoice::Antipodal) {
    if (!is_jaw(c))
      throw std::invalid_argument("constellation: 'antipodal' needs a parallel jaw (two active links whose samples "
                                  "face each other); hand " + hand.name() + " has " + std::to_string(c.points.rows()) +
                                  " per-link samples" + (c.points.rows() == 2 ? " that do not face each other" : ""));
    return {ConstellationMode::PerLink, true};
  }
  if (is_jaw(c)) return {ConstellationMode::PerLink, true};
  if (c.points.rows() < 3) return {ConstellationMode::Area, false};
  for (Eigen::Index i = 0; i < c.points.rows(); ++i)
    for (Eigen::Index j = i + 1; j < c.points.rows(); ++j)
      if (!antipodal_pair(c, i, j)) return {ConstellationMode::PerLink, false};
  return {ConstellationMode::Area, false};
}

// Refuses a target whose checker fields would take more than `budget` bytes (an estimate, before
// anything is built): one line naming the budget and the options that change it.
void check_field_estimate(const Mesh& target, const Mask& free, const CheckOptions& co, std::size_t budget) {
  const std::size_t bytes = estimate_field_bytes(target, free, co);
  if (bytes <= budget) return;
  char buf[640];
  std::snprintf(buf, sizeof buf,
                "%s: the grasp checker's distance fields at a cell of %.3g mm would take about %.2g GB, over the "
                "budget of %.2g GB (max_field_memory in GB, CLI --max-field-memory; C++ max_field_bytes); a coarser "
                "field_cell (--field-cell) or unit-facet edge (--edge) fits, or a larger budget",
                target.source.empty() ? "target" : target.source.c_str(), co.field_cell * 1e3,
                static_cast<double>(bytes) / 1e9, static_cast<double>(budget) / 1e9);
  throw BudgetError(buf);
}

}  // namespace

double hand_span(const Hand& hand) {
  double span = 0.0;
  for (const Eigen::VectorXd& q : corner_samples(hand.dof_lower(), hand.dof_upper()))
    span = std::max(span, largest_span(hand.constellation(q, ConstellationMode::PerLink).points));
  return span;
}

double suggest_target_scale(const Mesh& target, double hand_span) {
  if (!target.vertices.rows() || !(hand_span > 0.0)) return 1.0;
  const double largest = (target.vertices.colwise().maxCoeff() - target.vertices.colwise().minCoeff()).maxCoeff();
  if (!(largest > 0.0)) return 1.0;
  // The power of ten that brings the largest extent nearest (in ratio) to the hand's span.
  return std::pow(10.0, std::round(std::log10(hand_span / largest)));
}

void check_target_scale(const Mesh& target, double hand_span) {
  // A hand grasps a part of an object at most about its own size: an object whose every extent is
  // 50 times the hand's span (or whose largest is 200 times smaller) is at the wrong scale.
  if (!target.vertices.rows()) return;
  const Eigen::Vector3d extent = (target.vertices.colwise().maxCoeff() - target.vertices.colwise().minCoeff()).transpose();
  const double smallest = extent.minCoeff(), largest = extent.maxCoeff();
  const std::string name = target.source.empty() ? "target" : target.source;
  const double fix = suggest_target_scale(target, hand_span);
  char buf[512];
  if (smallest > 50.0 * hand_span) {
    std::snprintf(buf, sizeof buf,
                  "%s: every extent of the target is at least %.4g m, %.0f times the hand's span of %.3g m; is the "
                  "mesh in %s? Load it with scale=%g (CLI: --scale %g), which makes it %.3g m across",
                  name.c_str(), smallest, smallest / hand_span, hand_span,
                  fix == 1e-3 ? "millimetres" : fix == 1e-2 ? "centimetres" : "other units", fix, fix, largest * fix);
    throw std::invalid_argument(buf);
  }
  if (largest < hand_span / 200.0) {
    std::snprintf(buf, sizeof buf,
                  "%s: the target is at most %.4g m across, 1/%.0f of the hand's span of %.3g m; is it scaled twice? "
                  "Lengths are metres: scale=%g (CLI: --scale %g) makes it %.3g m across",
                  name.c_str(), largest, hand_span / largest, hand_span, fix, fix, largest * fix);
    throw std::invalid_argument(buf);
  }
}

std::vector<std::vector<double>> dof_axes(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                          const Eigen::VectorXd& steps) {
  if (lower.size() != upper.size() || steps.size() != lower.size())
    throw std::invalid_argument("steps: expected " + std::to_string(lower.size()) + " values, got " +
                                std::to_string(steps.size()));
  std::vector<std::vector<double>> out;
  for (Eigen::Index d = 0; d < lower.size(); ++d) {
    const double lo = lower[d], hi = upper[d], st = steps[d];
    if (hi - lo <= 1e-12 || !(st > 0.0)) {
      out.push_back({lo});
      continue;
    }
    const long n = static_cast<long>(std::floor((hi - lo) / st + 1e-9));
    std::vector<double> v;
    for (long k = 0; k <= n; ++k) v.push_back(lo + st * static_cast<double>(k));
    if (hi - v.back() > 1e-9 * std::max(1.0, std::abs(hi))) v.push_back(hi);
    out.push_back(std::move(v));
  }
  return out;
}

std::vector<Eigen::VectorXd> dof_grid(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                      const Eigen::VectorXd& steps) {
  return cartesian(dof_axes(lower, upper, steps));
}

double finest_edge(const Mesh& target) {
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();
  if (target.vertices.rows())
    extent = (target.vertices.colwise().maxCoeff() - target.vertices.colwise().minCoeff()).transpose();
  return extent.minCoeff() > 0.0 ? std::min(0.005, extent.minCoeff() / 15.0) : 0.005;
}

void validate(const PlannerOptions& o) {
  check_value("edge", o.edge, false);
  check_value("d_max", o.d_max, false);
  check_value("spacing", o.spacing, false);
  check_value("depth_tolerance", o.depth_tolerance, true);
  check_value("gap", o.gap, true);
  check_value("backoff", o.backoff, true);
  check_value("field_cell", o.field_cell, false);
  if (!(o.mu >= 0.0) || !std::isfinite(o.mu))
    throw std::invalid_argument("mu: expected a finite number >= 0, got " + std::to_string(o.mu));
  if (o.max_pairs < 1) throw std::invalid_argument("max_pairs: expected an integer >= 1, got 0");
  if (o.max_field_bytes < 1) throw std::invalid_argument("max_field_bytes: expected an integer >= 1, got 0");
  if (o.max_area_samples < 3)
    throw std::invalid_argument("max_area_samples: expected an integer >= 3, got " + std::to_string(o.max_area_samples));
  if (o.threads < 0) throw std::invalid_argument("threads: expected an integer >= 0, got " + std::to_string(o.threads));
}

namespace {

// The diagonal of the active surfaces' bounding box in the wrist frame, largest over `samples`:
// no two contacts of a grasp are farther apart (to the DOF sampling).
double contact_span(const Hand& hand, const std::vector<Eigen::VectorXd>& samples) {
  double span = 0.0;
  for (const Eigen::VectorXd& q : samples) {
    const std::vector<Pose> poses = hand.link_poses(q);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
    for (std::size_t l = 0; l < hand.links().size(); ++l) {
      const HandLink& link = hand.links()[l];
      for (int f : link.active_faces)
        for (int k = 0; k < 3; ++k) {
          const Eigen::Vector3d p = poses[l] * link.mesh.vertices.row(link.mesh.faces(f, k)).transpose();
          lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
        }
    }
    if ((hi - lo).allFinite()) span = std::max(span, (hi - lo).norm());
  }
  return span;
}

std::string degrees(double radians) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0f", radians * 180.0 / 3.14159265358979323846);
  return buf;
}

// resolve_planner(), and in `index_free` the faces whose unit facets the index pairs: the free
// faces that may hold a contact of a force-closure grasp (`free` itself when they all may); in
// `facets` (when not null) the unit facets at the edge suggested, when suggesting made them.
PlannerSetup resolve(const Hand& hand, const Mesh& target, const Mask& free, const PlannerOptions& o, Mask& index_free,
                     std::optional<UnitFacets>* facets = nullptr) {
  validate(o);
  PlannerSetup s;
  std::tie(s.mode, s.antipodal) = choose_mode(hand, o.constellation);
  const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper(), mid = (lo + hi) / 2.0;
  double edge = o.edge ? *o.edge : finest_edge(target);
  const std::vector<Eigen::VectorXd> corners = corner_samples(lo, hi);
  if (o.d_max) {
    s.d_max = *o.d_max;
  } else {
    double span = 0.0;
    for (const Eigen::VectorXd& q : corners) {
      const Points p = s.mode == ConstellationMode::Area
                           ? hand.constellation(q, ConstellationMode::Area, std::max(edge, 0.005)).points
                           : hand.constellation(q, ConstellationMode::PerLink).points;
      span = std::max(span, largest_span(p));
    }
    if (!(span > 0.0))
      throw std::invalid_argument("hand " + hand.name() + ": its active surfaces give no two distinct samples");
    s.d_max = span + edge;
  }
  check_target_scale(target, s.d_max);
  s.contact_span = contact_span(hand, corners) + edge;
  const GraspableFaces g = graspable_faces(target, free, s.contact_span, o.mu, o.threads);
  s.free_faces = g.free;
  s.graspable_faces = g.graspable;
  if (g.free > 0 && g.graspable == 0) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%.3g m (the hand's contact span) with friction mu = %.3g", s.contact_span, o.mu);
    throw std::invalid_argument(
        (target.source.empty() ? std::string("target") : target.source) +
        ": no part of the free surface can hold a force-closure grasp within " + buf +
        ": near every point, the surface's inward normals lie within " + degrees(g.widest_cone) +
        " degrees of one direction, and contact forces that oppose each other need them spread beyond " +
        degrees(0.5 * 3.14159265358979323846 - std::atan(o.mu)) +
        " degrees (surfaces that could oppose each other are farther apart than the hand spans); a larger hand, a "
        "smaller target or more of it free, or a larger mu");
  }
  index_free = g.graspable == g.free ? free : g.faces;
  if (!o.edge) edge = detail::suggest_edge(target, s.d_max, o.max_pairs, index_free, edge, facets);
  s.edge = edge;
  if (s.mode == ConstellationMode::Area) {
    if (o.spacing) {
      s.spacing = *o.spacing;
    } else {
      double sp = s.edge;
      for (int k = 0; k < 40; ++k) {
        if (hand.constellation(mid, ConstellationMode::Area, sp).points.rows() <= o.max_area_samples) break;
        sp *= 1.25;
      }
      s.spacing = sp;
    }
  }
  for (const Eigen::VectorXd& q : corners) {
    const Points p = hand.constellation(q, ConstellationMode::PerLink).points;
    for (Eigen::Index i = 0; i < p.rows(); ++i) s.reach = std::max(s.reach, p.row(i).norm());
  }
  s.depth_tolerance = o.depth_tolerance ? *o.depth_tolerance : s.edge / 4.0;
  s.backoff = o.backoff ? *o.backoff : s.reach / 2.0;
  // h / 5, not finer than 1 mm: coarser fields for coarse (large) targets, and below h = 5 mm the
  // cell every plan used before the cell followed h (a finer one costs memory and moved grasps).
  s.field_cell = o.field_cell ? *o.field_cell : std::max(s.edge / 5.0, 0.001);
  // The fields pay for themselves over many checks: a per-link search settles thousands of aligned
  // poses (the demo's 3,396), a jaw's antipodal search a few hundred at most, which the exact
  // queries check in less time than building the target's fields takes.
  s.distance_fields = !s.antipodal;
  return s;
}

}  // namespace

PlannerSetup resolve_planner(const Hand& hand, const Mesh& target, const Mask& free, const PlannerOptions& o) {
  Mask index_free;
  return resolve(hand, target, free, o, index_free);
}

struct GraspPlanner::State {
  State(const Hand& h, FreeSurface f, std::vector<Obstacle> obs, const PlannerOptions& o, const PlannerSetup& s,
        TargetIndex i)
      : hand(h), surface(std::move(f)), obstacles(std::move(obs)), options(o), setup(s), index(std::move(i)) {}
  Hand hand;
  FreeSurface surface;
  std::vector<Obstacle> obstacles;
  PlannerOptions options;
  PlannerSetup setup;
  TargetIndex index;
  std::unique_ptr<Aligner> aligner;
  std::unique_ptr<GraspChecker> checker;
  TorqueReference reference;
  double seconds = 0.0;
};

namespace {
Scene paint_scene(const Mask& free, const std::vector<Obstacle>& obstacles) {
  Scene s;
  s.occlusion.paint = free;
  s.obstacles = obstacles;
  return s;
}
}  // namespace

GraspPlanner::GraspPlanner(const Hand& hand, const Mesh& target, const Mask& free,
                           const std::vector<Obstacle>& obstacles, const PlannerOptions& options)
    : GraspPlanner(hand, target, paint_scene(free, obstacles), options) {}

GraspPlanner::GraspPlanner(const Hand& hand, const Mesh& given, const Scene& scene, const PlannerOptions& options) {
  const auto t0 = Clock::now();
  validate(options);
  // The free surface at half the finest edge: the budget only makes the edge coarser, never finer.
  FreeSurface surface = pairgrasp::free_surface(
      given, scene.occlusion, 0.5 * (options.edge ? *options.edge : finest_edge(given)), options.threads);
  const Mesh& target = surface.mesh;
  const Mask& free = surface.free;
  Mask index_free;
  std::optional<UnitFacets> facets;  // the index's, when suggesting the edge made them
  const PlannerSetup setup = resolve(hand, target, free, options, index_free, &facets);
  std::vector<Obstacle> obstacles = scene.obstacles;
  if (scene.occlusion.support)
    obstacles.push_back(Obstacle{"support", support_box(*scene.occlusion.support, target,
                                                        2.0 * setup.reach + setup.backoff + setup.edge)});
  PairIndexOptions io;
  io.d_max = setup.d_max;
  io.max_pairs = options.max_pairs;
  io.max_pairs_per_cell = options.max_pairs_per_cell;
  io.threads = options.threads;
  // A jaw's antipodal alignment reads only pairs whose normals are opposed within twice its cone
  // (both within the cone of their line): the others are not stored.
  if (setup.antipodal) io.max_normal_dot = -std::cos(2.0 * kDefaultAntipodalCone) + 1e-6;
  CheckOptions co;
  co.depth_tolerance = setup.depth_tolerance;
  co.contact_gap = options.gap;
  co.field_cell = setup.field_cell;
  co.use_distance_field = setup.distance_fields;
  co.threads = options.threads;
  // Settling lifts the hand out of the support: the plane given, else the top of an obstacle the
  // target stands on (a table given as a mesh).
  co.support = scene.occlusion.support;
  for (std::size_t i = 0; !co.support && i < obstacles.size(); ++i)
    co.support = SupportPlane::under(target, obstacles[i].mesh, scene.occlusion.distance);
  // An edge far over the pair budget is refused before anything is built: the checker's fields are
  // sized by the same edge (its depth tolerance), and at a tiny edge they alone take minutes.
  check_pair_estimate(target, setup.edge, index_free, io);
  check_field_estimate(target, free, co, options.max_field_bytes);
  // The pair index and the checker's fields are built at once; an error of the index is reported
  // first, whichever finished first.
  std::optional<TargetIndex> index;
  std::unique_ptr<GraspChecker> checker;
  std::exception_ptr errors[2];
  detail::parallel_for(2, options.threads, [&](std::size_t k) {
    try {
      if (k == 0) {
        index.emplace(detail::build_target_index(target, setup.edge, index_free, io, std::move(facets)));
      } else {
        checker = std::make_unique<GraspChecker>(hand, surface, given, obstacles, co);
      }
    } catch (...) {
      errors[k] = std::current_exception();
    }
  });
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  auto s = std::make_shared<State>(hand, std::move(surface), std::move(obstacles), options, setup, std::move(*index));
  AlignerOptions ao;
  ao.threads = options.threads;
  s->aligner = std::make_unique<Aligner>(s->index.index, ao);
  s->checker = std::move(checker);
  s->reference = torque_reference(s->surface.mesh);
  s->seconds = seconds_since(t0);
  state_ = std::move(s);
}

const Hand& GraspPlanner::hand() const { return state_->hand; }
const Mesh& GraspPlanner::target() const { return state_->surface.mesh; }
const Mask& GraspPlanner::free() const { return state_->surface.free; }
const FreeSurface& GraspPlanner::free_surface() const { return state_->surface; }
const std::vector<Obstacle>& GraspPlanner::obstacles() const { return state_->obstacles; }
const PlannerSetup& GraspPlanner::setup() const { return state_->setup; }
const PlannerOptions& GraspPlanner::options() const { return state_->options; }
const TargetIndex& GraspPlanner::target_index() const { return state_->index; }
const Aligner& GraspPlanner::aligner() const { return *state_->aligner; }
const GraspChecker& GraspPlanner::checker() const { return *state_->checker; }
const TorqueReference& GraspPlanner::reference() const { return state_->reference; }
double GraspPlanner::setup_seconds() const { return state_->seconds; }

Eigen::VectorXd GraspPlanner::steps(double step) const {
  Eigen::VectorXd out = state_->hand.dof_step();
  const auto& dofs = state_->hand.dofs();
  if (step > 0.0)
    for (std::size_t d = 0; d < dofs.size(); ++d)
      if (!dofs[d].linear) out[static_cast<Eigen::Index>(d)] = step;
  return out;
}

Constellation GraspPlanner::constellation(const Eigen::VectorXd& dofs) const {
  const PlannerSetup& s = state_->setup;
  return s.mode == ConstellationMode::Area ? state_->hand.constellation(dofs, ConstellationMode::Area, s.spacing)
                                           : state_->hand.constellation(dofs, ConstellationMode::PerLink);
}

std::vector<AlignResult> GraspPlanner::align(const std::vector<Eigen::VectorXd>& samples, int max_poses) const {
  std::vector<Constellation> cons;
  cons.reserve(samples.size());
  for (const Eigen::VectorXd& q : samples) cons.push_back(constellation(q));
  return state_->setup.antipodal ? state_->aligner->align_antipodal_many(cons, max_poses)
                                 : state_->aligner->align_many(cons, max_poses);
}

std::vector<double> GraspPlanner::match_fractions(const std::vector<Eigen::VectorXd>& samples) const {
  for (const Eigen::VectorXd& q : samples) state_->hand.link_poses(q);  // "dofs: ..." before any work
  const PairIndex& index = state_->index.index;
  const Eigen::Vector3d tolerance = state_->aligner->options().feature_tolerance;
  const double d_max = state_->setup.d_max;
  std::vector<double> out(samples.size(), 0.0);
  detail::parallel_for(samples.size(), state_->options.threads, [&](std::size_t k) {
    const Constellation c = constellation(samples[k]);
    const Eigen::Index n = c.points.rows();
    if (n < 2) return;
    if (state_->setup.antipodal) {  // a jaw: whether it can close on any antipodal pair
      out[k] = state_->aligner->antipodal_count(c.points, c.normals) > 0 ? 1.0 : 0.0;
      return;
    }
    long matched = 0;
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = i + 1; j < n; ++j) {
        const Eigen::Vector3d f = pair_feature(c.points.row(i).transpose(), -c.normals.row(i).transpose(),
                                               c.points.row(j).transpose(), -c.normals.row(j).transpose());
        if (f[0] <= d_max && index.count(f, tolerance) > 0) ++matched;
      }
    out[k] = static_cast<double>(matched) / static_cast<double>(n * (n - 1) / 2);
  });
  return out;
}

}  // namespace pairgrasp
