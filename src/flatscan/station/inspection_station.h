#pragma once
// The station: a resident loop that takes pairs from a source, measures them with the
// active recipe, commits a record per pair to the results store and only then
// publishes it (log, counts; the line outputs next).
//
//   source --(serial: next pair, active recipe)--> measure (parallel: hash, decode,
//   inspect, judge) --(serial, in arrival order: skip a pair already recorded, commit,
//   publish, tell the source)--> store
//
// At most `max_in_flight` pairs are between the two serial stages (a TBB pipeline), so
// memory stays bounded however many pairs arrive. Every pair gets a record: a pair
// that cannot be measured (unreadable, corrupt, half a pair, the wrong part) gets a
// "not measured" record with the reason, and the station goes on. Only a store that
// cannot be written stops it (StoreError): it can record nothing.
#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "flatscan/station/image_archive.h"
#include "flatscan/station/pair_source.h"
#include "flatscan/station/recipe.h"
#include "flatscan/store/results_store.h"

namespace flatscan {

struct StationOptions {
  std::string station_id = "station";
  std::string software_version;
  // Return once this many seconds have passed since the last commit with nothing in
  // flight; nullopt: run until `stop` is set.
  std::optional<double> until_idle_s;
  int max_in_flight = 4;  // pairs being measured at once (2 cores: 2 measuring, 2 queued)
  // This many pairs in a row that the source could not deliver (SourcePair::source_fault)
  // make the station report itself not ready (RecordPublisher::Readiness), until a pair
  // comes through; 0: never. 5: a camera that lost one frame is not a station that
  // cannot work, five in a row is (a cable, a camera gone, a trigger line dead).
  int not_ready_after = 5;
  // > 0: each part also gets a thumbnail this many pixels wide (inspection_report.h,
  // DrawRimThumbnail; made in the parallel measuring stage) for the publishers'
  // PublishImage (the web page, the part-images folder); 0: none (no cost).
  int thumbnail_width = 0;
};

struct StationCounts {
  int64_t taken = 0;  // pairs taken from the source (the input stage's count; the others are the output stage's)
  int64_t committed = 0, pass = 0, fail = 0, not_measured = 0;
  int64_t already_recorded = 0;  // pairs skipped: the store had them (a restart)
};

// Where a committed record goes next (the status file; MQTT, Modbus, the plant store; the web page
// next). Called in commit order, after the record is durable, from one thread.
// An exception from a publisher is logged and does not stop the station: the record
// is safe in the store, which is where a publisher catches up from.
class RecordPublisher {
 public:
  virtual ~RecordPublisher() = default;
  virtual void Publish(const StationRecord& record, const StationCounts& counts) = 0;
  // The part's thumbnail (JPEG bytes), just before Publish, when the station makes them
  // (StationOptions::thumbnail_width) and the pair had an image.
  virtual void PublishImage(const StationRecord& /*record*/, const std::string& /*jpeg*/) {}
  // The station became not ready (`ready` false: the source failed not_ready_after pairs
  // in a row, `reason` says how) or ready again (a pair came through). Called after the
  // record that changed it was published.
  virtual void Readiness(bool /*ready*/, const std::string& /*reason*/, const StationCounts& /*counts*/) {}
  // The station stopped (a signal or idle): a last status.
  virtual void Stopped(const StationCounts& /*counts*/) {}
  // The station stops because it cannot record (`reason`).
  virtual void Failed(const StationCounts& counts, const std::string& /*reason*/) { Stopped(counts); }
};

// The record a station makes of one pair (the parallel stage), without sequence and time;
// with options.thumbnail_width > 0 and `thumbnail_jpeg`, also the part's thumbnail (empty
// when the pair has no image).
StationRecord MeasureSourcePair(const LoadedRecipe& recipe, const SourcePair& pair, const StationOptions& options,
                                std::string* thumbnail_jpeg = nullptr);

class InspectionStation {
 public:
  // `recipes`: at least one; the first is active.
  InspectionStation(std::vector<LoadedRecipe> recipes, PairSource& source, ResultsStore& store, StationOptions options);

  // Runs until `stop` is set (pairs in flight are finished and recorded) or, with
  // until_idle_s, until idle. Throws StoreError when the store cannot be written (the
  // pairs in flight are then not recorded, and their source files are left in place).
  StationCounts Run(const std::atomic<bool>& stop);

  // Keep images in `archive` by each recipe's policy (image_archive.h); nullptr: none.
  void SetArchive(ImageArchive* archive) { archive_ = archive; }

  // Publishers get each record once it is committed, in this order.
  void AddPublisher(RecordPublisher* publisher) { publishers_.push_back(publisher); }

  // Gauge-study tags for the pairs taken from now on that carry none of their own (a
  // PLC's study registers: docs/plc.md); empty tags: none. Any thread.
  void SetStudyTags(const StudyTags& tags);

  // Switches the recipe for the pairs taken from now on (line outputs, web page).
  void SetActiveRecipe(size_t index);
  size_t ActiveRecipe() const { return active_; }

 private:
  struct Measured;
  void RunPipeline(const std::atomic<bool>& stop);
  void Deliver(Measured& measured);
  void SkipRecorded(const SourcePair& pair);
  void SourceDone(const SourcePair& pair);
  void Publish(const StationRecord& record, const std::string& thumbnail_jpeg);
  void TrackSourceFaults(const SourcePair& pair, const StationRecord& record);
  void Notify(const std::string& what, const std::function<void(RecordPublisher&)>& f);

  std::vector<LoadedRecipe> recipes_;
  PairSource& source_;
  ResultsStore& store_;
  StationOptions options_;
  std::vector<RecordPublisher*> publishers_;
  ImageArchive* archive_ = nullptr;
  std::atomic<size_t> active_{0};
  mutable std::mutex study_mutex_;
  StudyTags study_tags_;
  StationCounts counts_;
  int source_faults_ = 0;  // pairs in a row the source could not deliver (the output stage's)
};

}  // namespace flatscan
