#pragma once
// Where a station's pairs come from. One pipeline, several sources: a replay of a
// pairs file (`pairs:FILE.csv`, io/pairs_csv.h), a watched folder (`folder:DIR`,
// station/folder_source.h), two cameras (`cameras:L,R`, `aravis-fake:DIR`:
// acquisition/camera_pair_source.h). A source hands out pairs; the station tells it when a
// pair's record is committed, so that a source that moves or deletes files does so only then.
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "flatscan/io/study_tags.h"

namespace flatscan {

struct Recipe;  // station/recipe.h

struct SourcePair {
  std::string source_id;                    // the pair's id in its source
  std::filesystem::path left, right;        // image files (a file source)
  StudyTags study;                          // the pair's gauge-study tags (a pairs file's part, appraiser, trial)
  std::optional<std::string> not_measurable;  // why it cannot be measured (a half pair past its timeout)
  // Not measurable because the source could not deliver it (a camera's frame lost,
  // incomplete or out of sync), not because of the part: the station counts these to
  // say it is not ready (StationOptions::not_ready_after).
  bool source_fault = false;
  // Frames in memory (a camera source), measured where they are: `frames` holds the
  // camera buffers they point into until the pair is done.
  cv::Mat1b left_image, right_image;
  std::shared_ptr<const void> frames;
};

// A pair of image files.
inline SourcePair FilePair(std::string id, std::filesystem::path left, std::filesystem::path right,
                           std::optional<std::string> not_measurable = std::nullopt) {
  SourcePair pair;
  pair.source_id = std::move(id);
  pair.left = std::move(left);
  pair.right = std::move(right);
  pair.not_measurable = std::move(not_measurable);
  return pair;
}

// Thread safety: the station calls Next() from one thread and Done() from another, at
// the same time; an implementation guards what the two share. Done() may throw (the
// station logs it; the record is already safe).
class PairSource {
 public:
  virtual ~PairSource() = default;
  // The next pair, waiting at most `wait` for one; nullopt when none came.
  virtual std::optional<SourcePair> Next(std::chrono::milliseconds wait) = 0;
  // True once the source will give no more pairs (a replay read to its end).
  virtual bool Exhausted() const = 0;
  // The pair's record is committed (or it was recorded before).
  virtual void Done(const SourcePair& /*pair*/) {}
  // What the source is, for logs: "pairs:list.csv".
  virtual std::string Name() const = 0;
  // The recipe the next pairs are measured with (called before the first pair and at
  // each change): a camera source sets its cameras' exposure and gain.
  virtual void UseRecipe(const Recipe& /*recipe*/) {}
  // The station is stopping: a source that fires triggers (a camera source) takes no new
  // ones from now on, and HasPending() says whether triggers already fired still await
  // their pair; the station takes those before it stops, so that every trigger has its record.
  virtual void StopTriggers() {}
  virtual bool HasPending() const { return false; }
};

// The folder source's timing and clean-up (station/folder_source.h).
struct FolderSourceOptions {
  // A half pair is reported after this: long enough for a camera program to write the
  // second image after the first, short enough that a lost image is reported within a
  // few parts.
  std::chrono::milliseconds half_pair_timeout{10000};
  // A file found at start-up counts once it has not been modified for this long.
  std::chrono::milliseconds settle{1000};
  // Pairs kept in done/ (the newest); 0 keeps none (files are deleted once recorded).
  int keep_done = 1000;
};

// `pairs:FILE.csv`: every pair the file lists, in order (paths relative to the file).
// Throws InputError as ReadPairsCsv does.
std::unique_ptr<PairSource> MakePairsFileSource(const std::filesystem::path& csv);

// A source from its command-line form: "pairs:FILE.csv" or "folder:DIR". Throws
// InputError naming the accepted forms otherwise.
std::unique_ptr<PairSource> MakePairSource(const std::string& spec, const FolderSourceOptions& folder = {});

}  // namespace flatscan
