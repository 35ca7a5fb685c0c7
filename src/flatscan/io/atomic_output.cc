#include "flatscan/io/atomic_output.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <mutex>
#include <vector>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

#include "flatscan/util/error.h"

namespace flatscan {
namespace fs = std::filesystem;

namespace {

// Distinguishes temporaries of several writes of the same file within one process.
std::atomic<unsigned> g_temp_counter{0};

// The folder a file path lives in ("." for a bare file name).
fs::path FolderOf(const fs::path& path) {
  const fs::path parent = path.parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

// Throws InputError "cannot write '<path>': ..." unless `folder` is an existing folder.
void RequireFolder(const fs::path& path, const fs::path& folder) {
  std::error_code ec;
  const fs::file_status status = fs::status(folder, ec);
  if (status.type() == fs::file_type::not_found)
    ThrowInputError("cannot write '{}': folder '{}' does not exist", path.string(),
                    folder.string());
  if (ec) ThrowInputError("cannot write '{}': {}", path.string(), ec.message());
  if (status.type() != fs::file_type::directory)
    ThrowInputError("cannot write '{}': '{}' is not a folder", path.string(), folder.string());
}

void RemoveQuietly(const fs::path& path) {
  std::error_code ignored;
  fs::remove(path, ignored);
}

bool WrittenByFlatscan(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / StagedDirectory::kOutputMarker, ec);
}

// An existing `final` must be a folder flatscan wrote, unless `replace_any`.
void CheckReplaceable(const fs::path& final_dir, bool replace_any) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(final_dir, ec);
  if (!fs::exists(status)) return;
  if (status.type() != fs::file_type::directory)
    ThrowInputError("cannot replace '{}': it exists and is not a folder", final_dir.string());
  if (!replace_any && !WrittenByFlatscan(final_dir))
    ThrowInputError("cannot replace '{}': the folder exists and flatscan did not write it (it has no {}); "
                    "choose another output folder, or give --force to replace it",
                    final_dir.string(), StagedDirectory::kOutputMarker);
}

// "<name>.partial-<pid>[-n][.old]" folders of processes that no longer run (killed
// before they could clean up), holding the marker.
void RemoveStalePartials(const fs::path& parent, const std::string& name) {
  const std::string prefix = name + ".partial-";
  std::error_code ec;
  for (fs::directory_iterator it(parent, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string entry = it->path().filename().string();
    if (!entry.starts_with(prefix)) continue;
    const long pid = std::strtol(entry.c_str() + prefix.size(), nullptr, 10);
    const bool running = pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM);
    if (running || !WrittenByFlatscan(it->path())) continue;
    std::error_code ignored;
    fs::remove_all(it->path(), ignored);
  }
}

std::mutex g_cleanup_mutex;
std::vector<fs::path>& CleanupList() {
  static std::vector<fs::path> paths;
  return paths;
}

}  // namespace

fs::path TemporaryPathFor(const fs::path& path) {
  const std::string name = path.filename().string();
  const size_t dot = name.find('.', 1);
  const std::string stem = dot == std::string::npos ? name : name.substr(0, dot);
  const std::string extensions = dot == std::string::npos ? "" : name.substr(dot);
  const std::string temp_name =
      fmt::format("{}{}.tmp-{}-{}{}", stem.starts_with('.') ? "" : ".", stem,
                  static_cast<long>(::getpid()), g_temp_counter.fetch_add(1), extensions);
  return path.parent_path() / temp_name;
}

void WriteFileAtomically(const fs::path& path,
                         const std::function<void(const fs::path& tmp_path)>& write) {
  if (path.filename().empty() || path.filename() == "." || path.filename() == "..")
    ThrowInputError("cannot write '{}': not a file name", path.string());
  RequireFolder(path, FolderOf(path));
  std::error_code status_error;
  if (fs::is_directory(path, status_error))
    ThrowInputError("cannot write '{}': a folder of that name exists", path.string());

  const fs::path tmp = TemporaryPathFor(path);
  // Probe that the folder is writable, so that the error names the reason (writers
  // such as cv::imwrite only return false).
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) {
    const int error = errno;
    ThrowInputError("cannot write '{}': {}", path.string(), std::strerror(error));
  }
  ::close(fd);
  RemoveQuietly(tmp);

  RegisterForCleanup(tmp);
  try {
    write(tmp);
    std::error_code ec;
    if (!fs::is_regular_file(tmp, ec))
      ThrowInputError("cannot write '{}': the writer produced no file", path.string());
    fs::rename(tmp, path, ec);
    if (ec) ThrowInputError("cannot write '{}': {}", path.string(), ec.message());
  } catch (...) {
    RemoveQuietly(tmp);
    UnregisterForCleanup(tmp);
    throw;
  }
  UnregisterForCleanup(tmp);
}

void WriteTextFileAtomically(const fs::path& path, const std::string& text) {
  WriteFileAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      const int error = errno;
      ThrowInputError("cannot write '{}': {}", path.string(), std::strerror(error));
    }
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.close();
    if (out.fail()) ThrowInputError("cannot write '{}': write failed", path.string());
  });
}

StagedDirectory::StagedDirectory(fs::path final_dir, bool replace_any) : final_(std::move(final_dir)) {
  // "out/" names the folder "out".
  if (!final_.has_filename() && final_.has_parent_path()) final_ = final_.parent_path();
  const std::string name = final_.filename().string();
  if (name.empty() || name == "." || name == "..")
    ThrowInputError("cannot create folder '{}': not a folder name", final_.string());
  CheckReplaceable(final_, replace_any);

  const fs::path parent = FolderOf(final_);
  std::error_code ec;
  if (fs::exists(fs::status(parent, ec)) && !fs::is_directory(fs::status(parent, ec)))
    ThrowInputError("cannot create folder '{}': '{}' is not a folder", final_.string(),
                    parent.string());
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent)) {
    ThrowInputError("cannot create folder '{}': cannot create '{}': {}", final_.string(),
                    parent.string(),
                    ec ? ec.message() : std::make_error_code(std::errc::not_a_directory).message());
  }
  RemoveStalePartials(parent, name);

  // "<final>.partial-<pid>"; a suffix is added only if that is taken (another staging
  // folder of this process, or a left-over of a crashed process with the same pid).
  const std::string base = fmt::format("{}.partial-{}", name, static_cast<long>(::getpid()));
  for (int attempt = 0;; ++attempt) {
    const fs::path candidate =
        final_.parent_path() / (attempt == 0 ? base : fmt::format("{}-{}", base, attempt));
    if (fs::create_directory(candidate, ec)) {
      staging_ = candidate;
      break;
    }
    if (ec)
      ThrowInputError("cannot create folder '{}': {}", candidate.string(), ec.message());
    if (attempt >= 1000)
      ThrowInputError("cannot create folder '{}': too many staging folders", final_.string());
  }
  RegisterForCleanup(staging_);
  WriteTextFileAtomically(staging_ / kOutputMarker,
                          "Written by flatscan: `-o` may replace this folder.\n");
}

StagedDirectory::~StagedDirectory() {
  if (committed_ || staging_.empty()) return;
  std::error_code ignored;
  fs::remove_all(staging_, ignored);
  UnregisterForCleanup(staging_);
}

void StagedDirectory::Commit() {
  FLATSCAN_CHECK(!committed_);
  std::error_code ec;
  const fs::file_status existing = fs::symlink_status(final_, ec);
  fs::path old;
  if (fs::exists(existing)) {
    if (!fs::is_directory(fs::status(final_, ec)))
      ThrowInputError("cannot replace '{}': it exists and is not a folder", final_.string());
    // Move the old folder aside first (deleting it in place could be interrupted and
    // leave a half-deleted folder that looks complete), then delete it once the new
    // one is in place.
    old = fs::path(staging_.string() + ".old");
    fs::remove_all(old, ec);
    fs::rename(final_, old, ec);
    if (ec) ThrowInputError("cannot replace '{}': {}", final_.string(), ec.message());
  }
  fs::rename(staging_, final_, ec);
  if (ec) {
    const std::string reason = ec.message();
    if (!old.empty()) {
      std::error_code ignored;
      fs::rename(old, final_, ignored);
    }
    ThrowInputError("cannot create folder '{}': {}", final_.string(), reason);
  }
  committed_ = true;
  UnregisterForCleanup(staging_);
  staging_ = final_;  // path() now names the committed folder
  if (!old.empty()) {
    std::error_code ignored;
    fs::remove_all(old, ignored);
  }
}

void RegisterForCleanup(const fs::path& path) {
  const std::lock_guard<std::mutex> lock(g_cleanup_mutex);
  CleanupList().push_back(path);
}

void UnregisterForCleanup(const fs::path& path) {
  const std::lock_guard<std::mutex> lock(g_cleanup_mutex);
  std::erase(CleanupList(), path);
}

void RemoveRegisteredForCleanup() {
  const std::lock_guard<std::mutex> lock(g_cleanup_mutex);
  for (const fs::path& path : CleanupList()) {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
  CleanupList().clear();
}

}  // namespace flatscan
