#include "flatscan/station/inspection_station.h"

#include <chrono>
#include <utility>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_pipeline.h>

#include "flatscan/inspection/inspection_report.h"
#include "flatscan/io/image_io.h"
#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"

namespace flatscan {
namespace {

using Clock = std::chrono::steady_clock;

// How long the input stage waits for a pair before it checks stop and idle again.
constexpr std::chrono::milliseconds kPollWait{100};

// The SHA-256 of an image file, or "" when it cannot be read (the record then says why).
std::string HashOrEmpty(const std::filesystem::path& file) {
  try {
    return Sha256HexOfFile(file);
  } catch (const InputError&) {
    return "";
  }
}

// A camera's frame as a hashed image, without a copy: its hash is that of its pixels,
// row by row. Throws InputError when its size is not the rig's.
HashedImage FrameHashed(const cv::Mat1b& frame, const cv::Size& expected, const char* side) {
  if (frame.size() != expected)
    ThrowInputError("{} camera frame: {} x {} pixels, expected {} x {} (the rig's calibration)", side, frame.cols,
                    frame.rows, expected.width, expected.height);
  const cv::Mat1b pixels = frame.isContinuous() ? frame : frame.clone();
  return {frame, Sha256Hex(pixels.data, pixels.total())};
}

// The pair's images, decoded from its files or as its frames.
std::pair<HashedImage, HashedImage> PairImages(const LoadedRecipe& loaded, const SourcePair& pair,
                                               const InspectionInputs& inputs) {
  const cv::Size left_size(loaded.rig.left.width, loaded.rig.left.height);
  const cv::Size right_size(loaded.rig.right.width, loaded.rig.right.height);
  if (pair.frames)
    return {FrameHashed(pair.left_image, left_size, "left"), FrameHashed(pair.right_image, right_size, "right")};
  return {ReadGreyImageHashed(inputs.left_file, left_size), ReadGreyImageHashed(inputs.right_file, right_size)};
}

// The part's thumbnail as JPEG bytes: rim heights on a measured part, the image alone on
// one not measured; "" when not asked for.
std::string Thumbnail(const cv::Mat1b& left, const InspectionResult* result, const Recipe& recipe, int width) {
  if (width <= 0 || left.empty()) return "";
  return EncodeJpeg(DrawRimThumbnail(left, result, recipe.spec, width));
}

// The pair's record; `r`'s image hashes are those of the bytes decoded; `thumbnail` (when
// not nullptr) gets the part's thumbnail `width` pixels wide.
InspectionRecord InspectOrExplain(const LoadedRecipe& loaded, const SourcePair& pair, const InspectionInputs& inputs,
                                  StationRecord& r, std::string* thumbnail, int width) {
  const Recipe& recipe = loaded.recipe;
  if (pair.not_measurable) return NotMeasuredRecord(*pair.not_measurable, recipe.params, recipe.spec, inputs);
  std::string ignored;
  std::string& jpeg = thumbnail ? *thumbnail : ignored;
  if (!thumbnail) width = 0;
  cv::Mat1b left_image;  // once decoded: a part not measured still gets its picture
  try {
    const auto [left, right] = PairImages(loaded, pair, inputs);
    left_image = left.image;
    r.left_sha256 = left.sha256;
    r.right_sha256 = right.sha256;
    // Messages name the image: its file, or the camera a frame came from.
    const InspectionResult result =
        InspectPart(loaded.rig, loaded.plane, left.image, right.image, recipe.params,
                    pair.frames ? "left camera frame" : inputs.left_file,
                    pair.frames ? "right camera frame" : inputs.right_file);
    if (const auto wrong = WrongPartReason(recipe, result)) {
      jpeg = Thumbnail(left_image, nullptr, recipe, width);
      return NotMeasuredRecord(*wrong, recipe.params, recipe.spec, inputs);
    }
    jpeg = Thumbnail(left_image, &result, recipe, width);
    return MeasuredRecord(result, recipe.params, recipe.spec, inputs);
  } catch (const InputError& e) {
    jpeg = Thumbnail(left_image, nullptr, recipe, width);
    return NotMeasuredRecord(e.what(), recipe.params, recipe.spec, inputs);
  } catch (const std::exception& e) {
    // Not the pair's fault as far as anyone can tell (out of memory, an OpenCV error):
    // the part is still not measured, and the station goes on.
    spdlog::error("{}: measuring failed: {}", pair.source_id, e.what());
    return NotMeasuredRecord(std::string("internal error while measuring: ") + e.what(), recipe.params, recipe.spec,
                             inputs);
  }
}

}  // namespace

StationRecord MeasureSourcePair(const LoadedRecipe& loaded, const SourcePair& pair, const StationOptions& options,
                                std::string* thumbnail_jpeg) {
  StationRecord r;
  r.record_id = NewRecordId();
  r.station_id = options.station_id;
  r.source_id = pair.source_id;
  r.study = pair.study;
  r.recipe_name = loaded.recipe.name;
  r.recipe_sha256 = loaded.recipe.sha256;
  r.software_version = options.software_version;
  InspectionInputs inputs = loaded.inputs;
  inputs.id = pair.source_id;
  inputs.left_file = pair.left.string();
  inputs.right_file = pair.right.string();
  r.inspection = InspectOrExplain(loaded, pair, inputs, r, thumbnail_jpeg, options.thumbnail_width);
  // An image that was not decoded (half pair, corrupt file) is hashed as a file.
  if (r.left_sha256.empty() && !pair.left.empty()) r.left_sha256 = HashOrEmpty(pair.left);
  if (r.right_sha256.empty() && !pair.right.empty()) r.right_sha256 = HashOrEmpty(pair.right);
  return r;
}

InspectionStation::InspectionStation(std::vector<LoadedRecipe> recipes, PairSource& source, ResultsStore& store, StationOptions options)
    : recipes_(std::move(recipes)), source_(source), store_(store), options_(std::move(options)) {
  FLATSCAN_CHECK(!recipes_.empty());
  FLATSCAN_CHECK(options_.max_in_flight >= 1);
}

void InspectionStation::SetStudyTags(const StudyTags& tags) {
  std::lock_guard lock(study_mutex_);
  study_tags_ = tags;
}

void InspectionStation::SetActiveRecipe(size_t index) {
  FLATSCAN_CHECK(index < recipes_.size());
  active_ = index;
  spdlog::info("active recipe: {}", recipes_[index].recipe.name);
}

// A pair on its way from the measuring stage to the store.
struct InspectionStation::Measured {
  StationRecord record;
  SourcePair pair;
  size_t recipe = 0;
  std::string thumbnail_jpeg;
};

void InspectionStation::Deliver(Measured& measured) {
  StationRecord& record = measured.record;
  const SourcePair& pair = measured.pair;
  if (store_.Contains(record.source_id, record.left_sha256, record.right_sha256)) {
    SkipRecorded(pair);  // not archived again either
    return;
  }
  if (archive_) {
    try {
      record.archive = archive_->Keep(record, pair, recipes_[measured.recipe].recipe.archive, measured.thumbnail_jpeg);
    } catch (const std::exception& e) {  // a full disk: the record still goes to the store
      spdlog::error("{}: images not archived: {}", record.source_id, e.what());
    }
  }
  if (!store_.Commit(record)) {  // durable before anything is published
    SkipRecorded(pair);
    return;
  }
  ++counts_.committed;
  const InspectionRecord& in = record.inspection;
  if (!in.measured) {
    ++counts_.not_measured;
    spdlog::warn("#{} {}: not measured: {}", record.sequence, record.source_id, in.error);
  } else {
    ++(in.judgement.pass() ? counts_.pass : counts_.fail);
    spdlog::info("#{} {}: {}{} flatness {:.4f} mm (tolerance {:.4f})", record.sequence, record.source_id,
                 VerdictName(in.judgement.verdict), in.judgement.marginal ? " (marginal)" : "", in.values.flatness_mm,
                 in.spec.tolerance_mm);
  }
  SourceDone(pair);
  Publish(record, measured.thumbnail_jpeg);
  TrackSourceFaults(pair, record);
}

void InspectionStation::TrackSourceFaults(const SourcePair& pair, const StationRecord& record) {
  const int limit = options_.not_ready_after;
  if (limit <= 0) return;
  if (pair.source_fault) {
    if (++source_faults_ != limit) return;
    const std::string reason = fmt::format("{} pairs in a row not delivered by {}; the last: {}", limit,
                                           source_.Name(), record.inspection.error);
    spdlog::error("station {}: not ready: {}", options_.station_id, reason);
    Notify("reporting not ready", [&](RecordPublisher& p) { p.Readiness(false, reason, counts_); });
    return;
  }
  if (source_faults_ >= limit) {
    spdlog::info("station {}: ready again ({} came through)", options_.station_id, record.source_id);
    Notify("reporting ready", [&](RecordPublisher& p) { p.Readiness(true, "", counts_); });
  }
  source_faults_ = 0;
}

void InspectionStation::SkipRecorded(const SourcePair& pair) {
  ++counts_.already_recorded;
  spdlog::info("{}: already recorded (same id and images), skipped", pair.source_id);
  SourceDone(pair);
}

// The record is safe; a source that cannot tidy up (move the files) is logged, and
// the pair is taken again, and skipped, after a restart.
void InspectionStation::SourceDone(const SourcePair& pair) {
  try {
    source_.Done(pair);
  } catch (const std::exception& e) {
    spdlog::error("{}: the source could not finish with the pair: {}", pair.source_id, e.what());
  }
}

void InspectionStation::Publish(const StationRecord& record, const std::string& thumbnail_jpeg) {
  const std::string what = "publishing #" + std::to_string(record.sequence);
  if (!thumbnail_jpeg.empty())
    Notify(what + "'s image", [&](RecordPublisher& p) { p.PublishImage(record, thumbnail_jpeg); });
  Notify(what, [&](RecordPublisher& p) { p.Publish(record, counts_); });
}

// Calls `f` on every publisher; an exception from one is logged and does not reach the
// others or the station.
void InspectionStation::Notify(const std::string& what, const std::function<void(RecordPublisher&)>& f) {
  for (RecordPublisher* publisher : publishers_) {
    try {
      f(*publisher);
    } catch (const std::exception& e) {
      spdlog::error("{} failed (the record is in the store): {}", what, e.what());
    }
  }
}

StationCounts InspectionStation::Run(const std::atomic<bool>& stop) {
  spdlog::info("station {}: taking pairs from {} with recipe {}", options_.station_id, source_.Name(),
               recipes_[active_].recipe.name);
  try {
    RunPipeline(stop);
  } catch (const std::exception& e) {
    spdlog::error("station {}: stopped: {}", options_.station_id, e.what());
    Notify("publishing the failure", [&](RecordPublisher& p) { p.Failed(counts_, e.what()); });
    throw;
  }
  spdlog::info("station {}: stopped; {} pairs taken, {} records committed ({} pass, {} fail, {} not measured), {} "
               "already recorded",
               options_.station_id, counts_.taken, counts_.committed, counts_.pass, counts_.fail, counts_.not_measured,
               counts_.already_recorded);
  Notify("publishing the stop", [&](RecordPublisher& p) { p.Stopped(counts_); });
  return counts_;
}

void InspectionStation::RunPipeline(const std::atomic<bool>& stop) {
  using Item = std::pair<SourcePair, size_t>;  // the pair and its recipe
  std::atomic<int64_t> in_flight{0};
  // Set when a record cannot be committed: the input stage stops taking pairs (else it
  // would wait for pairs while the pipeline waits for it to return).
  std::atomic<bool> failed{false};
  std::atomic<Clock::rep> last_activity{Clock::now().time_since_epoch().count()};
  const auto idle_for = [&] {
    return std::chrono::duration<double>(Clock::now() - Clock::time_point(Clock::duration(last_activity.load())))
        .count();
  };
  size_t source_recipe = recipes_.size();  // the recipe the source was last told of
  bool stopping = false;
  // Stop: no new triggers, then the pairs of those already fired (each trigger's record).
  const auto go_on = [&] {
    if (failed) return false;
    if (!stop) return true;
    if (!stopping) source_.StopTriggers();
    stopping = true;
    return source_.HasPending();
  };
  const auto next = [&](tbb::flow_control& control) -> Item {
    while (go_on()) {
      const size_t active = active_.load();
      if (active != source_recipe) source_.UseRecipe(recipes_[active].recipe);
      source_recipe = active;
      if (auto pair = source_.Next(kPollWait)) {
        if (pair->study.Empty()) {
          std::lock_guard lock(study_mutex_);
          pair->study = study_tags_;
        }
        ++in_flight;
        ++counts_.taken;
        return {std::move(*pair), active_.load()};  // a switch while waiting counts (the PLC's order)
      }
      if (options_.until_idle_s && in_flight == 0 && idle_for() >= *options_.until_idle_s) break;
    }
    control.stop();
    return {};
  };
  const auto measure = [&](const Item& item) {
    try {
      Measured m{{}, item.first, item.second, {}};
      m.record = MeasureSourcePair(recipes_[item.second], item.first, options_, &m.thumbnail_jpeg);
      return m;
    } catch (...) {  // MeasureSourcePair turns a pair's problems into records; this is the station's
      failed = true;
      throw;
    }
  };
  const auto deliver = [&](Measured measured) {
    try {
      Deliver(measured);
    } catch (...) {
      failed = true;
      throw;
    }
    last_activity = Clock::now().time_since_epoch().count();
    --in_flight;
  };
  tbb::parallel_pipeline(size_t(options_.max_in_flight),
                         tbb::make_filter<void, Item>(tbb::filter_mode::serial_in_order, next) &
                             tbb::make_filter<Item, Measured>(tbb::filter_mode::parallel, measure) &
                             tbb::make_filter<Measured, void>(tbb::filter_mode::serial_in_order, deliver));
}

}  // namespace flatscan
