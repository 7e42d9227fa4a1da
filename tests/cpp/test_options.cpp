// Options: every bad value of PlannerOptions and PlanOptions is refused by validate() with one
// std::invalid_argument whose message starts with the field's name (the name Python uses too), and
// the defaults pass.
#include <pairgrasp/planner.hpp>
#include <pairgrasp/search.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace {

using namespace pairgrasp;

template <class Options>
struct BadValue {
  std::string field;
  std::function<void(Options&)> set;
};

template <class Options>
void expect_each_refused(const std::vector<BadValue<Options>>& cases) {
  for (const BadValue<Options>& c : cases) {
    Options o;
    c.set(o);
    try {
      validate(o);
      ADD_FAILURE() << c.field << ": a bad value was accepted";
    } catch (const std::invalid_argument& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(c.field + ": ", 0), 0u) << "message does not start with '" << c.field << ": ': " << message;
    }
  }
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Options, DefaultsAreValid) {
  EXPECT_NO_THROW(validate(PlannerOptions()));
  EXPECT_NO_THROW(validate(PlanOptions()));
}

TEST(Options, EveryBadPlannerOptionIsRefusedByName) {
  using P = PlannerOptions;
  expect_each_refused<P>({
      {"edge", [](P& o) { o.edge = 0.0; }},
      {"edge", [](P& o) { o.edge = -0.01; }},
      {"edge", [](P& o) { o.edge = kNaN; }},
      {"d_max", [](P& o) { o.d_max = kInf; }},
      {"d_max", [](P& o) { o.d_max = 0.0; }},
      {"spacing", [](P& o) { o.spacing = -1.0; }},
      {"depth_tolerance", [](P& o) { o.depth_tolerance = -0.001; }},
      {"depth_tolerance", [](P& o) { o.depth_tolerance = kNaN; }},
      {"gap", [](P& o) { o.gap = -0.001; }},
      {"backoff", [](P& o) { o.backoff = kInf; }},
      {"field_cell", [](P& o) { o.field_cell = 0.0; }},
      {"max_pairs", [](P& o) { o.max_pairs = 0; }},
      {"max_field_bytes", [](P& o) { o.max_field_bytes = 0; }},
      {"max_area_samples", [](P& o) { o.max_area_samples = 2; }},
      {"mu", [](P& o) { o.mu = -0.1; }},
      {"mu", [](P& o) { o.mu = kInf; }},
      {"threads", [](P& o) { o.threads = -1; }},
  });
  PlannerOptions zero_ok;  // lengths that may be zero
  zero_ok.depth_tolerance = 0.0;
  zero_ok.gap = 0.0;
  zero_ok.backoff = 0.0;
  EXPECT_NO_THROW(validate(zero_ok));
}

TEST(Options, EveryBadPlanOptionIsRefusedByName) {
  using P = PlanOptions;
  expect_each_refused<P>({
      {"poses_per_sample", [](P& o) { o.poses_per_sample = 0; }},
      {"max_poses_per_sample", [](P& o) { o.max_poses_per_sample = 0; }},
      {"chunk", [](P& o) { o.chunk = 0; }},
      {"step", [](P& o) { o.step = 0.0; }},
      {"step", [](P& o) { o.step = kNaN; }},
      {"backoff", [](P& o) { o.backoff = -0.01; }},
      {"top", [](P& o) { o.top = 0; }},
      {"fine_tune", [](P& o) { o.fine_tune = -1; }},
      {"fine_tune_iterations", [](P& o) { o.fine_tune_iterations = -1; }},
      {"mu", [](P& o) { o.mu = -0.5; }},
      {"mu", [](P& o) { o.mu = kInf; }},
      {"edges", [](P& o) { o.edges = 2; }},
      {"contacts_per_link", [](P& o) { o.contacts_per_link = -1; }},
      {"max_evaluations", [](P& o) { o.max_evaluations = 0; }},
      {"hull_rank", [](P& o) { o.hull_rank = -1; }},
      {"robust_samples", [](P& o) { o.robust_samples = 0; }},
  });
}

}  // namespace
