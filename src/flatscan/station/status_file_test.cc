#include "flatscan/station/status_file.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "flatscan/store/store_test_util.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

nlohmann::json Read(const std::filesystem::path& path) { return nlohmann::json::parse(testing::ReadFileBytes(path)); }

// Not ready while the source fails pair after pair (the records go on), running again
// once a pair comes through, and the reason beside the state.
TEST(StatusFile, SaysNotReadyWithTheReasonUntilThePairsComeThroughAgain) {
  testing::ScratchDir dir("status");
  const auto path = dir.path() / "s.status.json";
  StatusFile status(path, "line1", "shield");
  EXPECT_EQ(Read(path)["state"], "running");
  EXPECT_TRUE(Read(path)["not_ready_reason"].is_null());
  StationCounts counts;
  counts.committed = counts.not_measured = 5;
  status.Readiness(false, "5 pairs in a row not delivered by cameras:A,B; the last: lost", counts);
  EXPECT_EQ(Read(path)["state"], "not_ready");
  EXPECT_EQ(Read(path)["not_ready_reason"], "5 pairs in a row not delivered by cameras:A,B; the last: lost");
  StationRecord record = testing::TestRecord("p6", std::string(64, 'a'), 0.05, "line1");
  record.sequence = 6;
  ++counts.committed;
  status.Publish(record, counts);  // another record: still not ready
  EXPECT_EQ(Read(path)["state"], "not_ready");
  EXPECT_EQ(Read(path)["committed"], 6);
  status.Readiness(true, "", counts);
  EXPECT_EQ(Read(path)["state"], "running");
  EXPECT_TRUE(Read(path)["not_ready_reason"].is_null());
  status.Stopped(counts);
  EXPECT_EQ(Read(path)["state"], "stopped");
}

}  // namespace
}  // namespace flatscan
