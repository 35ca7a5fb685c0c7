#include "flatscan/io/atomic_output.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
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

// ".<stem>.tmp-<pid>-<n><extensions>" in the folder of `path`. Everything from the first
// dot of the file name (ignoring a leading one) is kept at the end, so that writers
// which pick the format from the extension (cv::imwrite, cv::FileStorage, also with
// ".yml.gz") see the same extension as for the final name.
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

void RemoveQuietly(const fs::path& path) {
  std::error_code ignored;
  fs::remove(path, ignored);
}

}  // namespace

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

  try {
    write(tmp);
    std::error_code ec;
    if (!fs::is_regular_file(tmp, ec))
      ThrowInputError("cannot write '{}': the writer produced no file", path.string());
    fs::rename(tmp, path, ec);
    if (ec) ThrowInputError("cannot write '{}': {}", path.string(), ec.message());
  } catch (...) {
    RemoveQuietly(tmp);
    throw;
  }
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

StagedDirectory::StagedDirectory(fs::path final_dir) : final_(std::move(final_dir)) {
  // "out/" names the folder "out".
  if (!final_.has_filename() && final_.has_parent_path()) final_ = final_.parent_path();
  const std::string name = final_.filename().string();
  if (name.empty() || name == "." || name == "..")
    ThrowInputError("cannot create folder '{}': not a folder name", final_.string());

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
}

StagedDirectory::~StagedDirectory() {
  if (committed_ || staging_.empty()) return;
  std::error_code ignored;
  fs::remove_all(staging_, ignored);
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
  staging_ = final_;  // path() now names the committed folder
  if (!old.empty()) {
    std::error_code ignored;
    fs::remove_all(old, ignored);
  }
}

}  // namespace flatscan
