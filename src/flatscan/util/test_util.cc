#include "flatscan/util/test_util.h"

#include <signal.h>
#include <fcntl.h>
#include <spawn.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <random>
#include <fstream>
#include <thread>
#include <sstream>

#include "flatscan/util/error.h"

namespace flatscan::testing {

ScratchDir::ScratchDir(const std::string& name) {
  path_ = std::filesystem::temp_directory_path() / ("flatscan-test-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(path_);
  std::filesystem::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string InputErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string ReadFileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

CommandResult RunFlatscan(const std::string& args, int timeout_s) {
#ifdef FLATSCAN_BINARY
  const std::string binary = FLATSCAN_BINARY;
#else
  const std::string binary = "build/flatscan";
#endif
  const std::filesystem::path base = std::filesystem::temp_directory_path() /
                                     ("flatscan-run-" + std::to_string(::getpid()));
  const std::string out = base.string() + ".out", err = base.string() + ".err";
  const std::string limit = timeout_s > 0 ? "timeout -s KILL " + std::to_string(timeout_s) + " " : "";
  const std::string command = limit + "'" + binary + "' " + args + " >'" + out + "' 2>'" + err + "' </dev/null";
  const int status = std::system(command.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = ReadFileBytes(out);
  r.err = ReadFileBytes(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

namespace {
std::string Binary() {
#ifdef FLATSCAN_BINARY
  return FLATSCAN_BINARY;
#else
  return "build/flatscan";
#endif
}
}  // namespace

BackgroundProcess::BackgroundProcess(const std::string& program, const std::vector<std::string>& args,
                                     const std::filesystem::path& log) {
  std::vector<std::string> argv_text = {program};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  if (posix_spawnp(&pid, argv_text[0].c_str(), &actions, nullptr, argv.data(), environ) == 0) pid_ = pid;
  posix_spawn_file_actions_destroy(&actions);
}

BackgroundProcess::~BackgroundProcess() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGKILL);
  int status = 0;
  ::waitpid(pid_, &status, 0);
}

void BackgroundProcess::Signal(int signal) const {
  if (pid_ > 0) ::kill(pid_, signal);
}

int BackgroundProcess::Wait(double timeout_s) {
  if (pid_ <= 0) return -1;
  int status = 0;
  const bool ended = WaitFor([&] { return ::waitpid(pid_, &status, WNOHANG) == pid_; }, timeout_s);
  if (!ended) return -1;  // the destructor kills it
  pid_ = -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

bool MakeSelfSignedCertificate(const std::filesystem::path& cert, const std::filesystem::path& key,
                               const std::filesystem::path& log) {
  const std::string command = "openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=127.0.0.1 "
                              "-addext subjectAltName=IP:127.0.0.1 -keyout '" +
                              key.string() + "' -out '" + cert.string() + "' > '" + log.string() + "' 2>&1";
  return std::system(command.c_str()) == 0;
}

BackgroundFlatscan::BackgroundFlatscan(const std::vector<std::string>& args, const std::filesystem::path& log)
    : BackgroundProcess(Binary(), args, log) {}

namespace {
sockaddr_in Loopback(int port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return a;
}
}  // namespace

// Below Linux's ephemeral range (32768-60999), so that no outgoing connection (a client
// reconnecting to a broker that is down) takes the port while its server is away.
int FreeLoopbackPort() {
  static std::mt19937 random(static_cast<unsigned>(::getpid()) * 7919u + static_cast<unsigned>(::time(nullptr)));
  for (int attempt = 0; attempt < 200; ++attempt) {
    const int port = std::uniform_int_distribution<int>(20000, 32000)(random);
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return -1;
    const sockaddr_in a = Loopback(port);
    const bool free = ::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) == 0;
    ::close(fd);
    if (free) return port;
  }
  return -1;
}

bool LoopbackPortAccepts(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return false;
  const sockaddr_in a = Loopback(port);
  const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) == 0;
  ::close(fd);
  return ok;
}

bool WaitFor(const std::function<bool()>& condition, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!condition()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

LocalTimeZone::LocalTimeZone(const char* tz) {
  if (const char* old = std::getenv("TZ")) old_ = old, had_old_ = true;
  setenv("TZ", tz, 1);
  tzset();
}

LocalTimeZone::~LocalTimeZone() {
  if (had_old_) setenv("TZ", old_.c_str(), 1);
  else unsetenv("TZ");
  tzset();
}

}  // namespace flatscan::testing
