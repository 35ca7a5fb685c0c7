#include "flatscan/exe/cli.h"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <iostream>
#include <memory>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/core.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include "flatscan/exe/commands.h"
#include "flatscan/exe/number_checks.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/util/error.h"

namespace flatscan {

namespace {

// A resident command asked for a graceful stop: the first signal sets graceful_stop.
std::atomic<bool> graceful_mode{false};
std::atomic<bool> graceful_stop{false};

// SIGINT and SIGTERM (Ctrl-C, a stopping service) are taken by one thread, outside any
// signal handler, so that it may remove the partial outputs (staging folders,
// temporaries) before the process ends: an interrupted run leaves nothing behind, and its
// exit code is 2 (could not run). Call before any other thread starts, so that every
// thread inherits the blocked signals.
void RemovePartialOutputsOnInterrupt() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  if (pthread_sigmask(SIG_BLOCK, &signals, nullptr) != 0) return;
  std::thread([signals] {
    int signal = 0;
    if (sigwait(&signals, &signal) != 0) return;
    if (graceful_mode.exchange(false)) {
      const char stopping[] = "flatscan: stopping (finishing what is in flight; a second signal ends it now)\n";
      [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, stopping, sizeof(stopping) - 1);
      graceful_stop = true;
      if (sigwait(&signals, &signal) != 0) return;
    }
    const char message[] = "flatscan: interrupted; partial outputs removed\n";
    RemoveRegisteredForCleanup();
    [[maybe_unused]] const ssize_t written = ::write(STDERR_FILENO, message, sizeof(message) - 1);
    ::_exit(2);
  }).detach();
}

// The command named on the command line must be one of ours: CLI11 says only "A
// subcommand is required" for `flatscan no-such-command`. The first argument that is no
// option (nor --threads' value) is the command.
std::string UnknownCommandMessage(int argc, char** argv, const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) names.push_back(sub->get_name());
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--threads") {
      ++i;
      continue;
    }
    if (arg.starts_with("-")) continue;
    if (std::find(names.begin(), names.end(), arg) != names.end()) return "";
    return fmt::format("unknown command '{}' (expected one of: {}; see flatscan --help)", arg, fmt::join(names, ", "));
  }
  return "";
}

}  // namespace

const std::atomic<bool>& StopGracefullyOnSignal() {
  graceful_mode = true;
  return graceful_stop;
}

int RunCli(int argc, char** argv) {
  RemovePartialOutputsOnInterrupt();
  CLI::App app{"flatscan: flatness inspection of thin metal parts with two cameras and a backlight.\n"
               "Exit codes: 0 success / measured and pass, 1 measured and fail, 2 could not measure or bad input."};
  app.set_version_flag("--version", std::string("flatscan ") + FLATSCAN_VERSION);
  app.require_subcommand(1);
  app.fallthrough();  // --threads and --quiet may follow the subcommand
  int threads = 0;
  bool quiet = false;
  app.add_option("--threads", threads, "worker threads (0: all cores)")->check(IntegerIn(0, 256));
  app.add_flag("-q,--quiet", quiet, "only warnings and errors on stderr");

  std::vector<std::unique_ptr<Command>> commands = MakeCommands();
  for (auto& command : commands) command->Register(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    const std::string unknown = UnknownCommandMessage(argc, argv, app);
    if (!unknown.empty()) {
      std::cerr << unknown << "\n";
      return 2;
    }
    app.exit(e);
    return 2;
  }
  auto logger = spdlog::stderr_color_mt("flatscan");
  logger->set_pattern("%^%l%$: %v");
  spdlog::set_default_logger(logger);
  spdlog::set_level(quiet ? spdlog::level::warn : spdlog::level::info);
  cv::setNumThreads(1);  // our own parallelism is TBB's
  std::unique_ptr<tbb::global_control> thread_limit;
  if (threads > 0)
    thread_limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, threads);
  for (auto& command : commands) {
    if (!command->Parsed()) continue;
    try {
      return command->Run();
    } catch (const InputError& e) {
      const std::string flag = e.field().empty() ? std::string() : command->FlagOf(e.field());
      spdlog::error("{}", flag.empty() ? std::string(e.what()) : flag + ": " + e.detail());
      return 2;
    } catch (const cv::Exception& e) {
      spdlog::error("OpenCV: {}", e.what());
      return 2;
    } catch (const std::bad_alloc&) {
      spdlog::error("out of memory: this input needs more memory than the machine has (docs/conventions.md, "
                    "\"Input limits\", says what flatscan bounds)");
      return 2;
    } catch (const std::exception& e) {
      spdlog::error("internal error: {}", e.what());
      return 2;
    }
  }
  return 2;
}

}  // namespace flatscan
