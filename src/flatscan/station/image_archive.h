#pragma once
// The image archive (`station --archive DIR`): the images behind the records that matter,
// kept by the recipe's policy (recipe.h, `archive`) within a disk quota.
//
// What is kept: every "fail" and every "not measured" pair, and one "pass" pair in
// `keep_pass_every` (the first, then every N-th pass this station run records).
// Layout: DIR/<pass|fail|not_measured>/<YYYY-MM-DD>/<source id>_<record id's first 8
// hex digits>_<left|right>.png, and _thumb.jpg for the part's thumbnail when the station
// makes them (inspection_report.h, DrawRimThumbnail: the report shows the worst parts') (the day is the record's UTC day; the source id made a safe
// file name by io/output_files.h's SafeFileName). A kept image is a copy (not a hard link: a
// source rewritten in place must not change it). The record names the two files
// (`archive`: {left, right}); its left_sha256/right_sha256 are their bytes' hashes.
//
// Quota: once the archive's files exceed `quota_mb`, the oldest "pass" pairs are removed
// first, then "fail" and "not measured" pairs older than `fail_retention_days`, oldest
// first; a fail within its retention period is never removed, nor is the pair just kept
// (the archive then stays over its quota, with a warning). Age is the image file's modification time. With several
// recipes, the quota and the retention are the largest any of them asks for, and
// keep_pass_every is that of the record's recipe.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "flatscan/station/pair_source.h"
#include "flatscan/station/recipe.h"
#include "flatscan/store/station_record.h"

namespace flatscan {

class ImageArchive {
 public:
  // Creates DIR when missing and indexes what it already holds. Throws InputError naming
  // the folder when it cannot be created or read.
  ImageArchive(std::filesystem::path dir, double quota_mb, double fail_retention_days);

  // Keeps the pair's images when the policy says so (and returns where), with the part's
  // thumbnail (JPEG bytes, when not empty) beside them, then applies the quota. Empty
  // when not kept. Throws InputError when the images cannot be written (a full disk): the
  // caller records the part without them.
  ArchivedPair Keep(const StationRecord& record, const SourcePair& pair, const ArchivePolicy& policy,
                    const std::string& thumbnail_jpeg = "");

  int64_t bytes() const { return bytes_; }
  size_t pairs() const { return entries_.size(); }

 private:
  struct Entry {
    std::string kind;  // pass, fail, not_measured
    std::filesystem::file_time_type time;
    std::vector<std::filesystem::path> files;
    int64_t bytes = 0;
  };
  void Index();
  void ApplyQuota();

  std::filesystem::path dir_;
  int64_t quota_bytes_;
  std::chrono::seconds retention_;
  std::vector<Entry> entries_;  // oldest first
  int64_t bytes_ = 0;
  int64_t passes_seen_ = 0;
  bool warned_full_ = false;
};

}  // namespace flatscan
