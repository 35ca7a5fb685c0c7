#pragma once
// The flatscan command-line tool: subcommands on top of the library.
// Exit codes (docs/conventions.md): 0 measured and pass (or success), 1 measured and
// fail, 2 could not measure / bad input.
namespace flatscan {
int RunCli(int argc, char** argv);
}
