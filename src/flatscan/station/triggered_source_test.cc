#include "flatscan/station/triggered_source.h"

#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
using namespace std::chrono_literals;

// A replay of three listed pairs (the files need not exist: the source only lists them).
class TriggeredSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ofstream(dir_.path() / "pairs.csv") << "id,left,right\na,a_l.png,a_r.png\nb,b_l.png,b_r.png\n"
                                                "c,c_l.png,c_r.png\n";
    inner_ = MakePairsFileSource(dir_.path() / "pairs.csv");
  }
  testing::ScratchDir dir_{"triggered"};
  std::unique_ptr<PairSource> inner_;
};

TEST_F(TriggeredSourceTest, OnePairPerTrigger) {
  TriggeredSource source(*inner_);
  EXPECT_FALSE(source.Next(50ms));  // no trigger, no pair, though three wait
  source.Trigger();
  const auto a = source.Next(50ms);
  ASSERT_TRUE(a);
  EXPECT_EQ(a->source_id, "a");
  EXPECT_FALSE(source.Next(50ms));
  source.Trigger();
  source.Trigger();
  EXPECT_EQ(source.Waiting(), 2u);
  EXPECT_EQ(source.Next(50ms)->source_id, "b");
  EXPECT_EQ(source.Next(50ms)->source_id, "c");
  EXPECT_EQ(source.Waiting(), 0u);
  EXPECT_EQ(source.Name(), inner_->Name() + " (triggered)");
}

TEST_F(TriggeredSourceTest, ATriggerFromAnotherThreadWakesAWaitingStation) {
  TriggeredSource source(*inner_);
  std::thread plc([&] {
    std::this_thread::sleep_for(100ms);
    source.Trigger();
  });
  const auto a = source.Next(10s);  // returns at the trigger, not after 10 s
  plc.join();
  ASSERT_TRUE(a);
  EXPECT_EQ(a->source_id, "a");
}

TEST_F(TriggeredSourceTest, ATriggerWithoutAPairWaitsForTheNextOne) {
  TriggeredSource source(*inner_);
  for (int i = 0; i < 4; ++i) source.Trigger();
  for (const char* id : {"a", "b", "c"}) EXPECT_EQ(source.Next(50ms)->source_id, id);
  EXPECT_FALSE(source.Next(50ms));  // the replay is at its end
  EXPECT_TRUE(source.Exhausted());
  EXPECT_EQ(source.Waiting(), 1u);
}

}  // namespace
}  // namespace flatscan
