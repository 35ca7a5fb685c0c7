#pragma once
// Output that never looks complete unless it is: files are written under a temporary
// name in the same folder and renamed into place; output folders are built as
// "<dir>.partial-XXXX" and renamed to <dir> only when everything in them is written.
#include <filesystem>
#include <functional>
#include <string>

namespace flatscan {

// Calls write(tmp_path) then renames tmp_path -> path. On any exception the temporary
// is removed and the exception propagates. Throws InputError naming `path` if the
// folder is not writable.
void WriteFileAtomically(const std::filesystem::path& path,
                         const std::function<void(const std::filesystem::path& tmp_path)>& write);

// ".<stem>.tmp-<pid>-<n><extensions>" in the folder of `path`. Everything from the first
// dot of the file name (ignoring a leading one) is kept at the end, so that writers
// which pick the format from the extension (cv::imwrite, cv::FileStorage, also with
// ".yml.gz") see the same extension as for the final name.
std::filesystem::path TemporaryPathFor(const std::filesystem::path& path);

// Writes `text` to `path` atomically.
void WriteTextFileAtomically(const std::filesystem::path& path, const std::string& text);

// A folder under construction. The constructor makes "<final>.partial-<pid>" with the
// marker file kOutputMarker in it (throws InputError naming the path if its parent cannot
// be created or written); Commit() replaces `final` with it. If destroyed without
// Commit() the partial folder is removed, so an interrupted run leaves nothing that looks
// complete; a process killed outright leaves its partial folder, which the next
// StagedDirectory of the same final folder removes (its pid is gone).
//
// An existing `final` is replaced only if flatscan wrote it (it holds kOutputMarker) or
// with `replace_any` (the --force of simulate, evaluate and demo); else, and when `final`
// is not a folder, the constructor throws, before any work.
class StagedDirectory {
 public:
  static constexpr const char* kOutputMarker = ".flatscan-output";
  explicit StagedDirectory(std::filesystem::path final_dir, bool replace_any = false);
  ~StagedDirectory();
  StagedDirectory(const StagedDirectory&) = delete;
  StagedDirectory& operator=(const StagedDirectory&) = delete;

  const std::filesystem::path& path() const { return staging_; }  // write here
  const std::filesystem::path& final_path() const { return final_; }
  void Commit();

 private:
  std::filesystem::path final_;
  std::filesystem::path staging_;
  bool committed_ = false;
};

// Paths removed if the process is interrupted (SIGINT, SIGTERM) before it unregisters
// them: staging folders and temporaries. The command-line layer calls
// RemoveRegisteredForCleanup from its signal-handling thread.
void RegisterForCleanup(const std::filesystem::path& path);
void UnregisterForCleanup(const std::filesystem::path& path);
void RemoveRegisteredForCleanup();

}  // namespace flatscan
