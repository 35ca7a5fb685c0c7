#pragma once
// Helpers shared by the tests: scratch folders and running the flatscan binary.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

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

// A process in the background (a station, a broker): `program` started with `args`
// (one per element), standard output and error to `log`. Destroying it while it runs
// kills it (SIGKILL) and reaps it, so that a failed test leaves no process behind.
class BackgroundProcess {
 public:
  BackgroundProcess(const std::string& program, const std::vector<std::string>& args,
                    const std::filesystem::path& log);
  ~BackgroundProcess();
  BackgroundProcess(const BackgroundProcess&) = delete;
  BackgroundProcess& operator=(const BackgroundProcess&) = delete;
  bool started() const { return pid_ > 0; }
  void Signal(int signal) const;
  // Waits at most `timeout_s` for the process to end: its exit code, 128 + the signal
  // that ended it, or -1 when it still ran at the deadline (it is then killed).
  int Wait(double timeout_s);

 private:
  int pid_ = -1;
};

// The flatscan binary in the background.
class BackgroundFlatscan : public BackgroundProcess {
 public:
  BackgroundFlatscan(const std::vector<std::string>& args, const std::filesystem::path& log);
};

// A self-signed certificate for 127.0.0.1 (RSA 2048, two days; `cert` is also the CA a
// client trusts) and its unencrypted key, made with the openssl tool (its output to
// `log`); whether it worked.
bool MakeSelfSignedCertificate(const std::filesystem::path& cert, const std::filesystem::path& key,
                               const std::filesystem::path& log);

// A TCP port on 127.0.0.1 that was free a moment ago (20000-32000, below the ephemeral range).
int FreeLoopbackPort();
// Whether something accepts TCP connections on 127.0.0.1:`port`.
bool LoopbackPortAccepts(int port);

// Polls `condition` every 20 ms until it holds or `timeout_s` passes; whether it held.
bool WaitFor(const std::function<bool()>& condition, double timeout_s);

// The message of the InputError that `f` throws, or "(no error)".
std::string InputErrorOf(const std::function<void()>& f);

// Reads a whole file as bytes.
std::string ReadFileBytes(const std::filesystem::path& path);

// Sets the local time zone (TZ, a POSIX rule such as "CET-1CEST,M3.5.0,M10.5.0/3": no
// time-zone database needed) for as long as it lives.
class LocalTimeZone {
 public:
  explicit LocalTimeZone(const char* tz);
  ~LocalTimeZone();
  LocalTimeZone(const LocalTimeZone&) = delete;
  LocalTimeZone& operator=(const LocalTimeZone&) = delete;

 private:
  std::string old_;
  bool had_old_ = false;
};

}  // namespace flatscan::testing
