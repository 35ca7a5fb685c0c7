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
                                   std::shared_ptr<FakeScene> scene)
    : name_(std::move(name)),
      left_(std::move(left)),
      right_(std::move(right)),
      options_(options),
      scene_(std::move(scene)) {
  left_->Start(options_.acquisition);
  right_->Start(options_.acquisition);
  if (left_->IsFake() && right_->IsFake() && options_.acquisition.trigger == TriggerSource::kLine0) {
    if (scene_)
      for (int64_t k = 1; k <= kFakeLineLookahead; ++k) scene_->Prepare(k);
    left_->AwayFromFakeTick(kFakeTickMargin);  // both fakes' first frame at the same tick
    left_->QueueFakeLine();
    right_->QueueFakeLine();
  }
  spdlog::info("{}: left {}, right {}; {} trigger", name_, left_->Name(), right_->Name(),
               options_.acquisition.trigger == TriggerSource::kLine0 ? "line0" : "software");
}

CameraPairSource::~CameraPairSource() {
  left_->Stop();
  right_->Stop();
}

void CameraPairSource::UseRecipe(const Recipe& recipe) {
  settings_problem_.clear();
  try {
    for (AravisCamera* camera : {left_.get(), right_.get()})
      camera->SetExposureAndGain(recipe.camera.exposure_us, recipe.camera.gain_db);
  } catch (const InputError& e) {
    settings_problem_ = fmt::format("recipe {}: {}", recipe.name, e.what());
    spdlog::error("{}: {}: its pairs are not measured", name_, settings_problem_);
  }
}

int64_t CameraPairSource::Triggers() const {
  std::lock_guard lock(mutex_);
  return fired_;
}

void CameraPairSource::Trigger() {
  if (options_.acquisition.trigger == TriggerSource::kLine0) return;
  std::lock_guard one_at_a_time(trigger_mutex_);
  int64_t trigger = 0;
  {
    std::lock_guard lock(mutex_);
    if (scene_ && fired_ == scene_->Triggers()) return;  // the scene has no more pairs
    trigger = fired_ + 1;
  }
  if (scene_) scene_->Prepare(trigger);
  Fired fired{trigger, HostClockNs(), "", ""};
  fired.id = IdFor(trigger, fired.fired_ns);
  for (const bool left : {true, false}) {
    try {
      (left ? *left_ : *right_).Trigger(uint64_t(trigger), scene_ ? scene_->Fault(trigger, left) : FakeTriggerFault{});
    } catch (const InputError& e) {
      fired.problem = e.what();
    }
  }
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
  const std::optional<CameraFrame> left = FrameFor(*left_, fired);
  const std::optional<CameraFrame> right = FrameFor(*right_, fired);
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
  if (problem.empty()) {
    const double skew_ms = double(std::llabs(left->timestamp_ns - right->timestamp_ns)) / 1e6;
    if (skew_ms > double(options_.max_skew.count()))
      problem = fmt::format("cameras out of sync: the frames of trigger {} are {:.1f} ms apart (limit {} ms)",
                            trigger, skew_ms, options_.max_skew.count());
  }
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
  const auto take = [](AravisCamera& camera, std::optional<CameraFrame>& held, microseconds w) {
    std::optional<CameraFrame> f = std::move(held);
    held.reset();
    return f ? f : camera.NextFrame(w);
  };
  std::optional<CameraFrame> left = take(*left_, held_left_, wait);
  std::optional<CameraFrame> right = take(*right_, held_right_, left ? options_.frame_timeout : microseconds(0));
  if (!left && !right) return std::nullopt;
  if (!left) left = take(*left_, held_left_, options_.frame_timeout);
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
  return std::make_unique<CameraPairSource>(spec, std::move(left_camera), std::move(right_camera), options);
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
  const auto fill = [scene](bool left) {
    return [scene, left](int width, int height, uint8_t* pixels, uint64_t tag) {
      scene->Fill(int64_t(tag), left, width, height, pixels);
    };
  };
  return std::make_unique<CameraPairSource>(
      name, AravisCamera::OpenFake("FAKE-LEFT", size.width, size.height, fill(true)),
      AravisCamera::OpenFake("FAKE-RIGHT", size.width, size.height, fill(false)), options, scene);
}

}  // namespace flatscan
