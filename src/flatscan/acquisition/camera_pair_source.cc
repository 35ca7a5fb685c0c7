#include "flatscan/acquisition/camera_pair_source.h"

#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/io/image_io.h"
#include "flatscan/io/pairs_csv.h"
#include "flatscan/station/recipe.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

// Two fake lines queued one after the other take the same first pulse unless a tick
// falls between the two: keep this far from one.
constexpr microseconds kFakeTickMargin{800};
// On a fake line the frames come at every tick whether taken or not: the scene's frames
// are prepared this many pairs ahead of the pair taken.
constexpr int64_t kFakeLineLookahead = 4;

// The two frames of one pair and the buffers they live in.
struct FramePair {
  CameraFrame left, right;
};

// A dataset's pairs shown by two fake cameras. The images are decoded by Prepare before
// the trigger (or ahead, on a fake line); a frame not prepared is decoded as it is filled.
class DatasetScene : public FakeScene {
 public:
  explicit DatasetScene(std::vector<PairEntry> pairs) : pairs_(std::move(pairs)) {}
  int64_t Triggers() const override { return int64_t(pairs_.size()); }
  std::string Id(int64_t trigger) const override { return pairs_.at(size_t(trigger - 1)).id; }
  void Prepare(int64_t trigger) override {
    if (trigger < 1 || trigger > Triggers()) return;
    for (const bool left : {true, false}) {
      cv::Mat1b image = Decode(trigger, left);
      std::lock_guard lock(mutex_);
      ready_[{trigger, left}] = std::move(image);
    }
  }
  void Fill(int64_t trigger, bool left, int width, int height, uint8_t* pixels) override {
    cv::Mat1b image;
    {
      std::lock_guard lock(mutex_);
      if (const auto it = ready_.find({trigger, left}); it != ready_.end()) {
        image = std::move(it->second);
        ready_.erase(it);
      }
    }
    if (image.empty()) image = Decode(trigger, left);
    if (image.size() != cv::Size(width, height)) image = cv::Mat1b::zeros(height, width);  // a dark frame
    for (int y = 0; y < height; ++y) std::memcpy(pixels + size_t(y) * size_t(width), image.ptr(y), size_t(width));
  }
  cv::Size FrameSize() const override { return size_; }

 private:
  std::vector<PairEntry> pairs_;
  cv::Size size_ = FirstImageSize();

  std::mutex mutex_;
  std::map<std::pair<int64_t, bool>, cv::Mat1b> ready_;  // decoded by Prepare, taken by Fill

  // The image, or an empty one (logged) when the file cannot be shown.
  cv::Mat1b Decode(int64_t trigger, bool left) const {
    if (trigger < 1 || trigger > Triggers()) return {};
    const PairEntry& pair = pairs_[size_t(trigger - 1)];
    try {
      return ReadGreyImage(left ? pair.left : pair.right, size_);
    } catch (const std::exception& e) {
      spdlog::error("aravis-fake: pair {} {}: {}", pair.id, left ? "left" : "right", e.what());
      return {};
    }
  }

  cv::Size FirstImageSize() const {
    const std::optional<cv::Size> size = ReadImageHeaderSize(pairs_.front().left);
    if (!size) ThrowInputError("{}: not an image this station reads (expected an 8-bit grey PNG)", pairs_.front().left);
    return *size;
  }
};

std::string SideName(bool left) { return left ? "left" : "right"; }

}  // namespace

CameraPairSource::CameraPairSource(std::string name, std::unique_ptr<AravisCamera> left,
                                   std::unique_ptr<AravisCamera> right, CameraSourceOptions options,
                                   std::shared_ptr<FakeScene> scene, CameraOpener reopen_left,
                                   CameraOpener reopen_right)
    : name_(std::move(name)), options_(options), acquisition_(options.acquisition), scene_(std::move(scene)) {
  left_.camera = std::move(left);
  left_.reopen = std::move(reopen_left);
  right_.left = false;
  right_.camera = std::move(right);
  right_.reopen = std::move(reopen_right);
  left_.camera->Start(acquisition_);
  right_.camera->Start(acquisition_);
  if (left_.camera->IsFake() && right_.camera->IsFake() && acquisition_.trigger == TriggerSource::kLine0) {
    if (scene_)
      for (int64_t k = 1; k <= kFakeLineLookahead; ++k) scene_->Prepare(k);
    left_.camera->AwayFromFakeTick(kFakeTickMargin);  // both fakes' first frame at the same tick
    left_.camera->QueueFakeLine();
    right_.camera->QueueFakeLine();
  }
  spdlog::info("{}: left {}, right {}; {} trigger", name_, left_.camera->Name(), right_.camera->Name(),
               acquisition_.trigger == TriggerSource::kLine0 ? "line0" : "software");
}

CameraPairSource::~CameraPairSource() {
  for (Side* side : {&left_, &right_})
    if (side->camera) side->camera->Stop();
}

std::shared_ptr<AravisCamera> CameraPairSource::Camera(bool left) const {
  std::lock_guard lock(trigger_mutex_);
  return left ? left_.camera : right_.camera;
}

int CameraPairSource::Reconnections() const {
  std::lock_guard lock(trigger_mutex_);
  return reconnections_;
}

void CameraPairSource::UseRecipe(const Recipe& recipe) {
  std::lock_guard one_at_a_time(trigger_mutex_);
  settings_problem_.clear();
  acquisition_.exposure_us = recipe.camera.exposure_us ? recipe.camera.exposure_us : options_.acquisition.exposure_us;
  acquisition_.gain_db = recipe.camera.gain_db ? recipe.camera.gain_db : options_.acquisition.gain_db;
  try {
    for (Side* side : {&left_, &right_})
      if (side->camera) side->camera->SetExposureAndGain(recipe.camera.exposure_us, recipe.camera.gain_db);
  } catch (const InputError& e) {
    settings_problem_ = fmt::format("recipe {}: {}", recipe.name, e.what());
    spdlog::error("{}: {}: its pairs are not measured", name_, settings_problem_);
  }
}

int64_t CameraPairSource::Triggers() const {
  std::lock_guard lock(mutex_);
  return fired_;
}

std::chrono::milliseconds ReconnectDelay(int failed_attempts, milliseconds first, milliseconds max) {
  milliseconds delay = first;
  for (int i = 0; i < failed_attempts && delay < max; ++i) delay *= 2;
  return std::min(delay, max);
}

void CameraPairSource::Lose(Side& side, int64_t trigger, const std::string& reason) {
  spdlog::error("{}: the {} camera is lost at trigger {}: {}; reconnecting", name_, SideName(side.left), trigger,
                reason);
  // Closed when the last trigger fired on it has its pair (Next's thread may be waiting
  // for its frames now); its frames still held stay valid.
  side.camera.reset();
  side.lost_reason = reason;
  side.lost_at_trigger = trigger;
  side.failed_attempts = 0;
  side.last_failure.clear();
  side.next_attempt_ns = HostClockNs() + int64_t(options_.reconnect_first.count()) * 1'000'000;
}

bool CameraPairSource::EnsureCamera(Side& side, int64_t next_trigger) {
  if (side.camera && side.camera->ControlLost())
    Lose(side, next_trigger, fmt::format("camera {}: lost (it stopped answering on its control channel)",
                                         side.camera->Name()));
  if (side.camera) return true;
  if (!side.reopen || HostClockNs() < side.next_attempt_ns) return false;
  try {
    std::unique_ptr<AravisCamera> camera = side.reopen(next_trigger);
    camera->Start(acquisition_);
    if (camera->IsFake() && acquisition_.trigger == TriggerSource::kLine0) camera->QueueFakeLine();
    side.camera = std::move(camera);
    ++reconnections_;
    spdlog::info("{}: the {} camera is back ({}) after {} failed attempt(s)", name_, SideName(side.left),
                 side.camera->Name(), side.failed_attempts);
    return true;
  } catch (const InputError& e) {
    side.last_failure = e.what();
    ++side.failed_attempts;
    side.next_attempt_ns = HostClockNs() + int64_t(ReconnectDelay(side.failed_attempts, options_.reconnect_first,
                                                                  options_.reconnect_max).count()) * 1'000'000;
    spdlog::warn("{}: the {} camera: reconnection attempt {} failed: {}", name_, SideName(side.left),
                 side.failed_attempts, e.what());
    return false;
  }
}

std::string CameraPairSource::LostText(const Side& side) const {
  std::string text = fmt::format("the {} camera is lost since trigger {} ({})", SideName(side.left),
                                 side.lost_at_trigger, side.lost_reason);
  if (!side.reopen) return text + "; it is not reopened";
  const double next_s = double(std::max<int64_t>(0, side.next_attempt_ns - HostClockNs())) / 1e9;
  if (side.failed_attempts == 0) return text + fmt::format("; reconnecting in {:.1f} s", next_s);
  return text + fmt::format("; reconnection attempt {} failed ({}); next in {:.1f} s", side.failed_attempts,
                            side.last_failure, next_s);
}

bool CameraPairSource::HasPending() const {
  std::lock_guard lock(mutex_);
  return !pending_.empty();
}

void CameraPairSource::Trigger() {
  if (options_.acquisition.trigger == TriggerSource::kLine0 || triggers_stopped_) return;
  std::lock_guard one_at_a_time(trigger_mutex_);
  int64_t trigger = 0;
  {
    std::lock_guard lock(mutex_);
    if (scene_ && fired_ == scene_->Triggers()) return;  // the scene has no more pairs
    trigger = fired_ + 1;
  }
  if (scene_) scene_->Prepare(trigger);
  Fired fired;
  fired.trigger = trigger;
  // Both cameras, or neither: a frame of one camera alone would only be discarded.
  const bool left_ready = EnsureCamera(left_, trigger), right_ready = EnsureCamera(right_, trigger);
  fired.fired_ns = HostClockNs();
  fired.id = IdFor(trigger, fired.fired_ns);
  if (!left_ready || !right_ready) fired.problem = LostText(left_ready ? right_ : left_);
  for (Side* side : {&left_, &right_}) {
    if (!fired.problem.empty()) break;
    try {
      side->camera->Trigger(uint64_t(trigger), scene_ ? scene_->Fault(trigger, side->left) : FakeTriggerFault{});
    } catch (const InputError& e) {
      fired.problem = e.what();
      Lose(*side, trigger, e.what());
    }
  }
  fired.left = left_.camera;
  fired.right = right_.camera;
  {
    std::lock_guard lock(mutex_);
    fired_ = trigger;
    pending_.push_back(std::move(fired));
  }
  fired_cv_.notify_all();
}

std::string CameraPairSource::IdFor(int64_t trigger, int64_t ns) const {
  if (scene_ && trigger <= scene_->Triggers()) return scene_->Id(trigger);
  // Unique across restarts: the trigger's UTC time to the millisecond and its number.
  const std::time_t seconds = std::time_t(ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y%m%dT%H%M%S", &utc);
  return fmt::format("{}.{:03d}Z-{}", text, int((ns / 1'000'000) % 1000), trigger);
}

bool CameraPairSource::Exhausted() const {
  std::lock_guard lock(mutex_);
  if (options_.acquisition.trigger == TriggerSource::kLine0) return scene_ && taken_ >= scene_->Triggers();
  return scene_ && fired_ == scene_->Triggers() && pending_.empty();
}

std::optional<SourcePair> CameraPairSource::Next(milliseconds wait) {
  if (options_.acquisition.trigger == TriggerSource::kLine0) return NextOnLine(wait);
  return NextTriggered(wait);
}

std::optional<SourcePair> CameraPairSource::NextTriggered(milliseconds wait) {
  bool fire = false;
  {
    std::lock_guard lock(mutex_);
    fire = options_.trigger_on_demand && pending_.empty();
  }
  if (fire) Trigger();
  Fired fired;
  {
    std::unique_lock lock(mutex_);
    if (!fired_cv_.wait_for(lock, wait, [&] { return !pending_.empty(); })) return std::nullopt;
    fired = std::move(pending_.front());
    pending_.pop_front();
  }
  if (!fired.problem.empty()) {
    SourcePair pair = Pair(fired.id, std::nullopt, std::nullopt, fired.trigger);
    pair.not_measurable = "trigger " + std::to_string(fired.trigger) + ": " + fired.problem;
    pair.source_fault = true;
    return pair;
  }
  const std::optional<CameraFrame> left = FrameFor(*fired.left, fired);
  const std::optional<CameraFrame> right = FrameFor(*fired.right, fired);
  return Pair(fired.id, left, right, fired.trigger);
}

// The camera's frame for the trigger: the first one not older than the trigger, waiting
// until the trigger's timeout (a frame already there is taken even when that is past).
std::optional<CameraFrame> CameraPairSource::FrameFor(AravisCamera& camera, const Fired& fired) {
  const int64_t deadline_ns = fired.fired_ns + int64_t(options_.frame_timeout.count()) * 1'000'000;
  for (;;) {
    const int64_t left_ns = std::max<int64_t>(0, deadline_ns - HostClockNs());
    std::optional<CameraFrame> frame = camera.NextFrame(microseconds(left_ns / 1000));
    if (!frame) return std::nullopt;
    if (frame->timestamp_ns >= fired.fired_ns) return frame;
    spdlog::warn("{}: {}: discarded a frame that came after its trigger's timeout", name_, camera.Name());
  }
}

// The two frames of one trigger further apart than max_skew on the chosen clock, or "".
std::string CameraPairSource::SkewProblem(const CameraFrame& left, const CameraFrame& right, int64_t trigger) const {
  const bool cameras = options_.skew_clock == CameraSourceOptions::Clock::kCamera;
  if (cameras && (left.camera_timestamp_ns == 0 || right.camera_timestamp_ns == 0))
    return fmt::format("the {} camera gives no timestamp of its own (the skew is measured on the cameras' clocks)",
                       left.camera_timestamp_ns == 0 ? "left" : "right");
  const int64_t apart = cameras ? left.camera_timestamp_ns - right.camera_timestamp_ns
                                : left.timestamp_ns - right.timestamp_ns;
  const double skew_ms = double(std::llabs(apart)) / 1e6;
  if (skew_ms <= double(options_.max_skew.count())) return "";
  return fmt::format("cameras out of sync: the frames of trigger {} are {:.1f} ms apart (limit {} ms){}", trigger,
                     skew_ms, options_.max_skew.count(),
                     cameras ? " on the cameras' clocks (are both synchronised by PTP?)" : "");
}

SourcePair CameraPairSource::Pair(const std::string& id, const std::optional<CameraFrame>& left,
                                  const std::optional<CameraFrame>& right, int64_t trigger) {
  SourcePair pair;
  pair.source_id = id;
  ++taken_;
  std::string problem;
  for (const bool is_left : {true, false}) {
    const std::optional<CameraFrame>& f = is_left ? left : right;
    if (!problem.empty()) break;
    if (!f)
      problem = fmt::format("the {} camera gave no frame within {} ms of trigger {}", SideName(is_left),
                            options_.frame_timeout.count(), trigger);
    else if (!f->problem.empty())
      problem = fmt::format("the {} camera's frame of trigger {} is incomplete: {}", SideName(is_left), trigger,
                            f->problem);
  }
  if (problem.empty() && !settings_problem_.empty()) problem = settings_problem_;
  if (problem.empty()) problem = SkewProblem(*left, *right, trigger);
  if (!problem.empty()) {
    pair.not_measurable = problem;
    pair.source_fault = true;
    return pair;
  }
  auto frames = std::make_shared<FramePair>(FramePair{*left, *right});
  pair.left_image = frames->left.image;
  pair.right_image = frames->right.image;
  pair.frames = std::move(frames);
  return pair;
}

// line0: frames come when the line pulses. The older of two frames further apart than
// max_skew has no partner: it is reported alone, the newer one waits for its partner.
std::optional<SourcePair> CameraPairSource::NextOnLine(milliseconds wait) {
  if (Exhausted()) {  // a fake line runs on past its scene: nothing more to show
    std::this_thread::sleep_for(wait);
    return std::nullopt;
  }
  std::shared_ptr<AravisCamera> left_camera, right_camera;
  {
    std::lock_guard one_at_a_time(trigger_mutex_);
    const int64_t next = taken_ + 1;
    const bool left_ready = EnsureCamera(left_, next), right_ready = EnsureCamera(right_, next);
    if (!left_ready && !right_ready) {
      std::this_thread::sleep_for(wait);
      return std::nullopt;
    }
    if (!left_ready || !right_ready) return LoneFrameOnLine(left_ready ? right_ : left_, left_ready ? left_ : right_, wait);
    left_camera = left_.camera;
    right_camera = right_.camera;
  }
  const auto take = [](AravisCamera& camera, std::optional<CameraFrame>& held, microseconds w) {
    std::optional<CameraFrame> f = std::move(held);
    held.reset();
    return f ? f : camera.NextFrame(w);
  };
  std::optional<CameraFrame> left = take(*left_camera, held_left_, wait);
  std::optional<CameraFrame> right = take(*right_camera, held_right_, left ? options_.frame_timeout : microseconds(0));
  if (!left && !right) return std::nullopt;
  if (!left) left = take(*left_camera, held_left_, options_.frame_timeout);
  const int64_t trigger = taken_ + 1;
  if (scene_) scene_->Prepare(trigger + kFakeLineLookahead);
  const int64_t ns = left ? left->timestamp_ns : right->timestamp_ns;
  if (left && right && std::llabs(left->timestamp_ns - right->timestamp_ns) > int64_t(options_.max_skew.count()) * 1'000'000) {
    const bool left_older = left->timestamp_ns < right->timestamp_ns;
    (left_older ? held_right_ : held_left_) = left_older ? std::move(right) : std::move(left);
    if (left_older) right.reset();
    else left.reset();
    SourcePair alone = Pair(IdFor(trigger, ns), left, right, trigger);
    alone.not_measurable = fmt::format("cameras out of sync: the {} camera's frame has no partner within {} ms",
                                       left_older ? "left" : "right", options_.max_skew.count());
    return alone;
  }
  return Pair(IdFor(trigger, ns), left, right, trigger);
}

// line0 with one camera lost: each frame of the other is a pulse, recorded as not
// measured (one record per part still); called under trigger_mutex_.
std::optional<SourcePair> CameraPairSource::LoneFrameOnLine(Side& lost, Side& present, milliseconds wait) {
  std::optional<CameraFrame>& held = present.left ? held_left_ : held_right_;
  std::optional<CameraFrame> frame = std::move(held);
  held.reset();
  if (!frame) frame = present.camera->NextFrame(wait);
  if (!frame) return std::nullopt;
  const int64_t trigger = taken_ + 1;
  if (scene_) scene_->Prepare(trigger + kFakeLineLookahead);
  SourcePair pair = Pair(IdFor(trigger, frame->timestamp_ns), std::nullopt, std::nullopt, trigger);
  pair.not_measurable = LostText(lost);
  return pair;
}

std::unique_ptr<CameraPairSource> MakeCameraSource(const std::string& spec, CameraSourceOptions options,
                                                   const CameraInterfaces& interfaces) {
  const std::string prefix = "cameras:";
  const auto comma = spec.find(',');
  if (spec.rfind(prefix, 0) != 0 || comma == std::string::npos || comma == prefix.size() || comma + 1 == spec.size())
    ThrowFieldError("source", "'{}': expected cameras:LEFT,RIGHT (each camera's id or serial, from `flatscan cameras`)",
                    spec);
  const std::string left = spec.substr(prefix.size(), comma - prefix.size()), right = spec.substr(comma + 1);
  if (left == right) ThrowFieldError("source", "'{}': the left and the right camera are the same camera", spec);
  std::unique_ptr<AravisCamera> left_camera = AravisCamera::Open(left, interfaces);  // left first: its name in errors
  std::unique_ptr<AravisCamera> right_camera = AravisCamera::Open(right, interfaces);
  const auto opener = [interfaces](const std::string& camera) {
    return [interfaces, camera](int64_t) { return AravisCamera::Open(camera, interfaces); };
  };
  return std::make_unique<CameraPairSource>(spec, std::move(left_camera), std::move(right_camera), options, nullptr,
                                            opener(left), opener(right));
}

std::shared_ptr<FakeScene> MakeDatasetScene(const std::string& dir) {
  return std::make_shared<DatasetScene>(ReadPairsCsv(std::filesystem::path(dir) / "pairs.csv"));
}

std::shared_ptr<FakeScene> MakeImagePairsScene(std::vector<PairEntry> pairs) {
  FLATSCAN_CHECK(!pairs.empty());
  return std::make_shared<DatasetScene>(std::move(pairs));
}

std::unique_ptr<CameraPairSource> MakeFakeSource(const std::string& name, std::shared_ptr<FakeScene> scene,
                                                 CameraSourceOptions options) {
  const cv::Size size = scene->FrameSize();
  // A fake camera "re-added": a new one with the same serial, once the scene says it is back.
  const auto open = [scene, size](bool left) {
    return AravisCamera::OpenFake(left ? "FAKE-LEFT" : "FAKE-RIGHT", size.width, size.height,
                                  [scene, left](int width, int height, uint8_t* pixels, uint64_t tag) {
                                    scene->Fill(int64_t(tag), left, width, height, pixels);
                                  });
  };
  const auto reopen = [scene, open](bool left) -> CameraOpener {
    return [scene, open, left](int64_t next_trigger) {
      if (!scene->Present(next_trigger, left))
        ThrowInputError("camera 'FAKE-{}': not found among the GenICam cameras found", left ? "LEFT" : "RIGHT");
      return open(left);
    };
  };
  return std::make_unique<CameraPairSource>(name, open(true), open(false), options, scene, reopen(true), reopen(false));
}

}  // namespace flatscan
