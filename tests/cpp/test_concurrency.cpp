// Concurrency: the shared, immutable objects (PairIndex, Aligner, Hand, GraspChecker, GraspPlanner)
// used from several caller threads at once, each call itself multithreaded, give exactly the results
// of serial single-threaded calls; a GraspSearch, which serves one caller at a time, refuses a second
// one. Run under ThreadSanitizer by `make tsan` (part of `make check`).
#include <pairgrasp/aligner.hpp>
#include <pairgrasp/collision.hpp>
#include <pairgrasp/facets.hpp>
#include <pairgrasp/grasp.hpp>
#include <pairgrasp/hand.hpp>
#include <pairgrasp/mesh.hpp>
#include <pairgrasp/pair_index.hpp>
#include <pairgrasp/error.hpp>
#include <pairgrasp/search.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace pairgrasp;

constexpr int kCallers = 3;  // caller threads, each making multithreaded calls

/// Runs body(t) on kCallers threads at once and joins them.
template <class F>
void on_callers(F body) {
  std::vector<std::thread> pool;
  for (int t = 0; t < kCallers; ++t) pool.emplace_back([&, t] { body(t); });
  for (auto& th : pool) th.join();
}

bool same(const AlignResult& a, const AlignResult& b) {
  if (a.poses.size() != b.poses.size() || a.stats.correspondences != b.stats.correspondences ||
      a.stats.rotation_votes != b.stats.rotation_votes || a.stats.position_votes != b.stats.position_votes ||
      a.stats.saturated != b.stats.saturated)
    return false;
  for (std::size_t i = 0; i < a.poses.size(); ++i) {
    const AlignedPose &x = a.poses[i], &y = b.poses[i];
    if (x.rotation != y.rotation || x.translation != y.translation || x.votes != y.votes || x.quality != y.quality ||
        x.variance != y.variance || x.contacts != y.contacts)
      return false;
  }
  return true;
}

bool same(const CheckResult& a, const CheckResult& b) {
  if (a.pruned != b.pruned || a.collision != b.collision || a.depth != b.depth || a.target_depth != b.target_depth ||
      a.reason != b.reason || a.links.size() != b.links.size() || a.pairs.size() != b.pairs.size())
    return false;
  for (std::size_t i = 0; i < a.links.size(); ++i)
    if (a.links[i].depth != b.links[i].depth || a.links[i].colliding != b.links[i].colliding ||
        a.links[i].with != b.links[i].with)
      return false;
  return true;
}

bool same(const CloseResult& a, const CloseResult& b) {
  return a.dofs == b.dofs && a.reasons == b.reasons && a.clearance == b.clearance && a.iterations == b.iterations &&
         same(a.check, b.check);
}

class Concurrency : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    hand_ = std::make_unique<Hand>(Hand::load(PAIRGRASP_MODEL_DIR "/barrett/barrett.json"));
    mesh_ = std::make_unique<Mesh>(load_mesh(PAIRGRASP_MODEL_DIR "/targets/mug.stl"));
    facets_ = std::make_unique<UnitFacets>(tessellate(*mesh_, 0.008));
    PairIndexOptions o;
    o.d_max = 0.2;
    o.threads = 1;
    index_ = std::make_optional<PairIndex>(facets_->points, facets_->normals, facets_->free, o);
    const Eigen::VectorXd lo = hand_->dof_lower(), hi = hand_->dof_upper();
    for (double s : {0.0, 0.5}) {
      for (double f : {0.3, 0.6, 0.9}) {
        Eigen::VectorXd q = lo + f * (hi - lo);
        q[0] = lo[0] + s * (hi[0] - lo[0]);
        samples_.push_back(q);
        constellations_.push_back(hand_->constellation(q, ConstellationMode::PerLink));
      }
    }
  }
  static void TearDownTestSuite() {
    index_.reset();
    facets_.reset();
    mesh_.reset();
    hand_.reset();
  }

  static std::unique_ptr<Hand> hand_;
  static std::unique_ptr<Mesh> mesh_;
  static std::unique_ptr<UnitFacets> facets_;
  static std::optional<PairIndex> index_;
  static std::vector<Eigen::VectorXd> samples_;
  static std::vector<Constellation> constellations_;
};

std::unique_ptr<Hand> Concurrency::hand_;
std::unique_ptr<Mesh> Concurrency::mesh_;
std::unique_ptr<UnitFacets> Concurrency::facets_;
std::optional<PairIndex> Concurrency::index_;
std::vector<Eigen::VectorXd> Concurrency::samples_;
std::vector<Constellation> Concurrency::constellations_;

TEST_F(Concurrency, PairIndexBuiltOnSeveralThreadsAtOnceEqualsSerial) {
  PairIndexOptions o;
  o.d_max = 0.2;
  o.threads = 2;
  std::vector<std::unique_ptr<PairIndex>> built(kCallers);
  on_callers([&](int t) { built[t] = std::make_unique<PairIndex>(facets_->points, facets_->normals, facets_->free, o); });
  for (const auto& b : built) {
    ASSERT_EQ(b->size(), index_->size());
    EXPECT_TRUE(b->pairs() == index_->pairs());
    EXPECT_TRUE(b->features() == index_->features());
    EXPECT_EQ(b->node_boxes(), index_->node_boxes());
  }
}

TEST_F(Concurrency, AlignAndAlignManyFromSeveralThreadsEqualSerial) {
  AlignerOptions serial_options;
  serial_options.threads = 1;
  const Aligner serial(*index_, serial_options);
  std::vector<AlignResult> ref;
  for (const auto& c : constellations_) ref.push_back(serial.align(c.points, c.normals));
  ASSERT_FALSE(ref.front().poses.empty());

  AlignerOptions o;
  o.threads = 2;
  const Aligner shared(*index_, o);
  std::vector<std::vector<AlignResult>> many(kCallers), one(kCallers);
  on_callers([&](int t) {
    many[t] = shared.align_many(constellations_);
    // Each caller also aligns one at a time, starting at a different constellation.
    for (std::size_t k = 0; k < constellations_.size(); ++k) {
      const auto& c = constellations_[(k + t) % constellations_.size()];
      one[t].push_back(shared.align(c.points, c.normals));
    }
  });
  for (int t = 0; t < kCallers; ++t) {
    ASSERT_EQ(many[t].size(), ref.size());
    for (std::size_t k = 0; k < ref.size(); ++k) {
      EXPECT_TRUE(same(many[t][k], ref[k])) << "align_many, caller " << t << ", constellation " << k;
      EXPECT_TRUE(same(one[t][k], ref[(k + t) % ref.size()])) << "align, caller " << t << ", call " << k;
    }
  }
}

TEST_F(Concurrency, CheckManyAndCloseFromSeveralThreadsEqualSerial) {
  // Wrist poses from the alignments, with the DOF samples they came from.
  AlignerOptions ao;
  ao.threads = 1;
  ao.max_poses = 3;
  const Aligner aligner(*index_, ao);
  std::vector<Pose> wrists;
  std::vector<Eigen::VectorXd> dofs;
  for (std::size_t k = 0; k < constellations_.size(); ++k)
    for (const auto& p : aligner.align(constellations_[k].points, constellations_[k].normals).poses) {
      wrists.push_back(p.pose());
      dofs.push_back(samples_[k]);
    }
  ASSERT_GE(wrists.size(), 6u);

  CheckOptions co;
  co.depth_tolerance = 0.002;
  co.threads = 2;
  const GraspChecker checker(*hand_, *mesh_, Mask(), {}, co);
  std::vector<CheckResult> ref;
  for (std::size_t k = 0; k < wrists.size(); ++k) ref.push_back(checker.check(wrists[k], dofs[k]));
  const std::size_t n_close = 4;
  std::vector<CloseResult> close_ref;
  for (std::size_t k = 0; k < n_close; ++k) close_ref.push_back(close_fingers(checker, wrists[k], hand_->dof_lower()));

  std::vector<std::vector<CheckResult>> many(kCallers);
  std::vector<std::vector<CloseResult>> closed(kCallers);
  on_callers([&](int t) {
    many[t] = checker.check_many(wrists, dofs, 2);
    for (std::size_t k = 0; k < n_close; ++k)
      closed[t].push_back(close_fingers(checker, wrists[(k + t) % n_close], hand_->dof_lower()));
  });
  for (int t = 0; t < kCallers; ++t) {
    ASSERT_EQ(many[t].size(), ref.size());
    for (std::size_t k = 0; k < ref.size(); ++k) EXPECT_TRUE(same(many[t][k], ref[k])) << "caller " << t << ", pose " << k;
    for (std::size_t k = 0; k < n_close; ++k)
      EXPECT_TRUE(same(closed[t][k], close_ref[(k + t) % n_close])) << "close, caller " << t << ", call " << k;
  }
}

TEST_F(Concurrency, PlannersSetUpOnSeveralThreadsAtOnceEqualSerial) {
  // A planner builds its pair index and its checker's distance fields at once, each a parallel
  // loop nested in an item of another: with several callers doing so together, threads that wait
  // for their own loop run items of the others' loops. Everything equals a one-thread build.
  PlannerOptions serial;
  serial.threads = 1;
  serial.edge = 0.008;
  const GraspPlanner ref(*hand_, *mesh_, Mask(), {}, serial);
  // Aligned poses (unsettled: they penetrate) checked with exact depths.
  std::vector<Pose> wrists;
  std::vector<Eigen::VectorXd> dofs;
  const std::vector<AlignResult> aligned = ref.align(samples_);
  for (std::size_t k = 0; k < aligned.size(); ++k)
    for (const AlignedPose& p : aligned[k].poses) wrists.push_back(p.pose()), dofs.push_back(samples_[k]);
  std::vector<CheckResult> ref_checks;
  int pruned = 0;
  for (std::size_t k = 0; k < wrists.size(); ++k) {
    ref_checks.push_back(ref.checker().check(wrists[k], dofs[k], true));
    pruned += ref_checks.back().pruned;
  }
  ASSERT_GT(pruned, 0);
  PlannerOptions two = serial;
  two.threads = 2;
  std::vector<std::unique_ptr<GraspPlanner>> built(kCallers);
  on_callers([&](int t) { built[t] = std::make_unique<GraspPlanner>(*hand_, *mesh_, Mask(), std::vector<Obstacle>{}, two); });
  for (int t = 0; t < kCallers; ++t) {
    const PairIndex& a = built[t]->target_index().index;
    ASSERT_EQ(a.size(), ref.target_index().index.size()) << "caller " << t;
    EXPECT_TRUE(a.pairs() == ref.target_index().index.pairs()) << "caller " << t;
    EXPECT_TRUE(a.features() == ref.target_index().index.features()) << "caller " << t;
    for (std::size_t k = 0; k < wrists.size(); ++k)
      EXPECT_TRUE(same(built[t]->checker().check(wrists[k], dofs[k], true), ref_checks[k])) << "caller " << t << ", pose " << k;
  }
}

TEST_F(Concurrency, AreaConstellationsComputedOnSeveralThreadsAtOnceAgree) {
  // The first request of a spacing fills the hand's sample cache: every caller asks at once.
  const Hand hand = Hand::load(PAIRGRASP_MODEL_DIR "/barrett/barrett.json");
  const Eigen::VectorXd q = samples_[1];
  std::vector<Constellation> got(kCallers);
  on_callers([&](int t) { got[t] = hand.constellation(q, ConstellationMode::Area, 0.012); });
  const Constellation ref = Hand::load(PAIRGRASP_MODEL_DIR "/barrett/barrett.json")
                                .constellation(q, ConstellationMode::Area, 0.012);
  ASSERT_GT(ref.points.rows(), 7);
  for (const auto& c : got) {
    EXPECT_TRUE(c.points == ref.points);
    EXPECT_TRUE(c.normals == ref.normals);
    EXPECT_EQ(c.link, ref.link);
  }
}

TEST_F(Concurrency, SearchesOnOneSharedPlannerFromSeveralThreadsEqualSerial) {
  // Each caller runs a whole search (align, settle, evaluate, fine-tune, robust scoring) on the
  // same planner with two threads of its own; every result equals a one-thread search's.
  PlannerOptions po;
  po.threads = 1;
  po.edge = 0.008;
  const GraspPlanner serial(*hand_, *mesh_, Mask(), {}, po);
  po.threads = 2;
  const GraspPlanner shared(*hand_, *mesh_, Mask(), {}, po);
  PlanOptions o;
  o.top = 3;
  o.fine_tune = 2;
  o.fine_tune_iterations = 4;
  o.seed = 7;
  o.rank = Ranking::Robust;
  o.robust_samples = 3;
  o.chunk = 4;
  const PlanReport ref = plan_samples(serial, samples_, o);
  ASSERT_FALSE(ref.grasps.empty());
  std::vector<PlanReport> got(kCallers);
  on_callers([&](int t) { got[t] = plan_samples(shared, samples_, o); });
  for (int t = 0; t < kCallers; ++t) {
    ASSERT_EQ(got[t].grasps.size(), ref.grasps.size()) << "caller " << t;
    ASSERT_EQ(got[t].candidates.size(), ref.candidates.size()) << "caller " << t;
    for (std::size_t k = 0; k < ref.grasps.size(); ++k) {
      EXPECT_EQ(got[t].grasps[k].quality.epsilon, ref.grasps[k].quality.epsilon) << "caller " << t << ", rank " << k;
      EXPECT_TRUE(got[t].grasps[k].evaluation.wrist.matrix() == ref.grasps[k].evaluation.wrist.matrix());
      ASSERT_TRUE(got[t].grasps[k].robust && ref.grasps[k].robust);
      EXPECT_EQ(got[t].grasps[k].robust->force_closure_probability, ref.grasps[k].robust->force_closure_probability);
    }
    EXPECT_EQ(got[t].counts, ref.counts) << "caller " << t;
  }
}

TEST_F(Concurrency, ASecondCallerOfOneSearchIsRefused) {
  PlannerOptions po;
  po.edge = 0.008;
  const GraspPlanner planner(*hand_, *mesh_, Mask(), {}, po);
  GraspSearch search(planner);
  std::vector<Eigen::VectorXd> many;
  for (int r = 0; r < 8; ++r) many.insert(many.end(), samples_.begin(), samples_.end());
  std::atomic<bool> done{false};
  std::thread worker([&] {
    for (;;) {  // finish() below may hold the search when this starts: retry until it runs
      try {
        search.add_samples(many);
        break;
      } catch (const BusyError&) {
      }
    }
    done = true;
  });
  bool refused = false;
  std::string message;
  while (!refused && !done) {
    try {
      search.finish();
    } catch (const BusyError& e) {
      refused = true;
      message = e.what();
    }
  }
  worker.join();
  ASSERT_TRUE(refused) << "the search finished before a second call could overlap it";
  EXPECT_NE(message.find("GraspSearch"), std::string::npos) << message;
  EXPECT_EQ(search.samples().size(), many.size());  // the first caller's call was not disturbed
}

}  // namespace
