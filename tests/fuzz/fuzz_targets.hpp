#pragma once
// The fuzz targets of pairgrasp's parsers of user files, shared by the libFuzzer harnesses
// (fuzz_*.cpp in this folder) and the GoogleTest that replays the committed corpora and
// regression inputs (tests/cpp/test_fuzz_corpus.cpp).
//
// Each target feeds one input to a parser the way a user's file reaches it (written to a file,
// then loaded by path) and accepts exactly two outcomes: a result that satisfies the documented
// invariants, or a pairgrasp::FileError whose message starts with the file's path. Anything
// else (another exception, a broken invariant) is a bug: fuzz::bug() reports it (the harnesses
// abort, so libFuzzer keeps the input; the replay test turns it into a failure). Crashes, hangs,
// leaks and undefined behaviour are caught by the sanitizers and libFuzzer themselves.
#include <pairgrasp/error.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/paint.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <unistd.h>

#ifndef PAIRGRASP_MODEL_DIR
#error "PAIRGRASP_MODEL_DIR must name the models folder"
#endif

namespace pairgrasp::fuzz {

namespace fs = std::filesystem;

/// A broken expectation found by a target (not a std::exception, so that no handler of the
/// parsers' errors can swallow it).
struct Bug {
  std::string message;
};

/// What a target did with an input.
enum class Outcome { Loaded, Rejected };

/// Whether bug() aborts (the libFuzzer harnesses) or throws Bug (the replay test).
inline bool& abort_on_bug() {
  static bool abort_it = true;
  return abort_it;
}

[[noreturn]] inline void bug(const std::string& target, const std::string& what) {
  const std::string message = target + ": " + what;
  if (abort_on_bug()) {
    std::fprintf(stderr, "pairgrasp fuzz target %s\n", message.c_str());
    std::fflush(stderr);
    std::abort();
  }
  throw Bug{message};
}

/// This process's scratch folder under the system temporary folder, made on first use and
/// removed when the process exits normally.
inline const fs::path& scratch() {
  struct Dir {
    fs::path path;
    Dir() {
      std::error_code ec;
      fs::path base = fs::temp_directory_path(ec);
      if (ec) base = "/tmp";
      path = base / ("pairgrasp-fuzz-" + std::to_string(::getpid()));
      fs::create_directories(path);
    }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  };
  static const Dir dir;
  return dir.path;
}

inline void write_file(const fs::path& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) bug("write_file", "cannot write " + path.string());
}

inline bool starts_with(const std::string& s, const std::string& prefix) { return s.compare(0, prefix.size(), prefix) == 0; }

inline bool finite_pose(const Pose& p) { return p.matrix().allFinite(); }

/// Checks the invariants load_mesh() documents for a mesh it returned.
inline void check_mesh(const std::string& target, const Mesh& m) {
  if (m.faces.rows() == 0) bug(target, "a mesh with no faces was returned");
  if (!m.vertices.allFinite()) bug(target, "a vertex is not finite");
  if (m.faces.minCoeff() < 0 || m.faces.maxCoeff() >= m.vertices.rows()) bug(target, "a face index is out of range");
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f) {
    if (m.faces(f, 0) == m.faces(f, 1) || m.faces(f, 1) == m.faces(f, 2) || m.faces(f, 0) == m.faces(f, 2))
      bug(target, "face " + std::to_string(f) + " repeats a vertex");
  }
  if (!std::isfinite(m.area) || !(m.area > 0.0)) bug(target, "area is " + std::to_string(m.area));
  if (!std::isfinite(m.volume) || !m.center_of_mass.allFinite()) bug(target, "volume or centre of mass is not finite");
  if (m.closed && !(m.volume > 0.0)) bug(target, "a closed, oriented mesh has volume " + std::to_string(m.volume));
  if (!m.face_normals().allFinite()) bug(target, "a face normal is not finite");
}

/// load_mesh() of `data` saved as a file with extension `ext` (".stl", ".obj", ".ply", ".dae").
inline Outcome mesh_target(const std::string& ext, const std::uint8_t* data, std::size_t size) {
  const std::string target = "mesh" + ext;
  const fs::path path = scratch() / ("input" + ext);
  write_file(path, data, size);
  try {
    check_mesh(target, load_mesh(path.string()));
    return Outcome::Loaded;
  } catch (const Bug&) {
    throw;
  } catch (const FileError& e) {
    if (!starts_with(e.what(), path.string() + ": ")) bug(target, std::string("FileError not naming the file: ") + e.what());
  } catch (const std::exception& e) {
    bug(target, std::string("unexpected exception: ") + e.what());
  }
  return Outcome::Rejected;
}

/// The separator between the hand spec and the URDF in a hand target's input.
inline const char* hand_separator() { return "\n%%URDF%%\n"; }

/// Hand::load() of an input "<spec JSON>" + hand_separator() + "<URDF>" (without the separator:
/// the input is the spec and the URDF is the bundled parallel jaw's). The spec is saved as
/// hand.json and the URDF as hand.urdf in a folder whose meshes/ holds the bundled hands' meshes;
/// package:// URIs resolve in the models folder.
inline Outcome hand_target(const std::uint8_t* data, std::size_t size) {
  const std::string target = "hand";
  const fs::path dir = scratch() / "hand";
  static const bool ready = [&] {
    fs::create_directories(dir / "meshes");
    for (const char* hand : {"barrett", "parallel_jaw"})
      for (const auto& e : fs::directory_iterator(fs::path(PAIRGRASP_MODEL_DIR) / hand / "meshes")) {
        const fs::path link = dir / "meshes" / e.path().filename();
        if (!fs::exists(link)) fs::create_symlink(fs::absolute(e.path()), link);
      }
    return true;
  }();
  (void)ready;
  const std::string input(reinterpret_cast<const char*>(data), size);
  const std::size_t cut = input.find(hand_separator());
  const fs::path spec = dir / "hand.json", urdf = dir / "hand.urdf";
  if (cut == std::string::npos) {
    write_file(spec, data, size);
    std::error_code ec;
    fs::copy_file(fs::path(PAIRGRASP_MODEL_DIR) / "parallel_jaw" / "parallel_jaw.urdf", urdf,
                  fs::copy_options::overwrite_existing, ec);
    if (ec) bug("copy_file", "cannot copy the parallel jaw's URDF to " + urdf.string() + ": " + ec.message());
  } else {
    const std::size_t rest = cut + std::char_traits<char>::length(hand_separator());
    write_file(spec, data, cut);
    write_file(urdf, data + rest, size - rest);
  }
  HandLoadOptions options;
  options.package_paths = {PAIRGRASP_MODEL_DIR};
  try {
    const Hand hand = Hand::load(spec.string(), options);
    const Eigen::VectorXd lo = hand.dof_lower(), hi = hand.dof_upper();
    if (lo.size() == 0) bug(target, "a hand with no DOF was returned");
    if (!lo.allFinite() || !hi.allFinite() || (hi - lo).minCoeff() < 0.0) bug(target, "DOF limits are not finite or inverted");
    if (!(hand.dof_step().minCoeff() > 0.0)) bug(target, "a DOF step is not positive");
    bool active = false;
    for (const HandLink& link : hand.links()) {
      check_mesh(target + " link " + link.name, link.mesh);
      active = active || link.active();
    }
    if (!active) bug(target, "a hand with no active surface was returned");
    for (const Eigen::VectorXd& q : {Eigen::VectorXd(lo), Eigen::VectorXd(hi), Eigen::VectorXd((lo + hi) / 2)}) {
      for (const Pose& p : hand.link_poses(q))
        if (!finite_pose(p)) bug(target, "a link pose is not finite");
      const Constellation c = hand.constellation(q, ConstellationMode::PerLink);
      if (c.points.rows() == 0 || !c.points.allFinite() || !c.normals.allFinite())
        bug(target, "the per-link constellation is empty or not finite");
      for (Eigen::Index i = 0; i < c.normals.rows(); ++i)
        if (std::abs(c.normals.row(i).norm() - 1.0) > 1e-6) bug(target, "a constellation normal is not unit");
    }
    return Outcome::Loaded;
  } catch (const Bug&) {
    throw;
  } catch (const FileError& e) {
    // The message names the spec, the URDF or a mesh: a file of the hand folder or the models.
    if (!starts_with(e.what(), dir.string() + "/") && !starts_with(e.what(), PAIRGRASP_MODEL_DIR))
      bug(target, std::string("FileError naming no hand file: ") + e.what());
  } catch (const std::exception& e) {
    bug(target, std::string("unexpected exception: ") + e.what());
  }
  return Outcome::Rejected;
}

/// load_paint() of `data` for the bundled box target (12 faces).
inline Outcome paint_target(const std::uint8_t* data, std::size_t size) {
  const std::string target = "paint";
  static const Mesh box = load_mesh(std::string(PAIRGRASP_MODEL_DIR) + "/targets/box.stl");
  const fs::path path = scratch() / "input.paint.json";
  write_file(path, data, size);
  try {
    const Mask mask = load_paint(path.string(), box);
    if (mask.size() != box.faces.rows()) bug(target, "mask size " + std::to_string(mask.size()) + " for 12 faces");
    if (!mask.any()) bug(target, "a mask with no free face was returned");
    return Outcome::Loaded;
  } catch (const Bug&) {
    throw;
  } catch (const FileError& e) {
    if (!starts_with(e.what(), path.string() + ": ")) bug(target, std::string("FileError not naming the file: ") + e.what());
  } catch (const std::invalid_argument& e) {
    // Documented: a paint that leaves no face free.
    if (std::string(e.what()) != path.string() + ": paint leaves no free face")
      bug(target, std::string("unexpected invalid_argument: ") + e.what());
  } catch (const std::exception& e) {
    bug(target, std::string("unexpected exception: ") + e.what());
  }
  return Outcome::Rejected;
}

/// Runs the target named `name` ("mesh_stl", "mesh_obj", "mesh_ply", "mesh_dae", "hand", "paint").
inline Outcome run_target(const std::string& name, const std::uint8_t* data, std::size_t size) {
  if (starts_with(name, "mesh_")) return mesh_target("." + name.substr(5), data, size);
  if (name == "hand") return hand_target(data, size);
  if (name == "paint") return paint_target(data, size);
  bug("run_target", "no target named " + name);
}

}  // namespace pairgrasp::fuzz
