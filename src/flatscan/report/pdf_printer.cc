#include "flatscan/report/pdf_printer.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fmt/format.h>

extern char** environ;

namespace flatscan {
namespace {

namespace fs = std::filesystem;

// A private folder for Chromium's profile and log, removed when it goes.
class TempFolder {
 public:
  TempFolder() {
    std::string pattern = (fs::temp_directory_path() / "flatscan-chromium-XXXXXX").string();
    if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot create a temporary folder for Chromium");
    path_ = pattern;
  }
  ~TempFolder() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string LastLines(const fs::path& log, size_t count) {
  std::ifstream in(log);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(line);
  std::string out;
  for (size_t i = lines.size() > count ? lines.size() - count : 0; i < lines.size(); ++i) out += "\n  " + lines[i];
  return out;
}

// Starts `args` in its own process group, standard output and error to `log`; its pid.
pid_t Spawn(const std::vector<std::string>& args, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attr, 0);
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int error = posix_spawnp(&pid, argv[0], &actions, &attr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (error != 0)
    throw std::runtime_error(fmt::format("cannot start '{}': {} (install Debian's chromium)", args[0],
                                         std::strerror(error)));
  return pid;
}

// Waits for `pid` for at most `timeout_s`; its wait status. On the time limit its whole
// process group is killed (Chromium's renderers too) and this throws.
int WaitWithin(pid_t pid, double timeout_s, const std::string& what) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(-pid, SIGKILL);
      waitpid(pid, &status, 0);
      throw std::runtime_error(fmt::format("{} did not finish within {} s (killed)", what, timeout_s));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(-pid, SIGKILL);  // a helper process left behind by Chromium
  return status;
}

}  // namespace

int PrintHtmlToPdf(const std::string& html_text, const fs::path& pdf, const PdfPrintOptions& options) {
  const TempFolder temp;
  const fs::path log = temp.path() / "chromium.log", html = temp.path() / "report.html";
  std::ofstream(html, std::ios::binary) << html_text;
  std::vector<std::string> args = {options.chromium,
                                   "--headless",
                                   "--disable-gpu",
                                   "--no-pdf-header-footer",
                                   "--user-data-dir=" + (temp.path() / "profile").string(),
                                   "--print-to-pdf=" + fs::absolute(pdf).string()};
  if (geteuid() == 0) args.push_back("--no-sandbox");
  args.push_back("file://" + html.string());
  const std::string what = fmt::format("'{}' printing the report", options.chromium);
  const int status = WaitWithin(Spawn(args, log), options.timeout_s, what);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw std::runtime_error(fmt::format("{} failed ({}); it printed:{}", what,
                                         WIFEXITED(status) ? fmt::format("exit code {}", WEXITSTATUS(status))
                                                           : fmt::format("signal {}", WTERMSIG(status)),
                                         LastLines(log, 5)));
  std::ifstream in(pdf, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  const int pages = PdfPageCount(bytes.str());
  if (pages == 0) throw std::runtime_error(fmt::format("{} wrote no PDF pages; it printed:{}", what, LastLines(log, 5)));
  return pages;
}

int PdfPageCount(const std::string& bytes) {
  if (bytes.rfind("%PDF-", 0) != 0) return 0;
  static const std::regex page(R"(/Type\s*/Page(?![a-zA-Z]))");
  return int(std::distance(std::sregex_iterator(bytes.begin(), bytes.end(), page), std::sregex_iterator()));
}

}  // namespace flatscan
