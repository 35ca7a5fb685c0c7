#include "flatscan/exe/cli.h"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <iostream>
#include <memory>
#include <thread>

#include <CLI/CLI.hpp>
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
    const char message[] = "flatscan: interrupted; partial outputs removed\n";
    RemoveRegisteredForCleanup();
    [[maybe_unused]] const ssize_t written = ::write(STDERR_FILENO, message, sizeof(message) - 1);
    ::_exit(2);
  }).detach();
}

}  // namespace

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
    } catch (const std::exception& e) {
      spdlog::error("internal error: {}", e.what());
      return 2;
    }
  }
  return 2;
}

}  // namespace flatscan
