#pragma once
// The station's camera source: two cameras, one trigger, one pair per trigger.
//
//   cameras:LEFT,RIGHT   two GenICam cameras, each named by id or serial (`flatscan cameras`)
//   aravis-fake:DIR      two Aravis in-process fake cameras showing, trigger by trigger,
//                        the pairs of a simulated dataset (DIR/pairs.csv): demos and tests
//
// Every trigger gives exactly one pair, so the record count is the trigger count: the
// two frames, measured where the camera put them (no copy), or a "not measured" pair
// saying why:
//   - a camera gave no frame within `frame_timeout` of the trigger (a lost frame);
//   - a frame arrived incomplete (Aravis's buffer status: missing packets, ...);
//   - the two frames' timestamps are further apart than `max_skew`: "cameras out of
//     sync" (a trigger one camera missed pairs the wrong frames otherwise).
// Timestamps are the host's arrival times (one clock for both cameras; the cameras' own
// clocks are not synchronised without PTP). A frame that arrives after its trigger's
// timeout is discarded when the next trigger looks for frames (it is older than that
// trigger), so it can never be paired with the wrong part.
//
// A camera that disappears (Aravis's control-lost, or a trigger it refuses) is closed and
// opened again with a growing wait between attempts (ReconnectDelay); every trigger
// meanwhile is a "not measured" pair saying since when it is gone.
//
// Triggers: `software` fires both cameras from Trigger() (a rate, the PLC's register 12)
// or, with trigger_on_demand, whenever the station asks for a pair and none is waiting;
// `line0` leaves triggering to the wiring (both cameras on one input line) and pairs the
// frames as they come by their timestamps: a frame with no partner within max_skew is
// reported alone.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "flatscan/acquisition/aravis_camera.h"
#include "flatscan/io/pairs_csv.h"
#include "flatscan/station/pair_source.h"

namespace flatscan {

struct CameraSourceOptions {
  AcquisitionSettings acquisition;  // trigger source, exposure, gain, buffers
  bool trigger_on_demand = false;   // software: Next() fires when no trigger waits
  // A trigger's frames must have arrived by then. Exposure plus transfer: a 5 MP Mono8
  // frame takes about 45 ms over Gigabit Ethernet; a second leaves room for a busy host.
  std::chrono::milliseconds frame_timeout{1000};
  // Two frames of one trigger arrive within a few ms of each other (the transfer
  // differs); a missed trigger shifts the pairing by a whole part period (100 ms or more
  // on a line): 20 ms tells the two apart.
  std::chrono::milliseconds max_skew{20};
  // Whose clock the skew is measured on: the host's (when each frame arrived: one clock
  // for both, but the transfer's jitter is in it), or the cameras' own (when each frame
  // was exposed: exact, but only when PTP, IEEE 1588, synchronises the two cameras;
  // unsynchronised clocks put every pair out of sync, and the reason says so).
  enum class Clock { kHost, kCamera } skew_clock = Clock::kHost;
  // A camera lost (ControlLost, or a trigger it refused) is opened again after
  // reconnect_first, then after twice the last wait each time it fails, at most
  // reconnect_max: a camera back after a power cycle (a few seconds) is found within a
  // second or two of it, and one gone for good costs a discovery (about 1 s on GigE) every
  // 30 s, not at every trigger.
  std::chrono::milliseconds reconnect_first{500};
  std::chrono::milliseconds reconnect_max{30000};
};

// The wait before the attempt after `failed_attempts` failed ones (0: the first attempt):
// first * 2^failed_attempts, at most `max`.
std::chrono::milliseconds ReconnectDelay(int failed_attempts, std::chrono::milliseconds first,
                                         std::chrono::milliseconds max);

// Opens one of the source's cameras again after it was lost (by id or serial, as at the
// start). `next_trigger` is the trigger about to fire: a fake scene decides by it
// whether its camera is back. Throws InputError when the camera cannot be opened.
using CameraOpener = std::function<std::unique_ptr<AravisCamera>(int64_t next_trigger)>;

// What two fake cameras show at each trigger (aravis-fake:DIR, tests). Triggers are
// numbered from 1.
class FakeScene {
 public:
  virtual ~FakeScene() = default;
  virtual int64_t Triggers() const = 0;  // triggers it has a pair for
  virtual cv::Size FrameSize() const = 0;
  virtual std::string Id(int64_t trigger) const = 0;
  // Makes the trigger's frames ready before the cameras are given their buffers (on the
  // triggering thread; on a fake line, a few pairs ahead): a fill that takes long on a
  // fake camera's thread makes it miss ticks, and its frame comes ticks after the other
  // camera's.
  virtual void Prepare(int64_t /*trigger*/) {}
  // Fills one camera's Mono8 frame (on that camera's thread).
  virtual void Fill(int64_t trigger, bool left, int width, int height, uint8_t* pixels) = 0;
  // A fault to inject at this trigger (tests).
  virtual FakeTriggerFault Fault(int64_t /*trigger*/, bool /*left*/) const { return {}; }
  // Whether a lost camera can be opened again before this trigger (tests: a camera
  // removed and re-added).
  virtual bool Present(int64_t /*trigger*/, bool /*left*/) const { return true; }
};

class CameraPairSource : public PairSource {
 public:
  // Starts acquisition on both cameras; throws InputError naming a camera that refuses.
  // A lost camera is opened again with its opener (none: it stays lost).
  CameraPairSource(std::string name, std::unique_ptr<AravisCamera> left, std::unique_ptr<AravisCamera> right,
                   CameraSourceOptions options, std::shared_ptr<FakeScene> scene = nullptr,
                   CameraOpener reopen_left = nullptr, CameraOpener reopen_right = nullptr);
  ~CameraPairSource() override;

  // Software trigger: both cameras now (any thread). Ignored with line0, and past the
  // end of a fake scene.
  void Trigger();
  int64_t Triggers() const;  // fired so far

  std::optional<SourcePair> Next(std::chrono::milliseconds wait) override;
  bool Exhausted() const override;
  std::string Name() const override { return name_; }
  // Sets both cameras' exposure and gain to the recipe's. A camera that refuses makes
  // every pair "not measured" (with the camera's reason) until a recipe it takes.
  void UseRecipe(const Recipe& recipe) override;
  // Triggers from now on are ignored; HasPending: fired triggers whose pair is not taken.
  void StopTriggers() override { triggers_stopped_ = true; }
  bool HasPending() const override;
  // The camera open now on that side (null while it is lost); any thread.
  std::shared_ptr<AravisCamera> Camera(bool left) const;
  // Times a lost camera was opened again.
  int Reconnections() const;

 private:
  // One side's camera, and while it is lost, when to try again.
  struct Side {
    bool left = true;
    std::shared_ptr<AravisCamera> camera;  // null while lost
    CameraOpener reopen;
    std::string lost_reason;    // why it was lost
    int64_t lost_at_trigger = 0;
    int failed_attempts = 0;    // since it was lost
    std::string last_failure;   // the last failed attempt's error
    int64_t next_attempt_ns = 0;
  };
  struct Fired {
    int64_t trigger = 0;
    int64_t fired_ns = 0;     // host clock, UTC
    std::string id;
    std::string problem;      // a camera lost or refusing the trigger
    std::shared_ptr<AravisCamera> left, right;  // the cameras triggered (their frames come from them)
  };
  std::optional<SourcePair> NextTriggered(std::chrono::milliseconds wait);
  std::optional<SourcePair> NextOnLine(std::chrono::milliseconds wait);
  std::optional<SourcePair> LoneFrameOnLine(Side& lost, Side& present, std::chrono::milliseconds wait);
  std::optional<CameraFrame> FrameFor(AravisCamera& camera, const Fired& fired);
  // Under trigger_mutex_: a camera found lost is closed; a lost one reopened when due.
  // Whether the side has a camera now.
  bool EnsureCamera(Side& side, int64_t next_trigger);
  void Lose(Side& side, int64_t trigger, const std::string& reason);
  std::string LostText(const Side& side) const;
  std::string SkewProblem(const CameraFrame& left, const CameraFrame& right, int64_t trigger) const;
  SourcePair Pair(const std::string& id, const std::optional<CameraFrame>& left,
                  const std::optional<CameraFrame>& right, int64_t trigger);
  std::string IdFor(int64_t trigger, int64_t ns) const;

  std::string name_;
  Side left_, right_;  // written under trigger_mutex_
  CameraSourceOptions options_;
  AcquisitionSettings acquisition_;  // options_.acquisition with the recipe's exposure and gain (trigger_mutex_)
  int reconnections_ = 0;            // trigger_mutex_
  std::atomic<bool> triggers_stopped_{false};
  std::shared_ptr<FakeScene> scene_;
  mutable std::mutex mutex_;
  std::condition_variable fired_cv_;
  mutable std::mutex trigger_mutex_;  // one trigger at a time: both cameras, in order; the sides
  std::deque<Fired> pending_;
  int64_t fired_ = 0;
  std::atomic<int64_t> taken_{0};  // pairs handed out (written by Next's thread only)
  // line0: a frame kept for the next pairing (its partner did not come yet).
  std::optional<CameraFrame> held_left_, held_right_;
  std::string settings_problem_;  // the active recipe's settings a camera refused (Next's thread)
};

// The source for `cameras:LEFT,RIGHT` (ids or serials, found on `interfaces`). Throws
// InputError naming the camera, or the spec (field "source") when it is not of that form.
std::unique_ptr<CameraPairSource> MakeCameraSource(const std::string& spec, CameraSourceOptions options,
                                                   const CameraInterfaces& interfaces = {});

// Two fake cameras (serials FAKE-LEFT, FAKE-RIGHT) showing `scene`.
std::unique_ptr<CameraPairSource> MakeFakeSource(const std::string& name, std::shared_ptr<FakeScene> scene,
                                                 CameraSourceOptions options);

// The scene of `aravis-fake:DIR`: DIR/pairs.csv's pairs in order, one per trigger, with
// their ids, frames the size of its first image. Throws InputError as ReadPairsCsv does,
// or naming an image that is not an 8-bit grey PNG.
std::shared_ptr<FakeScene> MakeDatasetScene(const std::string& dir);
// The same for a list of pairs (not empty), e.g. chessboard images for
// `capture-calibration --cameras aravis-fake:DIR`.
std::shared_ptr<FakeScene> MakeImagePairsScene(std::vector<PairEntry> pairs);

}  // namespace flatscan
