// Hands (pairgrasp/hand.hpp): load_hand, Hand (FK, joint values, constellations), HandLink, Dof,
// Constellation with zero-copy read-only NumPy views.
#include "bind.hpp"

#include <pairgrasp/hand.hpp>

#include <pybind11/stl/filesystem.h>

#include <cstdint>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>

namespace pairgrasp::py {
namespace {

using namespace pybind11::literals;

// A read-only (rows, 3) NumPy view of a row-major (N,3) block owned by `owner`.
pyb::array view3(const Points& block, const pyb::object& owner) {
  const auto s = static_cast<pyb::ssize_t>(sizeof(double));
  pyb::array_t<double> a({static_cast<pyb::ssize_t>(block.rows()), pyb::ssize_t{3}}, {3 * s, s}, block.data(),
                         owner);
  a.attr("flags").attr("writeable") = false;
  return std::move(a);
}

// A read-only 1-D NumPy view of a std::vector<int> owned by `owner`.
pyb::array view1(const std::vector<int>& v, const pyb::object& owner) {
  pyb::array_t<int> a({static_cast<pyb::ssize_t>(v.size())}, {static_cast<pyb::ssize_t>(sizeof(int))}, v.data(),
                      owner);
  a.attr("flags").attr("writeable") = false;
  return std::move(a);
}

pyb::array_t<double> matrix4(const Pose& T) {
  pyb::array_t<double> a({4, 4});
  auto r = a.mutable_unchecked<2>();
  const Eigen::Matrix4d M = T.matrix();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r(i, j) = M(i, j);
  return a;
}

// A DOF vector from any 1-D sequence of numbers (size and values are checked by Hand).
Eigen::VectorXd dofs_from(const pyb::object& obj) {
  pyb::array a = pyb::module_::import("numpy").attr("asarray")(obj, "dtype"_a = "float64");
  if (a.ndim() != 1) {
    std::ostringstream s;
    s << "dofs: expected a 1-D sequence of DOF values, got an array of shape (";
    for (pyb::ssize_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.shape(i);
    s << ")";
    throw std::invalid_argument(s.str());
  }
  const auto c = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(a);
  Eigen::VectorXd v(c.shape(0));
  std::copy(c.data(), c.data() + c.size(), v.data());
  return v;
}

ConstellationMode mode_from(const std::string& mode) {
  if (mode == "per_link") return ConstellationMode::PerLink;
  if (mode == "area") return ConstellationMode::Area;
  throw std::invalid_argument("mode: expected 'per_link' or 'area', got '" + mode + "'");
}

}  // namespace

void bind_hand(pyb::module_& m) {
  pyb::class_<DofJoint>(m, "DofJoint", "A joint driven by a DOF: q_joint = ratio * q_dof + offset.")
      .def_readonly("joint", &DofJoint::joint, "URDF joint name.")
      .def_readonly("ratio", &DofJoint::ratio)
      .def_readonly("offset", &DofJoint::offset, "rad or m")
      .def("__repr__", [](const DofJoint& j) {
        std::ostringstream s;
        s << "DofJoint('" << j.joint << "', ratio=" << j.ratio << ", offset=" << j.offset << ")";
        return s.str();
      });

  pyb::class_<Dof>(m, "Dof", "A degree of freedom of the hand as the planner samples it.")
      .def_readonly("name", &Dof::name)
      .def_readonly("joints", &Dof::joints, "Joints it drives (their mimic joints follow).")
      .def_readonly("lower", &Dof::lower, "Lower limit, rad (m when linear).")
      .def_readonly("upper", &Dof::upper, "Upper limit, rad (m when linear).")
      .def_readonly("step", &Dof::step, "Default sampling step, rad (m when linear).")
      .def_readonly("linear", &Dof::linear, "True when it drives prismatic joints (metres).")
      .def("__repr__", [](const Dof& d) {
        std::ostringstream s;
        s << "Dof('" << d.name << "', [" << d.lower << ", " << d.upper << "] " << (d.linear ? "m" : "rad")
          << ", step " << d.step << ")";
        return s.str();
      });

  pyb::enum_<HandJoint::Type>(m, "JointType", "Type of a URDF joint.")
      .value("fixed", HandJoint::Type::Fixed)
      .value("revolute", HandJoint::Type::Revolute)
      .value("continuous", HandJoint::Type::Continuous)
      .value("prismatic", HandJoint::Type::Prismatic);

  pyb::class_<HandJoint>(m, "HandJoint",
                         "A URDF joint (fixed ones included). The child link frame is `origin` followed by a "
                         "rotation of q about `axis` (revolute, continuous) or a translation of q along it "
                         "(prismatic).")
      .def_readonly("name", &HandJoint::name)
      .def_readonly("type", &HandJoint::type, "JointType.")
      .def_readonly("parent_link", &HandJoint::parent_link)
      .def_readonly("child_link", &HandJoint::child_link)
      .def_property_readonly("origin", [](const HandJoint& j) { return matrix4(j.origin); },
                             "4x4 joint frame in the parent link frame at q = 0 (m).")
      .def_property_readonly("axis", [](const HandJoint& j) { return Eigen::Vector3d(j.axis); },
                             "Unit axis in the joint frame.")
      .def_readonly("limited", &HandJoint::limited, "Has position limits (revolute, prismatic).")
      .def_readonly("lower", &HandJoint::lower, "Lower limit, rad (m when prismatic).")
      .def_readonly("upper", &HandJoint::upper, "Upper limit, rad (m when prismatic).")
      .def_readonly("effort", &HandJoint::effort, "URDF effort limit, N·m (N when prismatic); 0 when absent.")
      .def_readonly("velocity", &HandJoint::velocity, "URDF velocity limit, rad/s (m/s); 0 when absent.")
      .def_readonly("mimic_joint", &HandJoint::mimic_joint, "The joint it mimics ('' when none).")
      .def_readonly("multiplier", &HandJoint::multiplier, "Mimic: q = multiplier * q_mimicked + offset.")
      .def_readonly("offset", &HandJoint::offset, "Mimic offset, rad (m when prismatic).")
      .def("__repr__", [](const HandJoint& j) {
        static const char* names[] = {"fixed", "revolute", "continuous", "prismatic"};
        std::ostringstream s;
        s << "HandJoint('" << j.name << "', " << names[static_cast<int>(j.type)] << ", " << j.parent_link << " -> "
          << j.child_link;
        if (!j.mimic_joint.empty()) s << ", mimic of " << j.mimic_joint;
        s << ")";
        return s.str();
      });

  pyb::class_<HandInertial>(m, "HandInertial",
                            "A link's URDF <inertial>: mass (kg), inertia (kg m^2) about the centre of mass in "
                            "the inertial frame, the frame in the link frame.")
      .def_readonly("present", &HandInertial::present, "False when the URDF gives none.")
      .def_readonly("mass", &HandInertial::mass, "kg")
      .def_property_readonly("frame", [](const HandInertial& i) { return matrix4(i.frame); },
                             "4x4 inertial frame in the link frame (origin: centre of mass, m).")
      .def_property_readonly("inertia", [](const HandInertial& i) { return Eigen::Matrix3d(i.inertia); },
                             "3x3 inertia tensor, kg m^2.");

  pyb::class_<HandLink>(m, "HandLink", "A link with geometry, in its own link frame.")
      .def_readonly("name", &HandLink::name)
      .def_readonly("mesh", &HandLink::mesh, "Collision geometry (visual if none), link frame, metres.")
      .def_property_readonly(
          "active_faces", [](pyb::object self) { return view1(self.cast<const HandLink&>().active_faces, self); },
          "Indices of the mesh faces that form the contact surface (read-only int array).")
      .def_property_readonly("active", &HandLink::active, "Whether the link has an active surface.")
      .def("__repr__", [](const HandLink& l) {
        std::ostringstream s;
        s << "HandLink('" << l.name << "', " << l.mesh.faces.rows() << " faces, " << l.active_faces.size()
          << " active)";
        return s.str();
      });

  pyb::class_<Constellation>(m, "Constellation",
                             "Active-surface samples at one DOF vector, in the wrist frame. Normals point out "
                             "of the finger surface (not flipped).")
      .def_property_readonly(
          "points", [](pyb::object self) { return view3(self.cast<const Constellation&>().points, self); },
          "(P, 3) sample positions, metres (read-only view).")
      .def_property_readonly(
          "normals", [](pyb::object self) { return view3(self.cast<const Constellation&>().normals, self); },
          "(P, 3) unit outward normals (read-only view).")
      .def_property_readonly(
          "link_index", [](pyb::object self) { return view1(self.cast<const Constellation&>().link, self); },
          "(P,) index into Hand.links of each sample.")
      .def_readonly("links", &Constellation::link_names, "Link name of each sample.")
      .def("__len__", [](const Constellation& c) { return c.points.rows(); })
      .def("__repr__", [](const Constellation& c) {
        return "Constellation(" + std::to_string(c.points.rows()) + " samples)";
      });

  pyb::class_<Hand>(m, "Hand",
                    "An articulated hand: URDF kinematics, DOF map, link meshes and active surfaces. Poses are "
                    "in the wrist frame.")
      .def_property_readonly("name", &Hand::name)
      .def_property_readonly("spec_path", &Hand::spec_path, "The hand spec file it was loaded from.")
      .def_property_readonly("urdf_path", &Hand::urdf_path, "The URDF file the spec names.")
      .def_property_readonly("dofs", &Hand::dofs, "The DOFs (Dof objects).")
      .def_property_readonly("dof_names", &Hand::dof_names)
      .def_property_readonly("dof_lower", &Hand::dof_lower, "Lower DOF limits, rad (m for linear DOFs).")
      .def_property_readonly("dof_upper", &Hand::dof_upper, "Upper DOF limits, rad (m for linear DOFs).")
      .def_property_readonly("dof_step", &Hand::dof_step, "Default sampling steps, rad (m for linear DOFs).")
      .def_property_readonly("joint_names", &Hand::joint_names,
                             "Every non-fixed URDF joint (mimics included), depth-first from the root.")
      .def_property_readonly("wrist_link", &Hand::wrist_link, "The link whose frame poses are expressed in.")
      .def_property_readonly("approach", [](const Hand& h) { return Eigen::Vector3d(h.approach()); },
                             "Unit approach direction in the wrist frame (the way the palm faces).")
      .def_property_readonly("links", &Hand::links, pyb::return_value_policy::reference_internal,
                             "Links with geometry (HandLink), depth-first from the wrist link.")
      .def_property_readonly("link_names", &Hand::link_names, "Every link of the hand (the wrist link's subtree), depth-first from the wrist.")
      .def_property_readonly("root_to_wrist", [](const Hand&) {
            if (PyErr_WarnEx(PyExc_DeprecationWarning,
                             "Hand.root_to_wrist is deprecated: use the identity (the hand is rooted at its wrist "
                             "link; the name goes in the next release)", 1) != 0)
              throw pyb::error_already_set();
            return matrix4(Pose::Identity());
          }, "Deprecated: the identity (the hand is the wrist link's subtree).")
      .def("link_index", &Hand::link_index, "name"_a, "Index of a link in `links`, -1 when it has no geometry.")
      .def_property_readonly("joints", &Hand::joints,
                             "The URDF joints (HandJoint), fixed ones included, depth-first from the root.")
      .def("inertial", &Hand::inertial, "link"_a,
           "The URDF <inertial> of a link (HandInertial; present=False when none). ValueError for an unknown "
           "link.")
      .def(
          "joint_values",
          [](const Hand& h, const pyb::object& dofs, bool clamp) {
            const Eigen::VectorXd q = h.joint_values(dofs_from(dofs), clamp);
            const auto names = h.joint_names();
            pyb::dict out;
            for (std::size_t i = 0; i < names.size(); ++i) out[pyb::str(names[i])] = q[static_cast<Eigen::Index>(i)];
            return out;
          },
          "dofs"_a, "clamp"_a = false,
          "Values of every non-fixed joint (mimics applied) as {joint name: value} in joint_names order. "
          "ValueError for a wrong size, NaN, or a value outside the DOF limits unless clamp=True.")
      .def(
          "link_transforms",
          [](const Hand& h, const pyb::object& dofs, bool clamp) {
            const auto T = h.link_transforms(dofs_from(dofs), clamp);
            pyb::dict out;
            for (const auto& name : h.link_names()) out[pyb::str(name)] = matrix4(T.at(name));
            return out;
          },
          "dofs"_a, "clamp"_a = false, "{link name: 4x4 pose in the wrist frame} for every URDF link.")
      .def(
          "link_poses",
          [](const Hand& h, const pyb::object& dofs, bool clamp) {
            const auto T = h.link_poses(dofs_from(dofs), clamp);
            pyb::array_t<double> out({static_cast<pyb::ssize_t>(T.size()), pyb::ssize_t{4}, pyb::ssize_t{4}});
            auto r = out.mutable_unchecked<3>();
            for (std::size_t k = 0; k < T.size(); ++k) {
              const Eigen::Matrix4d M = T[k].matrix();
              for (int i = 0; i < 4; ++i)
                for (int j = 0; j < 4; ++j) r(static_cast<pyb::ssize_t>(k), i, j) = M(i, j);
            }
            return out;
          },
          "dofs"_a, "clamp"_a = false, "(L, 4, 4) poses of `links` in the wrist frame, in `links` order.")
      .def(
          "constellation",
          [](const Hand& h, const pyb::object& dofs, const std::string& mode, double spacing, bool clamp) {
            const Eigen::VectorXd d = dofs_from(dofs);
            const ConstellationMode md = mode_from(mode);
            pyb::gil_scoped_release release;
            return h.constellation(d, md, spacing, clamp);
          },
          "dofs"_a, "mode"_a = "per_link", "spacing"_a = 0.01, "clamp"_a = false,
          "Active-surface samples in the wrist frame. mode='per_link': one per active link (the point "
          "of its active surface nearest the area-weighted centroid, with the mean normal); mode='area': "
          "evenly spread samples `spacing` metres apart. ValueError for a bad mode, spacing or DOF vector.")
      .def("__repr__", [](const Hand& h) {
        int active = 0;
        for (const auto& l : h.links()) active += l.active();
        std::ostringstream s;
        s << "<pairgrasp.Hand '" << h.name() << "': " << h.dofs().size() << " DOF, " << h.links().size()
          << " links (" << active << " active), wrist '" << h.wrist_link() << "'>";
        return s.str();
      });

  m.def(
      "load_hand",
      [](const std::filesystem::path& spec_path, const std::vector<std::filesystem::path>& package_paths) {
        HandLoadOptions opt;
        for (const auto& p : package_paths) opt.package_paths.push_back(p.string());
        pyb::gil_scoped_release release;
        return Hand::load(spec_path.string(), opt);
      },
      "spec_path"_a, "package_paths"_a = std::vector<std::filesystem::path>{},
      "Loads a hand spec (JSON) and the URDF it names. `package_paths`: directories searched for "
      "package://NAME/... mesh URIs before the spec's own. Raises pairgrasp.FileError naming the file and "
      "field at fault.");
}

}  // namespace pairgrasp::py
