#pragma once
// Test hands for the collision, closing and contact tests: a one-link "probe" (a 20 mm cube on a prismatic slide)
// written as URDF + spec into a temporary directory, and the bundled models.
#include <pairgrasp/hand.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace pairgrasp::testing_hands {

namespace fs = std::filesystem;

/// A temporary directory removed at the end of the scope.
struct TempDir {
  fs::path path;
  TempDir() {
    std::random_device rd;
    path = fs::temp_directory_path() /
           ("pairgrasp_test_hand_" + std::to_string(rd()) + "_" +
            std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

/// The probe hand: link "probe" is the cube [-0.01, 0.01]^2 x [0, 0.02] (link frame) on a
/// prismatic joint along +z of the wrist (DOF "slide", 0..0.05 m). Its top face (+z) is active.
/// At slide = s the cube occupies z in [s, s + 0.02] of the wrist frame.
inline Hand probe_hand(const TempDir& dir) {
  const fs::path urdf = dir.path / "probe.urdf";
  std::ofstream(urdf) << R"(<?xml version="1.0"?>
<robot name="probe">
  <link name="wrist"/>
  <link name="probe">
    <collision><origin xyz="0 0 0.01" rpy="0 0 0"/><geometry><box size="0.02 0.02 0.02"/></geometry></collision>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="wrist"/><child link="probe"/>
    <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.05" effort="1" velocity="1"/>
  </joint>
</robot>
)";
  const fs::path spec = dir.path / "probe.json";
  std::ofstream(spec) << R"({
  "name": "probe", "urdf": "probe.urdf", "wrist_link": "wrist", "approach": [0, 0, 1],
  "dofs": [{"name": "slide", "joints": [{"joint": "slide"}], "step": 0.01}],
  "active_surfaces": [{"link": "probe", "normal_cone": {"axis": [0, 0, 1], "half_angle_deg": 10}}]
})";
  return Hand::load(spec.string());
}

inline Hand parallel_jaw() { return Hand::load(std::string(PAIRGRASP_MODEL_DIR) + "/parallel_jaw/parallel_jaw.json"); }
inline Hand barrett() { return Hand::load(std::string(PAIRGRASP_MODEL_DIR) + "/barrett/barrett.json"); }

/// A wrist pose: rotation about an axis (radians) then translation (metres).
inline Pose pose(const Eigen::Vector3d& t, double angle = 0.0,
                 const Eigen::Vector3d& axis = Eigen::Vector3d::UnitX()) {
  Pose p = Pose::Identity();
  p.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  p.translation() = t;
  return p;
}

}  // namespace pairgrasp::testing_hands
