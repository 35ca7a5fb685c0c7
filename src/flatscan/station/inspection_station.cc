#include "flatscan/station/inspection_station.h"

#include <chrono>
#include <utility>

#include <opencv2/core.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_pipeline.h>

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

InspectionRecord InspectOrExplain(const LoadedRecipe& loaded, const SourcePair& pair, const InspectionInputs& inputs) {
  const Recipe& recipe = loaded.recipe;
  if (pair.not_measurable) return NotMeasuredRecord(*pair.not_measurable, recipe.params, recipe.spec, inputs);
  try {
    const cv::Mat1b left = ReadGreyImage(inputs.left_file, {loaded.rig.left.width, loaded.rig.left.height});
    const cv::Mat1b right = ReadGreyImage(inputs.right_file, {loaded.rig.right.width, loaded.rig.right.height});
    const InspectionResult result =
        InspectPart(loaded.rig, loaded.plane, left, right, recipe.params, inputs.left_file, inputs.right_file);
    if (const auto wrong = WrongPartReason(recipe, result))
      return NotMeasuredRecord(*wrong, recipe.params, recipe.spec, inputs);
    return MeasuredRecord(result, recipe.params, recipe.spec, inputs);
  } catch (const InputError& e) {
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

StationRecord MeasureSourcePair(const LoadedRecipe& loaded, const SourcePair& pair, const StationOptions& options) {
  StationRecord r;
  r.record_id = NewRecordId();
  r.station_id = options.station_id;
  r.source_id = pair.source_id;
  r.recipe_name = loaded.recipe.name;
  r.recipe_sha256 = loaded.recipe.sha256;
  r.software_version = options.software_version;
  r.left_sha256 = HashOrEmpty(pair.left);
  r.right_sha256 = HashOrEmpty(pair.right);
  InspectionInputs inputs = loaded.inputs;
  inputs.id = pair.source_id;
  inputs.left_file = pair.left.string();
  inputs.right_file = pair.right.string();
  r.inspection = InspectOrExplain(loaded, pair, inputs);
  return r;
}

InspectionStation::InspectionStation(std::vector<LoadedRecipe> recipes, PairSource& source, ResultsStore& store, StationOptions options)
    : recipes_(std::move(recipes)), source_(source), store_(store), options_(std::move(options)) {
  FLATSCAN_CHECK(!recipes_.empty());
  FLATSCAN_CHECK(options_.max_in_flight >= 1);
}

void InspectionStation::SetActiveRecipe(size_t index) {
  FLATSCAN_CHECK(index < recipes_.size());
  active_ = index;
  spdlog::info("active recipe: {}", recipes_[index].recipe.name);
}

void InspectionStation::Deliver(StationRecord& record, const SourcePair& pair) {
  if (store_.Contains(record.source_id, record.left_sha256, record.right_sha256)) {
    ++counts_.already_recorded;
    spdlog::info("{}: already recorded (same id and images), skipped", record.source_id);
    source_.Done(pair);
    return;
  }
  store_.Commit(record);  // durable before anything is published
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
  source_.Done(pair);
  Publish(record);
}

void InspectionStation::Publish(const StationRecord& record) {
  for (RecordPublisher* publisher : publishers_) {
    try {
      publisher->Publish(record, counts_);
    } catch (const std::exception& e) {
      spdlog::error("#{}: publishing failed (the record is in the store): {}", record.sequence, e.what());
    }
  }
}

StationCounts InspectionStation::Run(const std::atomic<bool>& stop) {
  using Item = std::pair<SourcePair, size_t>;  // the pair and its recipe
  std::atomic<int64_t> in_flight{0};
  std::atomic<Clock::rep> last_activity{Clock::now().time_since_epoch().count()};
  const auto idle_for = [&] {
    return std::chrono::duration<double>(Clock::now() - Clock::time_point(Clock::duration(last_activity.load())))
        .count();
  };
  spdlog::info("station {}: taking pairs from {} with recipe {}", options_.station_id, source_.Name(),
               recipes_[active_].recipe.name);
  tbb::parallel_pipeline(
      size_t(options_.max_in_flight),
      tbb::make_filter<void, Item>(tbb::filter_mode::serial_in_order,
                                   [&](tbb::flow_control& control) -> Item {
                                     while (!stop) {
                                       if (auto pair = source_.Next(kPollWait)) {
                                         ++in_flight;
                                         return {std::move(*pair), active_.load()};
                                       }
                                       if (options_.until_idle_s && in_flight == 0 &&
                                           idle_for() >= *options_.until_idle_s)
                                         break;
                                     }
                                     control.stop();
                                     return {};
                                   }) &
          tbb::make_filter<Item, std::pair<StationRecord, SourcePair>>(
              tbb::filter_mode::parallel,
              [&](const Item& item) {
                return std::pair(MeasureSourcePair(recipes_[item.second], item.first, options_), item.first);
              }) &
          tbb::make_filter<std::pair<StationRecord, SourcePair>, void>(
              tbb::filter_mode::serial_in_order, [&](std::pair<StationRecord, SourcePair> done) {
                Deliver(done.first, done.second);
                last_activity = Clock::now().time_since_epoch().count();
                --in_flight;
              }));
  spdlog::info("station {}: stopped; {} records committed ({} pass, {} fail, {} not measured), {} already recorded",
               options_.station_id, counts_.committed, counts_.pass, counts_.fail, counts_.not_measured,
               counts_.already_recorded);
  for (RecordPublisher* publisher : publishers_) {
    try {
      publisher->Stopped(counts_);
    } catch (const std::exception& e) {
      spdlog::error("publishing the station's stop failed: {}", e.what());
    }
  }
  return counts_;
}

}  // namespace flatscan
