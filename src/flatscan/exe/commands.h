#pragma once
// One class per subcommand: Register() adds its options to the CLI, Run() does the
// work and returns the exit code. Each lives in its own <name>_command.cc.
#include <memory>
#include <vector>

#include <CLI/CLI.hpp>

namespace flatscan {

class Command {
 public:
  virtual ~Command() = default;
  virtual void Register(CLI::App& app) = 0;
  virtual int Run() = 0;
  bool Parsed() const { return sub_ != nullptr && sub_->parsed(); }

 protected:
  CLI::App* sub_ = nullptr;
};

std::unique_ptr<Command> MakeSimulateCommand();
std::unique_ptr<Command> MakeDemoCommand();

inline std::vector<std::unique_ptr<Command>> MakeCommands() {
  std::vector<std::unique_ptr<Command>> out;
  out.push_back(MakeDemoCommand());
  out.push_back(MakeSimulateCommand());
  return out;
}

}  // namespace flatscan
