// Replays the fuzz harnesses' committed inputs (tests/fuzz/corpus/<target>/ and
// tests/fuzz/regressions/<target>/) through the same targets, in every build: each input must be
// loaded with its invariants intact or rejected with a FileError naming the file. Seed names say
// which: "ok_*" must load, "bad_*" must be rejected; regressions (inputs that once crashed or
// broke an invariant) only need to be handled cleanly.
#include "fuzz_targets.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using pairgrasp::fuzz::Outcome;

const char* const kTargets[] = {"mesh_stl", "mesh_obj", "mesh_ply", "mesh_dae", "hand", "paint"};

std::vector<fs::path> files_in(const fs::path& dir) {
  std::vector<fs::path> out;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file() && e.path().filename().string()[0] != '.') out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

Outcome replay(const std::string& target, const fs::path& file) {
  const std::string bytes = read_bytes(file);
  return pairgrasp::fuzz::run_target(target, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
}

class FuzzCorpus : public ::testing::TestWithParam<const char*> {
 protected:
  void SetUp() override { pairgrasp::fuzz::abort_on_bug() = false; }
};

TEST_P(FuzzCorpus, SeedsLoadOrAreRejectedAsNamed) {
  const std::string target = GetParam();
  const auto seeds = files_in(fs::path(PAIRGRASP_FUZZ_DIR) / "corpus" / target);
  int ok = 0, bad = 0;
  for (const fs::path& f : seeds) {
    const std::string name = f.filename().string();
    const bool want_ok = name.rfind("ok_", 0) == 0;
    ASSERT_TRUE(want_ok || name.rfind("bad_", 0) == 0) << f << ": a seed is named ok_* or bad_*";
    (want_ok ? ok : bad) += 1;
    try {
      EXPECT_EQ(replay(target, f), want_ok ? Outcome::Loaded : Outcome::Rejected) << f;
    } catch (const pairgrasp::fuzz::Bug& b) {
      ADD_FAILURE() << f << ": " << b.message;
    }
  }
  EXPECT_GT(ok, 0) << "no valid seed for " << target;
  EXPECT_GT(bad, 0) << "no broken seed for " << target;
}

TEST_P(FuzzCorpus, RegressionInputsAreHandledCleanly) {
  const std::string target = GetParam();
  for (const fs::path& f : files_in(fs::path(PAIRGRASP_FUZZ_DIR) / "regressions" / target)) {
    try {
      replay(target, f);
    } catch (const pairgrasp::fuzz::Bug& b) {
      ADD_FAILURE() << f << ": " << b.message;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Targets, FuzzCorpus, ::testing::ValuesIn(kTargets),
                         [](const ::testing::TestParamInfo<const char*>& info) { return std::string(info.param); });

}  // namespace
