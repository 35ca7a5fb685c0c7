// The camera pair source through Aravis's in-process fake cameras: frames as the
// dataset shows them, one pair per trigger, and the faults a line meets (a lost frame,
// a late camera, an incomplete buffer), each a "not measured" pair with its reason.
#include "flatscan/acquisition/camera_pair_source.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/io/image_io.h"
#include "flatscan/station/inspection_station.h"
#include "flatscan/station/recipe.h"
#include "flatscan/store/results_store.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;
using std::chrono::milliseconds;

// `n` pairs of 96 x 64 noise images (seeded: every image different) and their pairs.csv.
std::vector<std::pair<cv::Mat1b, cv::Mat1b>> WriteNoiseDataset(const fs::path& dir, int n) {
  std::mt19937 rng(7);
  std::vector<std::pair<cv::Mat1b, cv::Mat1b>> images;
  std::ofstream csv(dir / "pairs.csv");
  csv << "id,left,right\n";
  for (int k = 1; k <= n; ++k) {
    cv::Mat1b left(64, 96), right(64, 96);
    for (auto* image : {&left, &right})
      for (auto& p : *image) p = uint8_t(rng() & 0xff);
    WriteImage((dir / fmt::format("p{}_left.png", k)).string(), left);
    WriteImage((dir / fmt::format("p{}_right.png", k)).string(), right);
    csv << fmt::format("part-{},p{}_left.png,p{}_right.png\n", k, k, k);
    images.emplace_back(left, right);
  }
  return images;
}

bool Same(const cv::Mat1b& a, const cv::Mat1b& b) { return a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0; }

// The dataset with a fault at some triggers.
class FaultyScene : public FakeScene {
 public:
  FaultyScene(std::shared_ptr<FakeScene> scene, std::map<std::pair<int64_t, bool>, FakeTriggerFault> faults)
      : scene_(std::move(scene)), faults_(std::move(faults)) {}
  int64_t Triggers() const override { return scene_->Triggers(); }
  cv::Size FrameSize() const override { return scene_->FrameSize(); }
  std::string Id(int64_t trigger) const override { return scene_->Id(trigger); }
  void Fill(int64_t trigger, bool left, int width, int height, uint8_t* pixels) override {
    scene_->Fill(trigger, left, width, height, pixels);
  }
  FakeTriggerFault Fault(int64_t trigger, bool left) const override {
    const auto it = faults_.find({trigger, left});
    return it == faults_.end() ? FakeTriggerFault{} : it->second;
  }
  // The left camera is unplugged for the triggers [first, last]: it cannot be opened.
  void RemoveLeftCamera(int64_t first, int64_t last) { removed_ = {first, last}; }
  bool Present(int64_t trigger, bool left) const override {
    ++reopen_tries;
    return !left || trigger < removed_.first || trigger > removed_.second;
  }
  mutable int reopen_tries = 0;

 private:
  std::shared_ptr<FakeScene> scene_;
  std::map<std::pair<int64_t, bool>, FakeTriggerFault> faults_;
  std::pair<int64_t, int64_t> removed_{0, -1};
};

// The left fake camera lost at `trigger` (Aravis's control-lost signal).
std::map<std::pair<int64_t, bool>, FakeTriggerFault> LoseLeftCameraAt(int64_t trigger) {
  FakeTriggerFault lose;
  lose.lose = true;
  return {{{trigger, true}, lose}};
}

TEST(CameraPairSource, FakeCamerasShowTheDatasetPairByPairWithoutACopy) {
  testing::ScratchDir dir("fake_source");
  const auto images = WriteNoiseDataset(dir.path(), 3);
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  const auto source = MakeFakeSource("aravis-fake:test", MakeDatasetScene(dir.path().string()), options);
  for (int k = 1; k <= 3; ++k) {
    EXPECT_FALSE(source->Exhausted());
    const std::optional<SourcePair> pair = source->Next(milliseconds(2000));
    ASSERT_TRUE(pair);
    EXPECT_EQ(pair->source_id, fmt::format("part-{}", k));
    EXPECT_FALSE(pair->not_measurable) << *pair->not_measurable;
    ASSERT_TRUE(pair->frames);
    EXPECT_TRUE(Same(pair->left_image, images[size_t(k - 1)].first)) << k;
    EXPECT_TRUE(Same(pair->right_image, images[size_t(k - 1)].second)) << k;
    EXPECT_TRUE(pair->left.empty() && pair->right.empty());  // no file behind a frame
  }
  EXPECT_TRUE(source->Exhausted());
  EXPECT_EQ(source->Triggers(), 3);
  EXPECT_FALSE(source->Next(milliseconds(50)));  // no fourth trigger past the dataset
}

// Mono16 through the fakes (each grey level v sent as v * 257): reduced to the dataset's
// pixels exactly. Mono12, which the fake does not offer: the camera and format named.
TEST(CameraPairSource, SixteenBitFramesAreReducedToTheEightBitsTheyCameFrom) {
  testing::ScratchDir dir("fake_mono16");
  const auto images = WriteNoiseDataset(dir.path(), 2);
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.acquisition.pixel_format = PixelFormat::kMono16;
  const auto source = MakeFakeSource("aravis-fake:test", MakeDatasetScene(dir.path().string()), options);
  for (int k = 1; k <= 2; ++k) {
    const std::optional<SourcePair> pair = source->Next(milliseconds(2000));
    ASSERT_TRUE(pair);
    ASSERT_FALSE(pair->not_measurable) << *pair->not_measurable;
    EXPECT_TRUE(Same(pair->left_image, images[size_t(k - 1)].first)) << k;
    EXPECT_TRUE(Same(pair->right_image, images[size_t(k - 1)].second)) << k;
  }
  options.acquisition.pixel_format = PixelFormat::kMono12;
  EXPECT_EQ(testing::InputErrorOf([&] { MakeFakeSource("aravis-fake:test", MakeDatasetScene(dir.path().string()), options); })
                .rfind("camera Aravis Fake (FAKE-LEFT): cannot set pixel format Mono12: ", 0),
            0u);
}

TEST(CameraPairSource, ABufferComesBackToTheCameraOnlyWhenItsPairIsDone) {
  testing::ScratchDir dir("fake_buffers");
  const auto images = WriteNoiseDataset(dir.path(), 4);
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.acquisition.buffers = 2;
  const auto source = MakeFakeSource("aravis-fake:test", MakeDatasetScene(dir.path().string()), options);
  std::optional<SourcePair> first = source->Next(milliseconds(2000)), second = source->Next(milliseconds(2000));
  ASSERT_TRUE(first && second);
  EXPECT_FALSE(second->not_measurable);
  // Both buffers are held: the third trigger finds none, its frames are lost, and the
  // pairs held are untouched.
  const std::optional<SourcePair> third = source->Next(milliseconds(2000));
  ASSERT_TRUE(third);
  ASSERT_TRUE(third->not_measurable);
  EXPECT_EQ(*third->not_measurable, "the left camera gave no frame within 1000 ms of trigger 3");
  EXPECT_TRUE(Same(first->left_image, images[0].first));
  first.reset();  // its buffers go back
  const std::optional<SourcePair> fourth = source->Next(milliseconds(2000));
  ASSERT_TRUE(fourth);
  EXPECT_FALSE(fourth->not_measurable);
  EXPECT_TRUE(Same(fourth->left_image, images[3].first));
  EXPECT_TRUE(Same(second->right_image, images[1].second));
}

// Every fault: one pair per trigger, the reason named, and the pairs after it right.
TEST(CameraPairSource, FaultsGiveNotMeasuredPairsAndTheNextTriggerIsRight) {
  testing::ScratchDir dir("fake_faults");
  const auto images = WriteNoiseDataset(dir.path(), 6);
  FakeTriggerFault drop, late, incomplete;
  drop.drop = true;
  late.delay = milliseconds(60);
  incomplete.incomplete = true;
  auto scene = std::make_shared<FaultyScene>(MakeDatasetScene(dir.path().string()),
                                             std::map<std::pair<int64_t, bool>, FakeTriggerFault>{
                                                 {{2, true}, drop}, {{3, false}, late}, {{5, false}, incomplete}});
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.frame_timeout = milliseconds(300);
  const auto source = MakeFakeSource("aravis-fake:test", scene, options);
  std::vector<SourcePair> pairs;
  while (!source->Exhausted())
    if (auto pair = source->Next(milliseconds(2000))) pairs.push_back(std::move(*pair));
  ASSERT_EQ(pairs.size(), 6u);  // one per trigger
  EXPECT_EQ(source->Triggers(), 6);
  const auto reason = [&](size_t k) { return pairs[k - 1].not_measurable.value_or(""); };
  EXPECT_EQ(reason(2), "the left camera gave no frame within 300 ms of trigger 2");
  EXPECT_NE(reason(3).find("cameras out of sync: the frames of trigger 3 are "), std::string::npos) << reason(3);
  EXPECT_NE(reason(3).find(" ms apart (limit 20 ms)"), std::string::npos) << reason(3);
  EXPECT_EQ(reason(5), "the right camera's frame of trigger 5 is incomplete: size mismatch (the frame did not fit the "
                       "buffer)");
  for (const size_t k : {1, 4, 6}) {
    EXPECT_EQ(reason(k), "") << k;
    EXPECT_TRUE(Same(pairs[k - 1].left_image, images[k - 1].first)) << k;
    EXPECT_TRUE(Same(pairs[k - 1].right_image, images[k - 1].second)) << k;
  }
}

TEST(CameraPairSource, ReconnectionWaitsLongerAfterEachFailedAttempt) {
  const milliseconds first(500), most(30000);
  std::vector<long> delays;
  for (int failed = 0; failed <= 8; ++failed) delays.push_back(long(ReconnectDelay(failed, first, most).count()));
  EXPECT_EQ(delays, (std::vector<long>{500, 1000, 2000, 4000, 8000, 16000, 30000, 30000, 30000}));
  EXPECT_EQ(ReconnectDelay(1000000, first, most).count(), 30000);  // no overflow
}

// A camera unplugged at trigger 3 and plugged in again before trigger 6: a record per
// trigger, the reason for each, the camera opened again and its frames right.
TEST(CameraPairSource, ACameraRemovedAndAddedAgainIsReconnected) {
  testing::ScratchDir dir("fake_reconnect");
  const auto images = WriteNoiseDataset(dir.path(), 7);
  auto scene = std::make_shared<FaultyScene>(MakeDatasetScene(dir.path().string()), LoseLeftCameraAt(3));
  scene->RemoveLeftCamera(3, 5);
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.reconnect_first = milliseconds(0);  // an attempt at every trigger: the test does not wait
  const auto source = MakeFakeSource("aravis-fake:test", scene, options);
  const std::shared_ptr<AravisCamera> first_left = source->Camera(true);
  std::vector<SourcePair> pairs;
  while (!source->Exhausted())
    if (auto pair = source->Next(milliseconds(2000))) pairs.push_back(std::move(*pair));
  ASSERT_EQ(pairs.size(), 7u);
  const auto reason = [&](size_t k) { return pairs[k - 1].not_measurable.value_or(""); };
  const std::string lost = "the left camera is lost since trigger 3 (camera Aravis Fake (FAKE-LEFT): lost (it stopped "
                           "answering on its control channel))";
  EXPECT_EQ(reason(3), "trigger 3: camera Aravis Fake (FAKE-LEFT): lost (it stopped answering on its control channel)");
  EXPECT_EQ(reason(4).rfind("trigger 4: " + lost + "; reconnection attempt 1 failed (camera 'FAKE-LEFT': not found "
                            "among the GenICam cameras found); next in 0.",
                            0),
            0u)
      << reason(4);
  EXPECT_EQ(reason(5).rfind("trigger 5: " + lost + "; reconnection attempt 2 failed", 0), 0u) << reason(5);
  for (const size_t k : {3, 4, 5}) EXPECT_TRUE(pairs[k - 1].source_fault) << k;
  for (const size_t k : {1, 2, 6, 7}) {
    EXPECT_EQ(reason(k), "") << k;
    EXPECT_TRUE(Same(pairs[k - 1].left_image, images[k - 1].first)) << k;
    EXPECT_TRUE(Same(pairs[k - 1].right_image, images[k - 1].second)) << k;
  }
  EXPECT_EQ(source->Reconnections(), 1);
  EXPECT_NE(source->Camera(true), first_left);  // a new camera object: the lost one was closed
  EXPECT_TRUE(Same(pairs[0].left_image, images[0].first));  // a frame of the closed camera is still valid
}

// A lost camera is not opened at every trigger: the first attempt waits reconnect_first.
TEST(CameraPairSource, ALostCameraIsRetriedOnlyWhenItsWaitIsOver) {
  testing::ScratchDir dir("fake_backoff");
  WriteNoiseDataset(dir.path(), 5);
  auto scene = std::make_shared<FaultyScene>(MakeDatasetScene(dir.path().string()), LoseLeftCameraAt(2));
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.reconnect_first = milliseconds(3'600'000);
  const auto source = MakeFakeSource("aravis-fake:test", scene, options);
  std::vector<SourcePair> pairs;
  while (!source->Exhausted())
    if (auto pair = source->Next(milliseconds(2000))) pairs.push_back(std::move(*pair));
  ASSERT_EQ(pairs.size(), 5u);
  EXPECT_FALSE(pairs[0].not_measurable);
  for (size_t k = 3; k <= 5; ++k)
    EXPECT_EQ(pairs[k - 1].not_measurable.value_or("").rfind(
                  fmt::format("trigger {}: the left camera is lost since trigger 2 (camera Aravis Fake (FAKE-LEFT): "
                              "lost (it stopped answering on its control channel)); reconnecting in 3",
                              k),
                  0),
              0u)
        << *pairs[k - 1].not_measurable;
  EXPECT_EQ(scene->reopen_tries, 0);
  EXPECT_EQ(source->Reconnections(), 0);
  EXPECT_FALSE(source->Camera(true));
}

// The skew measured on the cameras' own clocks (PTP-synchronised cameras): the right
// camera exposing 60 ms late (the left is triggered first) is out of sync by them, the
// others are pairs.
TEST(CameraPairSource, TheSkewCanBeMeasuredOnTheCamerasClocks) {
  testing::ScratchDir dir("fake_camera_clock");
  const auto images = WriteNoiseDataset(dir.path(), 3);
  FakeTriggerFault late;
  late.delay = milliseconds(60);
  auto scene = std::make_shared<FaultyScene>(MakeDatasetScene(dir.path().string()),
                                             std::map<std::pair<int64_t, bool>, FakeTriggerFault>{{{2, false}, late}});
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.skew_clock = CameraSourceOptions::Clock::kCamera;
  const auto source = MakeFakeSource("aravis-fake:test", scene, options);
  std::vector<SourcePair> pairs;
  while (!source->Exhausted())
    if (auto pair = source->Next(milliseconds(2000))) pairs.push_back(std::move(*pair));
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_FALSE(pairs[0].not_measurable);
  EXPECT_FALSE(pairs[2].not_measurable);
  EXPECT_TRUE(Same(pairs[2].left_image, images[2].first));
  const std::string reason = pairs[1].not_measurable.value_or("");
  EXPECT_EQ(reason.rfind("cameras out of sync: the frames of trigger 2 are ", 0), 0u) << reason;
  EXPECT_NE(reason.find(" ms apart (limit 20 ms) on the cameras' clocks (are both synchronised by PTP?)"),
            std::string::npos)
      << reason;
}

// line0: a fake line pulsing at 20 Hz, both fake cameras on it; the frames paired by
// their timestamps, in the dataset's order.
TEST(CameraPairSource, OnALineTheFramesArePairedByTheirTimestamps) {
  testing::ScratchDir dir("fake_line");
  const auto images = WriteNoiseDataset(dir.path(), 4);
  CameraSourceOptions options;
  options.acquisition.trigger = TriggerSource::kLine0;
  options.acquisition.fake_line_hz = 20;
  const auto source = MakeFakeSource("aravis-fake:test", MakeDatasetScene(dir.path().string()), options);
  for (int k = 1; k <= 4; ++k) {
    const std::optional<SourcePair> pair = source->Next(milliseconds(2000));
    ASSERT_TRUE(pair);
    EXPECT_EQ(pair->source_id, fmt::format("part-{}", k));
    ASSERT_FALSE(pair->not_measurable) << *pair->not_measurable;
    EXPECT_TRUE(Same(pair->left_image, images[size_t(k - 1)].first)) << k;
    EXPECT_TRUE(Same(pair->right_image, images[size_t(k - 1)].second)) << k;
  }
  EXPECT_TRUE(source->Exhausted());
}

// The recipe's exposure and gain reach both cameras; settings a camera refuses make the
// pairs "not measured" until a recipe it takes.
TEST(CameraPairSource, TheRecipeSetsExposureAndGain) {
  testing::ScratchDir dir("fake_settings");
  WriteNoiseDataset(dir.path(), 3);
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.acquisition.exposure_us = 500;
  const auto source = MakeFakeSource("aravis-fake:test", MakeDatasetScene(dir.path().string()), options);
  EXPECT_EQ(source->Camera(true)->ExposureUs(), 500);  // from the start
  Recipe recipe;
  recipe.name = "bright";
  recipe.camera.exposure_us = 800;
  recipe.camera.gain_db = 6;
  source->UseRecipe(recipe);
  for (const bool left : {true, false}) {
    EXPECT_EQ(source->Camera(left)->ExposureUs(), 800);
    EXPECT_EQ(source->Camera(left)->GainDb(), 6);
  }
  EXPECT_FALSE(source->Next(milliseconds(2000))->not_measurable);
  recipe.name = "too-much";
  recipe.camera.gain_db = 40;  // the fake's gain goes to 10
  source->UseRecipe(recipe);
  const std::string reason = source->Next(milliseconds(2000))->not_measurable.value_or("");
  EXPECT_EQ(reason.rfind("recipe too-much: camera Aravis Fake (FAKE-LEFT): cannot set the gain to 40 dB: ", 0), 0u)
      << reason;
  recipe.camera.gain_db = 2;
  source->UseRecipe(recipe);
  EXPECT_FALSE(source->Next(milliseconds(2000))->not_measurable);
}

// Records what the station tells its publishers, in order.
class EventLog : public RecordPublisher {
 public:
  void Publish(const StationRecord& record, const StationCounts&) override {
    events.push_back(record.source_id + (record.inspection.measured ? " measured" : " not measured"));
  }
  void Readiness(bool ready, const std::string& reason, const StationCounts&) override {
    events.push_back(ready ? "ready" : "not ready");
    if (!ready) not_ready_reason = reason;
  }
  std::vector<std::string> events;
  std::string not_ready_reason;
};

// A simulated part shown seven times (p1 ... p7, compact rig) and its recipe, shield.yml;
// empty when the simulation failed.
fs::path SevenShotsOfOnePart(const fs::path& dir) {
  const auto sim = testing::RunFlatscan("simulate --preset compact --parts 1 --no-calibration --no-markers --seed 4 "
                                        "-q -o " + (dir / "data").string());
  EXPECT_EQ(sim.exit_code, 0) << sim.err;
  if (sim.exit_code != 0) return {};
  const fs::path data = dir / "data";
  std::ofstream csv(data / "pairs.csv");
  csv << "id,left,right\n";
  for (int k = 1; k <= 7; ++k) csv << fmt::format("p{},parts/part_000_left.png,parts/part_000_right.png\n", k);
  std::ofstream(data / "shield.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.25\n"
                                        "rig: rig.yml\nplane: plane_true.yml\n";
  return data;
}

// A camera that loses frame after frame: each trigger still gets its record, the
// station says it is not ready after not_ready_after of them in a row, and ready again
// when a pair comes through.
TEST(CameraPairSource, FramesLostInARowMakeTheStationNotReadyUntilOneComesThrough) {
  testing::ScratchDir dir("fake_not_ready");
  const fs::path data = SevenShotsOfOnePart(dir.path());
  ASSERT_FALSE(data.empty());
  FakeTriggerFault drop;
  drop.drop = true;
  std::map<std::pair<int64_t, bool>, FakeTriggerFault> faults;
  for (int64_t k = 2; k <= 5; ++k) faults[{k, true}] = drop;
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.frame_timeout = milliseconds(300);
  const auto source = MakeFakeSource(
      "aravis-fake:test", std::make_shared<FaultyScene>(MakeDatasetScene(data.string()), faults), options);
  auto store = OpenSqliteStore((dir.path() / "results.db").string(), true);
  StationOptions station_options;
  station_options.until_idle_s = 1;
  station_options.not_ready_after = 3;
  InspectionStation station({LoadRecipe(data / "shield.yml")}, *source, *store, station_options);
  EventLog log;
  station.AddPublisher(&log);
  const std::atomic<bool> stop{false};
  const StationCounts counts = station.Run(stop);
  EXPECT_EQ(counts.committed, 7);  // one record per trigger
  EXPECT_EQ(source->Triggers(), 7);
  EXPECT_EQ(log.events, (std::vector<std::string>{"p1 measured", "p2 not measured", "p3 not measured",
                                                  "p4 not measured", "not ready", "p5 not measured", "p6 measured",
                                                  "ready", "p7 measured"}));
  EXPECT_EQ(log.not_ready_reason, "3 pairs in a row not delivered by aravis-fake:test; the last: the left camera gave "
                                  "no frame within 300 ms of trigger 4");
}

// The station through a camera unplugged at trigger 2 and back before trigger 6: a
// record per trigger, not ready while it is gone, ready again and measuring after.
TEST(CameraPairSource, TheStationKeepsRunningThroughACameraUnpluggedAndBack) {
  testing::ScratchDir dir("fake_unplugged");
  const fs::path data = SevenShotsOfOnePart(dir.path());
  ASSERT_FALSE(data.empty());
  auto scene = std::make_shared<FaultyScene>(MakeDatasetScene(data.string()), LoseLeftCameraAt(2));
  scene->RemoveLeftCamera(2, 5);
  CameraSourceOptions options;
  options.trigger_on_demand = true;
  options.reconnect_first = milliseconds(0);
  const auto source = MakeFakeSource("aravis-fake:test", scene, options);
  auto store = OpenSqliteStore((dir.path() / "results.db").string(), true);
  StationOptions station_options;
  station_options.until_idle_s = 1;
  station_options.not_ready_after = 3;
  InspectionStation station({LoadRecipe(data / "shield.yml")}, *source, *store, station_options);
  EventLog log;
  station.AddPublisher(&log);
  const std::atomic<bool> stop{false};
  EXPECT_EQ(station.Run(stop).committed, 7);
  EXPECT_EQ(log.events, (std::vector<std::string>{"p1 measured", "p2 not measured", "p3 not measured",
                                                  "p4 not measured", "not ready", "p5 not measured", "p6 measured",
                                                  "ready", "p7 measured"}));
  EXPECT_EQ(log.not_ready_reason.rfind("3 pairs in a row not delivered by aravis-fake:test; the last: trigger 4: the "
                                       "left camera is lost since trigger 2",
                                       0),
            0u)
      << log.not_ready_reason;
  EXPECT_EQ(source->Reconnections(), 1);
}

// A station told to stop with triggers fired and not yet taken: it fires no more, and
// records every one fired before it stops.
TEST(CameraPairSource, AStoppingStationRecordsEveryTriggerAlreadyFired) {
  testing::ScratchDir dir("fake_stop_drain");
  const fs::path data = SevenShotsOfOnePart(dir.path());
  ASSERT_FALSE(data.empty());
  CameraSourceOptions options;  // triggered from outside, as by --trigger-rate or the PLC
  const auto source = MakeFakeSource("aravis-fake:test", MakeDatasetScene(data.string()), options);
  for (int k = 0; k < 5; ++k) source->Trigger();
  auto store = OpenSqliteStore((dir.path() / "results.db").string(), true);
  InspectionStation station({LoadRecipe(data / "shield.yml")}, *source, *store, StationOptions{});
  const std::atomic<bool> stop{true};  // a SIGTERM before the station took any pair
  EXPECT_EQ(station.Run(stop).committed, 5);
  source->Trigger();  // a trigger after the stop is not taken
  EXPECT_EQ(source->Triggers(), 5);
  EXPECT_FALSE(source->HasPending());
}

TEST(CameraPairSource, NamesACameraSpecItCannotUse) {
  const CameraInterfaces fake = CameraInterfaces::FakeOnly();  // nothing sent on a network
  EXPECT_EQ(testing::InputErrorOf([&] { MakeCameraSource("cameras:A", {}, fake); }),
            "source: 'cameras:A': expected cameras:LEFT,RIGHT (each camera's id or serial, from `flatscan cameras`)");
  EXPECT_EQ(testing::InputErrorOf([&] { MakeCameraSource("cameras:A,A", {}, fake); }),
            "source: 'cameras:A,A': the left and the right camera are the same camera");
  EXPECT_EQ(testing::InputErrorOf([&] { MakeCameraSource("cameras:NO-SUCH-1,Fake_1", {}, fake); }),
            "camera 'NO-SUCH-1': not found among the 1 GenICam camera(s) found (`flatscan cameras` lists them by id "
            "and serial)");
}

}  // namespace
}  // namespace flatscan
