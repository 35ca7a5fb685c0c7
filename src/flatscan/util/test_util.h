#pragma once
// Helpers shared by the tests: scratch folders and running the flatscan binary.
#include <filesystem>
#include <functional>
#include <string>

namespace flatscan::testing {

// A fresh, empty folder under the system temp folder, removed on destruction.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name);
  ~ScratchDir();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

struct CommandResult {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};

// Runs build/flatscan with `args` (a shell-quoted string). With `timeout_s` > 0 the
// process is killed after that many seconds (exit code 137), so that a hang fails the
// test instead of stalling it.
CommandResult RunFlatscan(const std::string& args, int timeout_s = 0);

// The message of the InputError that `f` throws, or "(no error)".
std::string InputErrorOf(const std::function<void()>& f);

// Reads a whole file as bytes.
std::string ReadFileBytes(const std::filesystem::path& path);

}  // namespace flatscan::testing
