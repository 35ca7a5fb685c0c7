#include "flatscan/station/image_archive.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/io/image_io.h"
#include "flatscan/io/output_files.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

namespace fs = std::filesystem;

std::string Kind(const InspectionRecord& r) {
  if (!r.measured) return "not_measured";
  return r.judgement.pass() ? "pass" : "fail";
}

// `target` becomes a copy of `source` (a copy, not a hard link: a source rewritten in place
// later must not change the archived image its record's SHA-256 describes).
void Copy(const fs::path& source, const fs::path& target) {
  std::error_code ec;
  fs::copy_file(source, target, fs::copy_options::overwrite_existing, ec);
  if (ec) ThrowInputError("archive: cannot write {} ({})", target.string(), ec.message());
}

// A camera's frame as a PNG file (the record's hash is of its pixels: docs/cameras.md).
void WriteFrame(const cv::Mat1b& frame, const fs::path& target) {
  try {
    WriteImage(target.string(), frame);
  } catch (const std::exception& e) {
    ThrowInputError("archive: cannot write {} ({})", target.string(), e.what());
  }
}

void WriteBytes(const std::string& bytes, const fs::path& target) {
  std::ofstream out(target, std::ios::binary);
  out << bytes;
  out.close();
  if (!out) ThrowInputError("archive: cannot write {}", target.string());
}

}  // namespace

ImageArchive::ImageArchive(fs::path dir, double quota_mb, double fail_retention_days)
    : dir_(std::move(dir)),
      quota_bytes_(int64_t(quota_mb * 1024 * 1024)),
      retention_(int64_t(fail_retention_days * 86400)) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) ThrowInputError("--archive {}: cannot create the folder ({})", dir_.string(), ec.message());
  Index();
  spdlog::info("archive {}: {} pairs, {:.1f} MB of {:.0f} MB", dir_.string(), entries_.size(), bytes_ / 1048576.0,
               quota_mb);
}

// One entry per pair already in the archive (files grouped by their name without the
// side), oldest first.
void ImageArchive::Index() {
  std::map<fs::path, Entry> by_pair;
  for (const char* kind : {"pass", "fail", "not_measured"}) {
    if (!fs::is_directory(dir_ / kind)) continue;
    for (const auto& entry : fs::recursive_directory_iterator(dir_ / kind)) {
      if (!entry.is_regular_file()) continue;
      std::string stem = entry.path().filename().string();
      for (const char* side : {"_left.png", "_right.png", "_thumb.jpg"})
        if (stem.ends_with(side)) stem.resize(stem.size() - std::strlen(side));
      auto [it, added] = by_pair.try_emplace(entry.path().parent_path() / stem);
      Entry& e = it->second;
      // file_time_type{} is not "long ago": libstdc++'s file clock has its epoch in 2174.
      if (added) e.time = fs::file_time_type::min();
      e.kind = kind;
      e.time = std::max(e.time, entry.last_write_time());
      e.files.push_back(entry.path());
      e.bytes += int64_t(entry.file_size());
    }
  }
  for (auto& [key, e] : by_pair) {
    bytes_ += e.bytes;
    entries_.push_back(std::move(e));
  }
  std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) { return a.time < b.time; });
}

ArchivedPair ImageArchive::Keep(const StationRecord& record, const SourcePair& pair, const ArchivePolicy& policy,
                                const std::string& thumbnail_jpeg) {
  const std::string kind = Kind(record.inspection);
  if (kind == "pass") {
    const bool keep = policy.keep_pass_every > 0 && passes_seen_ % policy.keep_pass_every == 0;
    ++passes_seen_;
    if (!keep) return {};
  }
  const std::string day = UtcNowIso8601().substr(0, 10);  // the record's day (it is committed next)
  const fs::path folder = dir_ / kind / day;
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) ThrowInputError("archive: cannot create {} ({})", folder.string(), ec.message());
  const std::string stem = SafeFileName(record.source_id) + "_" + record.record_id.substr(0, 8);
  Entry entry{kind, fs::file_time_type::clock::now(), {}, 0};
  ArchivedPair out;
  try {
    for (const auto& [source, frame, name, target] :
         {std::tuple{pair.left, &pair.left_image, "_left.png", &out.left},
          std::tuple{pair.right, &pair.right_image, "_right.png", &out.right}}) {
      const bool from_camera = pair.frames && !frame->empty();
      if (!from_camera && !fs::is_regular_file(source)) continue;  // the missing half of a pair
      const fs::path file = folder / (stem + name);
      entry.files.push_back(file);
      if (from_camera) WriteFrame(*frame, file);
      else Copy(source, file);
      *target = file.string();
      entry.bytes += int64_t(fs::file_size(file));
    }
    if (!entry.files.empty() && !thumbnail_jpeg.empty()) {
      const fs::path file = folder / (stem + "_thumb.jpg");
      entry.files.push_back(file);
      WriteBytes(thumbnail_jpeg, file);
      out.thumbnail = file.string();
      entry.bytes += int64_t(thumbnail_jpeg.size());
    }
  } catch (...) {  // no half-archived pair left behind
    for (const fs::path& f : entry.files) fs::remove(f, ec);
    throw;
  }
  if (entry.files.empty()) return {};
  bytes_ += entry.bytes;
  entries_.push_back(std::move(entry));
  ApplyQuota();
  return out;
}

void ImageArchive::ApplyQuota() {
  const auto now = fs::file_time_type::clock::now();
  const auto evictable = [&](const Entry& e, bool pass_only) {
    return pass_only ? e.kind == "pass" : e.kind != "pass" && now - e.time > retention_;
  };
  // The pair just kept (the last entry) is never evicted: its record names it.
  for (const bool pass_only : {true, false}) {
    for (auto it = entries_.begin(); bytes_ > quota_bytes_ && it + 1 < entries_.end();) {
      if (!evictable(*it, pass_only)) {
        ++it;
        continue;
      }
      for (const fs::path& f : it->files) fs::remove(f);
      bytes_ -= it->bytes;
      it = entries_.erase(it);
    }
  }
  if (bytes_ > quota_bytes_ && !warned_full_) {
    spdlog::warn("archive {}: {:.1f} MB, over its quota of {:.0f} MB, all of it fails and not-measured pairs within "
                 "their retention: nothing more can be removed (raise quota_mb or lower fail_retention_days)",
                 dir_.string(), bytes_ / 1048576.0, quota_bytes_ / 1048576.0);
    warned_full_ = true;
  }
  if (bytes_ <= quota_bytes_) warned_full_ = false;
}

}  // namespace flatscan
