#include "flatscan/io/output_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "flatscan/io/atomic_output.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace fs = std::filesystem;

namespace {

bool IsStdout(const fs::path& path) { return path == "-"; }

// The same file: through hard links when both exist, else the same resolved path
// (symbolic links and ".." resolved in the part that exists).
bool SameFile(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  const fs::path ra = fs::weakly_canonical(a, ec);
  if (ec) return false;
  const fs::path rb = fs::weakly_canonical(b, ec);
  return !ec && ra == rb;
}

const char* KindOf(fs::file_type type) {
  switch (type) {
    case fs::file_type::directory: return "a folder";
    case fs::file_type::fifo: return "a FIFO";
    case fs::file_type::character: return "a character device";
    case fs::file_type::block: return "a block device";
    case fs::file_type::socket: return "a socket";
    case fs::file_type::symlink: return "a symbolic link";
    default: return "not a regular file";
  }
}

// The folder of `path` must exist (or, with `create`, its nearest existing ancestor must
// be a folder) and accept a new file.
void RequireWritableFolder(const std::string& option, const fs::path& path, bool create) {
  fs::path folder = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  std::error_code ec;
  if (create)
    while (!fs::exists(folder, ec) && folder.has_parent_path() && folder.parent_path() != folder)
      folder = folder.parent_path();
  const fs::file_status status = fs::status(folder, ec);
  if (status.type() == fs::file_type::not_found)
    ThrowInputError("{} '{}': the folder '{}' does not exist", option, path.string(), folder.string());
  if (status.type() != fs::file_type::directory)
    ThrowInputError("{} '{}': '{}' is not a folder", option, path.string(), folder.string());
  if (::access(folder.c_str(), W_OK | X_OK) != 0) {
    const int error = errno;
    ThrowInputError("{} '{}': cannot write in '{}': {}", option, path.string(), folder.string(),
                    std::strerror(error));
  }
}

}  // namespace

OutputFiles::OutputFiles(std::vector<Named> inputs) : inputs_(std::move(inputs)) {}

OutputFiles::~OutputFiles() {
  for (const Output& o : outputs_) {
    if (!o.staged || o.temporary.empty()) continue;
    std::error_code ignored;
    fs::remove(o.temporary, ignored);
    UnregisterForCleanup(o.temporary);
  }
}

void OutputFiles::Declare(const std::string& option, const fs::path& path, int flags) {
  FLATSCAN_CHECK(!committed_ && !Declared(option));
  if (path.empty() || IsStdout(path)) {
    if (!path.empty() && !(flags & kStdoutAllowed))
      ThrowInputError("{}: '-' (standard output) is not possible for this output; give a file name", option);
    outputs_.push_back({option, path, flags, {}, {}, false});
    return;
  }
  if (path.filename().empty() || path.filename() == "." || path.filename() == "..")
    ThrowInputError("{} '{}': not a file name", option, path.string());
  std::error_code ec;
  const fs::file_status link_status = fs::symlink_status(path, ec);
  if (fs::exists(link_status) && link_status.type() != fs::file_type::regular)
    ThrowInputError("{} '{}': is {}; an output must be a regular file or a new name (flatscan replaces "
                    "only regular files)",
                    option, path.string(), KindOf(link_status.type()));
  for (const auto& [input_option, input] : inputs_)
    if (!input.empty() && SameFile(path, input))
      ThrowInputError("{} '{}': is the input of {}; choose another output name", option, path.string(),
                      input_option);
  for (const Output& other : outputs_)
    if (!IsStdout(other.path) && !other.path.empty() && SameFile(path, other.path))
      ThrowInputError("{} '{}': is also the output of {}; give each output its own name", option, path.string(),
                      other.option);
  RequireWritableFolder(option, path, flags & kCreateFolder);
  outputs_.push_back({option, path, flags, {}, {}, false});
}

bool OutputFiles::Declared(const std::string& option) const {
  for (const Output& o : outputs_)
    if (o.option == option) return true;
  return false;
}

OutputFiles::Output& OutputFiles::Find(const std::string& option) {
  for (Output& o : outputs_)
    if (o.option == option) return o;
  throw std::logic_error("OutputFiles: output not declared: " + option);
}

void OutputFiles::Stage(const std::string& option, const std::function<void(const fs::path& tmp)>& write) {
  Output& o = Find(option);
  if (o.path.empty()) return;  // not asked for
  FLATSCAN_CHECK(!committed_ && !o.staged && !IsStdout(o.path));
  if (o.flags & kCreateFolder) {
    std::error_code ec;
    fs::create_directories(o.path.parent_path(), ec);
    if (ec) ThrowInputError("{} '{}': cannot create its folder: {}", option, o.path.string(), ec.message());
  }
  const fs::path tmp = TemporaryPathFor(o.path);
  RegisterForCleanup(tmp);
  try {
    write(tmp);
    std::error_code ec;
    if (!fs::is_regular_file(tmp, ec))
      ThrowInputError("{} '{}': cannot write: the writer produced no file", option, o.path.string());
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    UnregisterForCleanup(tmp);
    throw;
  }
  o.temporary = tmp;
  o.staged = true;
}

void OutputFiles::StageText(const std::string& option, const std::string& text) {
  Output& o = Find(option);
  if (o.path.empty()) return;
  if (IsStdout(o.path)) {
    FLATSCAN_CHECK(!committed_ && !o.staged);
    o.text = text;
    o.staged = true;
    return;
  }
  Stage(option, [&](const fs::path& tmp) { WriteTextFileAtomically(tmp, text); });
}

void OutputFiles::Commit() {
  FLATSCAN_CHECK(!committed_);
  for (Output& o : outputs_) {
    if (!o.staged || IsStdout(o.path) || o.path.empty()) continue;
    std::error_code ec;
    fs::rename(o.temporary, o.path, ec);
    if (ec) ThrowInputError("{} '{}': cannot write: {}", o.option, o.path.string(), ec.message());
    UnregisterForCleanup(o.temporary);
    o.temporary.clear();
  }
  committed_ = true;
  for (const Output& o : outputs_)
    if (o.staged && IsStdout(o.path)) std::cout << o.text << std::flush;
}

std::string SafeFileName(const std::string& id) {
  std::string name;
  for (const char c : id.substr(0, 100)) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-';
    name.push_back(ok && !(name.empty() && c == '.') ? c : '_');
  }
  if (name.empty()) name.push_back('_');
  return name;
}

std::string UniqueFileName(const std::string& name, std::set<std::string>* taken) {
  std::string unique = name;
  for (int k = 2; taken->count(unique) > 0; ++k) unique = fmt::format("{}-{}", name, k);
  taken->insert(unique);
  return unique;
}

}  // namespace flatscan
