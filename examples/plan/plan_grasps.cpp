// plan_grasps: grasps of a hand on a target planned with the C++ library alone (no Python), on the
// grid schedule (every DOF sampled every --step radians), written as a grasps.json that
// `pairgrasp simulate` and `pairgrasp view` read.
//
//   plan_grasps --hand SPEC --target MESH [--paint FILE] [--support auto|Z] [--obstacle MESH]...
//               [--occluder MESH]... [--step RAD] [--top K] [--seed S]
//               [--rank enclosure|epsilon|load|robust] [--threads N] -o FILE
//
// --support: the target rests on a horizontal plane (auto: through its lowest point; Z: at height Z m),
// an obstacle and an occluder at once. --obstacle: a mesh the hand must not touch; --occluder: a mesh
// covering the surface within 5 mm (give a table mesh as both).
#include <pairgrasp/error.hpp>
#include <pairgrasp/free_surface.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/paint.hpp>
#include <pairgrasp/search.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace pg = pairgrasp;

namespace {

struct Args {
  std::string hand, target, paint, out, support;  // support: "", "auto" or a height (m)
  std::vector<std::string> obstacles, occluders;
  double step = 0.0;  // 0: the hand's steps
  double field_cell = 0.0;  // 0: derived (edge / 5, at least 1 mm)
  int top = 10;
  unsigned long seed = 0;
  int threads = 0;
  pg::Ranking rank = pg::PlanOptions().rank;
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "plan_grasps: %s\nusage: plan_grasps --hand SPEC --target MESH [--paint FILE] [--support auto|Z] "
               "[--obstacle MESH]... [--occluder MESH]... [--step RAD] [--field-cell M] [--top K] [--seed S] "
               "[--rank enclosure|epsilon|load|robust] [--threads N] -o FILE\n",
               why.c_str());
  std::exit(2);
}

double number(const std::string& flag, const char* text) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v)) usage(flag + ": expected a number, got '" + text + "'");
  return v;
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string f = argv[i];
    if (i + 1 >= argc) usage(f + ": missing value");
    const char* v = argv[++i];
    if (f == "--hand") a.hand = v;
    else if (f == "--target") a.target = v;
    else if (f == "--paint") a.paint = v;
    else if (f == "--support") a.support = std::string(v) == "auto" ? v : (number(f, v), std::string(v));
    else if (f == "--obstacle") a.obstacles.push_back(v);
    else if (f == "--occluder") a.occluders.push_back(v);
    else if (f == "-o" || f == "--out") a.out = v;
    else if (f == "--step") a.step = number(f, v);
    else if (f == "--field-cell") a.field_cell = number(f, v);
    else if (f == "--top") a.top = static_cast<int>(number(f, v));
    else if (f == "--seed") a.seed = static_cast<unsigned long>(number(f, v));
    else if (f == "--threads") a.threads = static_cast<int>(number(f, v));
    else if (f == "--rank") {
      try {
        a.rank = pg::ranking_from_string(v);
      } catch (const std::invalid_argument& e) {
        usage(e.what());
      }
    } else usage("unknown option " + f);
  }
  if (a.hand.empty() || a.target.empty() || a.out.empty()) usage("--hand, --target and -o are required");
  if (a.step < 0.0 || a.field_cell < 0.0 || a.top < 1 || a.threads < 0)
    usage("--step and --field-cell must be >= 0, --top >= 1, --threads >= 0");
  return a;
}

// JSON text of numbers rounded to 9 decimals (nm / nrad), as the Python writer does, in the
// fewest digits that read back to the same double.
std::string num(double x) {
  const double r = std::round(x * 1e9) / 1e9;
  char buf[64];
  for (int digits = 15; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, r == 0.0 ? 0.0 : r);
    if (std::strtod(buf, nullptr) == r) break;
  }
  std::string s = buf;
  if (s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}
template <class V>
std::string list(const V& v) {
  std::string s = "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) s += (i ? ", " : "") + num(v[i]);
  return s + "]";
}
std::string matrix(const pg::Pose& p) {
  std::string s = "[";
  for (int i = 0; i < 4; ++i) s += (i ? ", " : "") + list(Eigen::Vector4d(p.matrix().row(i).transpose()));
  return s + "]";
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  try {
    const auto t0 = std::chrono::steady_clock::now();
    const pg::Hand hand = pg::Hand::load(args.hand);
    const pg::Mesh target = pg::load_mesh(args.target);
    // The scene: paint (faces and regions, marked per surface patch), occluders, obstacles, support.
    pg::Scene scene;
    if (!args.paint.empty()) {
      pg::Paint paint = pg::read_paint(args.paint, target);
      scene.occlusion.paint = std::move(paint.faces);
      scene.occlusion.regions = std::move(paint.regions);
    }
    for (const std::string& path : args.occluders) scene.occlusion.occluders.push_back(pg::load_mesh(path));
    for (const std::string& path : args.obstacles) scene.obstacles.push_back({path, pg::load_mesh(path)});
    if (!args.support.empty()) {
      scene.occlusion.support = pg::SupportPlane::below(target);
      if (args.support != "auto") scene.occlusion.support->point = {0.0, 0.0, std::strtod(args.support.c_str(), nullptr)};
    }
    pg::PlannerOptions po;
    po.threads = args.threads;
    if (args.field_cell > 0.0) po.field_cell = args.field_cell;
    const pg::GraspPlanner planner(hand, target, scene, po);
    const std::vector<Eigen::VectorXd> samples =
        pg::dof_grid(hand.dof_lower(), hand.dof_upper(), planner.steps(args.step));
    pg::PlanOptions o;
    if (args.step > 0.0) o.step = args.step;
    o.top = args.top;
    o.seed = args.seed;
    o.rank = args.rank;
    const pg::PlanReport report = pg::plan_samples(planner, samples, o);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    const pg::PlannerSetup& s = planner.setup();
    std::printf("%s on %s: %zu samples, %ld candidates evaluated, %ld force-closure; edge %.4g m, d_max %.4g m\n",
                hand.name().c_str(), args.target.c_str(), samples.size(), report.counts.at("evaluated"),
                report.counts.at("force_closure"), s.edge, s.d_max);
    std::printf("rank  epsilon   load  P(fc)  eps_q25   volume     Q_A      votes  contacts  dofs\n");
    std::ostringstream grasps;
    int rank = 0;
    for (const pg::RankedGrasp& g : report.grasps) {
      const pg::EvaluatedCandidate& c = report.candidates[g.candidate];
      const pg::GraspEvaluation& e = g.evaluation;
      ++rank;
      std::printf("%4d  %.5f  %5.3f  ", rank, g.quality.epsilon, g.load_resistance);
      if (g.robust)
        std::printf("%5.2f  %.5f  ", g.robust->force_closure_probability, g.robust->epsilon);
      else
        std::printf("    -        -  ");
      std::printf("%.3e  %7.2f  %5d  %8ld  [", g.quality.volume,
                  c.candidate.alignment_quality, c.candidate.votes, static_cast<long>(e.contacts.points.rows()));
      for (Eigen::Index d = 0; d < e.dofs.size(); ++d) std::printf("%s%.4f", d ? " " : "", e.dofs[d]);
      std::printf("]%s\n", g.quality.force_closure ? "" : "  (not force-closure)");
      const Eigen::VectorXd joints = hand.joint_values(e.dofs, true);
      const std::vector<std::string> names = hand.joint_names();
      std::string joint_text = "{";
      for (std::size_t j = 0; j < names.size(); ++j)
        joint_text += (j ? ", " : "") + quoted(names[j]) + ": " + num(joints[static_cast<Eigen::Index>(j)]);
      joint_text += "}";
      std::string contacts = "[";
      for (Eigen::Index k = 0; k < e.contacts.points.rows(); ++k)
        contacts += std::string(k ? ", " : "") + "{\"point\": " + list(Eigen::Vector3d(e.contacts.points.row(k).transpose())) +
                    ", \"normal\": " + list(Eigen::Vector3d(e.contacts.normals.row(k).transpose())) +
                    ", \"link\": " + quoted(e.contacts.link_names[static_cast<std::size_t>(k)]) + "}";
      contacts += "]";
      grasps << (rank > 1 ? ",\n" : "") << "    {\"rank\": " << rank << ", \"wrist_pose\": " << matrix(e.wrist)
             << ", \"dof\": " << list(e.dofs) << ", \"joints\": " << joint_text
             << ", \"epsilon\": " << num(g.quality.epsilon) << ", \"volume\": " << num(g.quality.volume)
             << ", \"force_closure\": " << (g.quality.force_closure ? "true" : "false")
             << ", \"alignment_quality\": " << num(c.candidate.alignment_quality) << ", \"votes\": " << c.candidate.votes
             << ", \"penetration_depth\": " << num(e.depth) << ", \"contacts\": " << contacts
             << ", \"sample\": " << list(c.candidate.dofs) << ", \"aligned_pose\": " << matrix(c.candidate.pose)
             << ", \"backoff\": " << num(c.backoff) << ", \"fine_tuned\": " << (g.fine_tuned ? "true" : "false")
             << ", \"load_resistance\": " << num(g.load_resistance)
         << ", \"opposition\": " << num(g.push.opposition)
             << ", \"drive\": " << num(g.push.drive);
      if (g.robust)
        grasps << ", \"force_closure_probability\": " << num(g.robust->force_closure_probability)
               << ", \"robust_epsilon\": " << num(g.robust->epsilon);
      grasps << "}";
    }
    std::ostringstream doc;
    doc << "{\n  \"format\": \"pairgrasp.grasps/1\",\n"
        << "  \"inputs\": {\"hand\": " << quoted(hand.name()) << ", \"hand_spec\": " << quoted(args.hand)
        << ", \"target\": " << quoted(args.target) << ", \"target_faces\": " << target.faces.rows()
        << (args.paint.empty() ? "" : ", \"paint\": " + quoted(args.paint));
    auto names = [&](const char* key, const std::vector<std::string>& paths) {
      if (paths.empty()) return;
      doc << ", " << quoted(key) << ": [";
      for (std::size_t i = 0; i < paths.size(); ++i) doc << (i ? ", " : "") << quoted(paths[i]);
      doc << "]";
    };
    names("occluders", args.occluders);
    names("obstacles", args.obstacles);
    const pg::Occlusion& occ = scene.occlusion;
    if (occ.support)
      doc << ", \"support\": {\"point\": " << list(occ.support->point) << ", \"normal\": " << list(occ.support->normal)
          << "}";
    if (occ.support || !occ.occluders.empty()) doc << ", \"occluder_distance\": " << num(occ.distance);
    const pg::FreeSurface& fs = planner.free_surface();
    if (fs.split_faces)
      doc << ", \"free_surface\": {\"faces\": " << fs.mesh.faces.rows() << ", \"split_faces\": " << fs.split_faces
          << ", \"resolution\": " << num(fs.resolution) << "}";
    doc << ", \"free_faces\": " << planner.free().count() << "},\n"
        << "  \"parameters\": {\"schedule\": \"grid\", \"step\": " << (args.step > 0 ? num(args.step) : "null")
        << ", \"poses_per_sample\": " << o.poses_per_sample << ", \"top\": " << o.top << ", \"seed\": " << o.seed
        << ", \"rank\": " << quoted(pg::to_string(o.rank)) << ", \"robust_samples\": " << o.robust_samples
        << ", \"fine_tune\": " << o.fine_tune << ", \"fine_tune_iterations\": " << o.fine_tune_iterations
        << ", \"contacts_per_link\": " << o.contacts_per_link << ", \"mu\": " << num(o.mu) << ", \"edges\": " << o.edges
        << ", \"edge\": " << num(s.edge) << ", \"d_max\": " << num(s.d_max) << ", \"constellation\": "
        << (s.mode == pg::ConstellationMode::Area ? "\"area\"" : "\"per_link\"") << "},\n  \"counts\": {";
    bool first = true;
    for (const auto& [k, v] : report.counts) {
      doc << (first ? "" : ", ") << quoted(k) << ": " << v;
      first = false;
    }
    doc << "},\n  \"timings\": {\"index\": " << num(planner.setup_seconds());
    for (const auto& [k, v] : report.timings) doc << ", " << quoted(k) << ": " << num(v);
    doc << ", \"total\": " << num(seconds) << "},\n  \"grasps\": [\n" << grasps.str() << "\n  ]\n}\n";
    const std::string part = args.out + ".part";
    {
      std::ofstream f(part);
      if (!(f << doc.str())) throw pg::FileError(args.out, "cannot write");
    }
    if (std::rename(part.c_str(), args.out.c_str()) != 0) throw pg::FileError(args.out, "cannot write");
    std::printf("time %.2f s (index %.2f, align %.2f, settle %.2f, evaluate %.2f, fine_tune %.2f, robust %.2f s); "
                "wrote %s\n", seconds, planner.setup_seconds(), report.timings.at("align"), report.timings.at("settle"),
                report.timings.at("evaluate"), report.timings.at("fine_tune"), report.timings.at("robust"),
                args.out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "plan_grasps: %s\n", e.what());
    return 1;
  }
  return 0;
}
