#pragma once
// The flatscan command-line tool: subcommands on top of the library.
// Exit codes (docs/conventions.md): 0 measured and pass (or success), 1 measured and
// fail, 2 could not measure / bad input.
#include <atomic>

namespace flatscan {
int RunCli(int argc, char** argv);
// For a resident command (the station): from this call on, the first SIGINT or SIGTERM
// sets the returned flag (the command finishes what is in flight and exits 0) instead
// of ending the process; a second one ends it (exit 2). The flag lives as long as the
// process.
const std::atomic<bool>& StopGracefullyOnSignal();
}
