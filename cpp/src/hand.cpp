// pairgrasp::Hand: accessors, forward kinematics and active-surface constellations.
#include "hand_impl.hpp"
#include "surface_query_internal.hpp"

#include <pairgrasp/error.hpp>
#include <pairgrasp/facets.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace pairgrasp {

namespace hand_detail {

LinkSample per_link_sample(const Mesh& mesh, const std::vector<int>& faces) {
  auto corner = [&](int f, int k) -> Eigen::Vector3d { return mesh.vertices.row(mesh.faces(f, k)).transpose(); };
  double total = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero(), normal_sum = Eigen::Vector3d::Zero();
  for (int f : faces) {
    const double a = mesh.face_area(f);
    total += a;
    centroid += a * (corner(f, 0) + corner(f, 1) + corner(f, 2)) / 3.0;
    normal_sum += a * mesh.face_normal(f);
  }
  centroid /= total;
  LinkSample s;
  double best = std::numeric_limits<double>::infinity();
  int best_face = faces.front();
  for (int f : faces) {
    const Eigen::Vector3d q = geometry_detail::closest_on_triangle(centroid, corner(f, 0), corner(f, 1), corner(f, 2));
    const double d = (q - centroid).squaredNorm();
    if (d < best) best = d, s.point = q, best_face = f;
  }
  // The mean normal vanishes when the active faces face every way (a closed tube, a sphere).
  s.normal = normal_sum.norm() > 1e-6 * total ? normal_sum.normalized() : mesh.face_normal(best_face);
  return s;
}

}  // namespace hand_detail

namespace {

std::string num(double x) {
  std::ostringstream ss;
  ss.precision(10);
  ss << x;
  return ss.str();
}

Eigen::Isometry3d joint_motion(const hand_detail::KJoint& j, double q) {
  Eigen::Isometry3d M = Eigen::Isometry3d::Identity();
  switch (j.type) {
    case hand_detail::KJoint::Revolute:
    case hand_detail::KJoint::Continuous:
      M.linear() = Eigen::AngleAxisd(q, j.axis).toRotationMatrix();
      break;
    case hand_detail::KJoint::Prismatic:
      M.translation() = q * j.axis;
      break;
    case hand_detail::KJoint::Fixed:
      break;
  }
  return M;
}

}  // namespace

// ------------------------------------------------------------------------------ Impl

Eigen::VectorXd Hand::Impl::checked_dofs(const Eigen::VectorXd& dofs_in, bool clamp) const {
  detail::check_size("dofs", static_cast<long>(dofs.size()), static_cast<long>(dofs_in.size()));
  Eigen::VectorXd out = dofs_in;
  constexpr double eps = 1e-9;
  for (std::size_t i = 0; i < dofs.size(); ++i) {
    const Dof& d = dofs[i];
    double& v = out[static_cast<Eigen::Index>(i)];
    const bool finite = std::isfinite(v);
    if (!finite || (!clamp && (v < d.lower - eps || v > d.upper + eps))) {  // messages built only here
      const std::string unit = d.linear ? " m" : " rad";
      const std::string limits = "[" + num(d.lower) + ", " + num(d.upper) + "]" + unit;
      const std::string what = "dofs[" + std::to_string(i) + "] ('" + d.name + "'): value " + num(v);
      throw std::invalid_argument(finite ? what + unit + " is outside its limits " + limits
                                         : what + " is not finite (limits " + limits + ")");
    }
    v = std::clamp(v, d.lower, d.upper);
  }
  return out;
}

Eigen::VectorXd Hand::Impl::joint_values(const Eigen::VectorXd& checked) const {
  Eigen::VectorXd q(static_cast<Eigen::Index>(drives.size()));
  for (std::size_t v = 0; v < drives.size(); ++v)
    q[static_cast<Eigen::Index>(v)] = drives[v].ratio * checked[drives[v].dof] + drives[v].offset;
  return q;
}

std::vector<Pose> Hand::Impl::root_poses(const Eigen::VectorXd& q) const {
  std::vector<Pose> T(model.links.size(), Pose::Identity());
  for (std::size_t li = 1; li < model.links.size(); ++li) {  // parents come first
    const hand_detail::KJoint& j = model.joints[model.links[li].parent_joint];
    const double value = j.value_index >= 0 ? q[j.value_index] : 0.0;
    T[li] = T[j.parent] * j.origin * joint_motion(j, value);
  }
  return T;
}

std::shared_ptr<const hand_detail::AreaSamples> Hand::Impl::area_samples(double spacing) const {
  std::lock_guard<std::mutex> lock(cache_mutex);
  auto it = area_cache.find(spacing);
  if (it != area_cache.end()) return it->second;

  auto samples = std::make_shared<hand_detail::AreaSamples>();
  const long budget = std::max<long>(1, 2'000'000 / std::max<long>(1, static_cast<long>(per_link.size())));
  for (const hand_detail::LinkSample& pl : per_link) {
    const HandLink& link = model.geometry[pl.link];
    // The active faces as a mesh of their own, link frame, as authored (no re-orientation).
    std::vector<int> remap(static_cast<std::size_t>(link.mesh.vertices.rows()), -1);
    Triangles F(static_cast<Eigen::Index>(link.active_faces.size()), 3);
    std::vector<int> used;
    for (std::size_t k = 0; k < link.active_faces.size(); ++k)
      for (int c = 0; c < 3; ++c) {
        const int v = link.mesh.faces(link.active_faces[k], c);
        if (remap[v] < 0) remap[v] = static_cast<int>(used.size()), used.push_back(v);
        F(static_cast<Eigen::Index>(k), c) = remap[v];
      }
    Points V(static_cast<Eigen::Index>(used.size()), 3);
    for (std::size_t i = 0; i < used.size(); ++i) V.row(static_cast<Eigen::Index>(i)) = link.mesh.vertices.row(used[i]);
    MeshLoadOptions opt;
    opt.orient = false;
    const Mesh sub = make_mesh(V, F, link.name + " active surface", opt);
    UnitFacets facets;
    try {
      facets = tessellate(sub, spacing, Mask(), budget);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("spacing: ") + e.what() + " (active surface of link '" +
                                  link.name + "')");
    }
    samples->link.push_back(pl.link);
    samples->points.push_back(std::move(facets.points));
    samples->normals.push_back(std::move(facets.normals));
  }
  if (area_cache.size() >= kMaxCachedSpacings) {
    area_cache.erase(cache_order.front());
    cache_order.erase(cache_order.begin());
  }
  area_cache.emplace(spacing, samples);
  cache_order.push_back(spacing);
  return samples;
}

// ------------------------------------------------------------------------------ Hand

const std::string& Hand::name() const { return impl_->name; }
const std::string& Hand::spec_path() const { return impl_->spec_path; }
const std::string& Hand::urdf_path() const { return impl_->model.urdf_path; }
const std::vector<Dof>& Hand::dofs() const { return impl_->dofs; }

std::vector<std::string> Hand::dof_names() const {
  std::vector<std::string> out;
  for (const Dof& d : impl_->dofs) out.push_back(d.name);
  return out;
}

Eigen::VectorXd Hand::dof_lower() const {
  Eigen::VectorXd v(static_cast<Eigen::Index>(impl_->dofs.size()));
  for (std::size_t i = 0; i < impl_->dofs.size(); ++i) v[static_cast<Eigen::Index>(i)] = impl_->dofs[i].lower;
  return v;
}

Eigen::VectorXd Hand::dof_upper() const {
  Eigen::VectorXd v(static_cast<Eigen::Index>(impl_->dofs.size()));
  for (std::size_t i = 0; i < impl_->dofs.size(); ++i) v[static_cast<Eigen::Index>(i)] = impl_->dofs[i].upper;
  return v;
}

Eigen::VectorXd Hand::dof_step() const {
  Eigen::VectorXd v(static_cast<Eigen::Index>(impl_->dofs.size()));
  for (std::size_t i = 0; i < impl_->dofs.size(); ++i) v[static_cast<Eigen::Index>(i)] = impl_->dofs[i].step;
  return v;
}

const std::vector<HandLink>& Hand::links() const { return impl_->model.geometry; }

int Hand::link_index(const std::string& link_name) const {
  auto it = impl_->model.link_index.find(link_name);
  return it == impl_->model.link_index.end() ? -1 : impl_->model.links[it->second].geometry;
}

std::vector<std::string> Hand::link_names() const {
  std::vector<std::string> out;
  for (const auto& l : impl_->model.links) out.push_back(l.name);
  return out;
}

std::vector<HandJoint> Hand::joints() const {
  const auto& km = impl_->model;
  std::vector<HandJoint> out;
  out.reserve(km.joints.size());
  for (const auto& kj : km.joints) {
    HandJoint j;
    j.name = kj.name;
    switch (kj.type) {
      case hand_detail::KJoint::Fixed: j.type = HandJoint::Type::Fixed; break;
      case hand_detail::KJoint::Revolute: j.type = HandJoint::Type::Revolute; break;
      case hand_detail::KJoint::Continuous: j.type = HandJoint::Type::Continuous; break;
      case hand_detail::KJoint::Prismatic: j.type = HandJoint::Type::Prismatic; break;
    }
    j.parent_link = km.links[static_cast<std::size_t>(kj.parent)].name;
    j.child_link = km.links[static_cast<std::size_t>(kj.child)].name;
    j.origin = kj.origin;
    j.axis = kj.axis;
    j.limited = kj.limited;
    j.lower = kj.lower;
    j.upper = kj.upper;
    j.effort = kj.effort;
    j.velocity = kj.velocity;
    j.mimic_joint = kj.mimic_of;
    j.multiplier = kj.multiplier;
    j.offset = kj.offset;
    out.push_back(std::move(j));
  }
  return out;
}

HandInertial Hand::inertial(const std::string& link_name) const {
  auto it = impl_->model.link_index.find(link_name);
  if (it == impl_->model.link_index.end())
    throw std::invalid_argument("link: no link '" + link_name + "' in " + impl_->model.urdf_path);
  return impl_->model.links[static_cast<std::size_t>(it->second)].inertial;
}

const std::string& Hand::wrist_link() const { return impl_->wrist; }
const Eigen::Vector3d& Hand::approach() const { return impl_->approach; }
Pose Hand::root_to_wrist() const { return Pose::Identity(); }

std::vector<std::string> Hand::joint_names() const {
  std::vector<std::string> out;
  for (int j : impl_->model.movable) out.push_back(impl_->model.joints[j].name);
  return out;
}

Eigen::VectorXd Hand::joint_values(const Eigen::VectorXd& dofs, bool clamp) const {
  return impl_->joint_values(impl_->checked_dofs(dofs, clamp));
}

std::map<std::string, Pose> Hand::link_transforms(const Eigen::VectorXd& dofs, bool clamp) const {
  const std::vector<Pose> T = impl_->root_poses(joint_values(dofs, clamp));
  std::map<std::string, Pose> out;
  for (std::size_t li = 0; li < T.size(); ++li) out.emplace(impl_->model.links[li].name, T[li]);
  return out;
}

std::vector<Pose> Hand::link_poses(const Eigen::VectorXd& dofs, bool clamp) const {
  const std::vector<Pose> T = impl_->root_poses(joint_values(dofs, clamp));
  std::vector<Pose> out(impl_->model.geometry.size(), Pose::Identity());
  for (std::size_t li = 0; li < T.size(); ++li)
    if (impl_->model.links[li].geometry >= 0) out[impl_->model.links[li].geometry] = T[li];
  return out;
}

Constellation Hand::constellation(const Eigen::VectorXd& dofs, ConstellationMode mode, double spacing,
                                  bool clamp) const {
  if (mode == ConstellationMode::Area && !(std::isfinite(spacing) && spacing > 0))
    throw std::invalid_argument("spacing: expected a positive finite length in metres, got " + num(spacing));
  const std::vector<Pose> poses = link_poses(dofs, clamp);
  const std::vector<HandLink>& links = impl_->model.geometry;
  Constellation c;
  if (mode == ConstellationMode::PerLink) {
    const auto& samples = impl_->per_link;
    c.points.resize(static_cast<Eigen::Index>(samples.size()), 3);
    c.normals.resize(static_cast<Eigen::Index>(samples.size()), 3);
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Pose& T = poses[samples[i].link];
      c.points.row(static_cast<Eigen::Index>(i)) = (T * samples[i].point).transpose();
      c.normals.row(static_cast<Eigen::Index>(i)) = (T.linear() * samples[i].normal).normalized().transpose();
      c.link.push_back(samples[i].link);
      c.link_names.push_back(links[samples[i].link].name);
    }
    return c;
  }
  const auto area = impl_->area_samples(spacing);
  Eigen::Index total = 0;
  for (const Points& p : area->points) total += p.rows();
  c.points.resize(total, 3);
  c.normals.resize(total, 3);
  c.link.reserve(static_cast<std::size_t>(total));
  c.link_names.reserve(static_cast<std::size_t>(total));
  Eigen::Index row = 0;
  for (std::size_t b = 0; b < area->link.size(); ++b) {
    const Pose& T = poses[area->link[b]];
    const Eigen::Matrix3d R = T.linear();
    const Eigen::Vector3d t = T.translation();
    const Points& P = area->points[b];
    const Points& N = area->normals[b];
    for (Eigen::Index i = 0; i < P.rows(); ++i, ++row) {
      c.points.row(row) = (R * P.row(i).transpose() + t).transpose();
      c.normals.row(row) = (R * N.row(i).transpose()).normalized().transpose();
      c.link.push_back(area->link[b]);
      c.link_names.push_back(links[area->link[b]].name);
    }
  }
  return c;
}

}  // namespace pairgrasp
