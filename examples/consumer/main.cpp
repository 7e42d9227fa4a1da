// Uses the installed pairgrasp library without Python: loads the bundled Barrett hand and a
// target, and prints what a planner would start from.
//   usage: pairgrasp_consumer MODELS_DIR
#include <pairgrasp/error.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/version.hpp>

#include <cstdio>
#include <exception>
#include <string>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MODELS_DIR\n", argv[0]);
    return 2;
  }
  const std::string models = argv[1];
  try {
    const pairgrasp::Hand hand = pairgrasp::Hand::load(models + "/barrett/barrett.json");
    const pairgrasp::Mesh target = pairgrasp::load_mesh(models + "/targets/flask.stl");
    const Eigen::VectorXd mid = 0.5 * (hand.dof_lower() + hand.dof_upper());
    const pairgrasp::Constellation c =
        hand.constellation(mid, pairgrasp::ConstellationMode::PerLink);
    std::printf("pairgrasp %s\n", pairgrasp::version());
    std::printf("hand %s: %zu DOF, %zu links, %ld constellation samples at mid-range\n",
                hand.name().c_str(), hand.dofs().size(), hand.links().size(),
                static_cast<long>(c.points.rows()));
    std::printf("target %s: %ld faces, closed %s, volume %.6g m^3\n", target.source.c_str(),
                static_cast<long>(target.faces.rows()), target.closed ? "yes" : "no", target.volume);
    try {  // bad input is an exception with a message, not a crash
      pairgrasp::load_mesh(models + "/no-such-file.stl");
      std::fprintf(stderr, "a missing file was accepted\n");
      return 1;
    } catch (const pairgrasp::FileError& e) {
      std::printf("missing file reported: %s\n", e.what());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
