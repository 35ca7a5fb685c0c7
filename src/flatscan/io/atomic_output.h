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

// Writes `text` to `path` atomically.
void WriteTextFileAtomically(const std::filesystem::path& path, const std::string& text);

// A folder under construction. Create() makes "<final>.partial-<pid>" (throws
// InputError naming the path if its parent cannot be created or written); Commit()
// replaces `final` with it. If destroyed without Commit() the partial folder is
// removed, so an interrupted run leaves nothing that looks complete.
class StagedDirectory {
 public:
  explicit StagedDirectory(std::filesystem::path final_dir);
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

}  // namespace flatscan
