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
std::unique_ptr<Command> MakeInspectCommand();
std::unique_ptr<Command> MakeEdgesCommand();
std::unique_ptr<Command> MakeEvaluateCommand();
std::unique_ptr<Command> MakeEvaluateEdgesCommand();
std::unique_ptr<Command> MakeCalibrateRigCommand();
std::unique_ptr<Command> MakeImportRigCommand();
std::unique_ptr<Command> MakeCalibratePlaneCommand();

inline std::vector<std::unique_ptr<Command>> MakeCommands() {
  std::vector<std::unique_ptr<Command>> out;
  out.push_back(MakeDemoCommand());
  out.push_back(MakeSimulateCommand());
  out.push_back(MakeInspectCommand());
  out.push_back(MakeEdgesCommand());
  out.push_back(MakeEvaluateCommand());
  out.push_back(MakeEvaluateEdgesCommand());
  out.push_back(MakeCalibrateRigCommand());
  out.push_back(MakeImportRigCommand());
  out.push_back(MakeCalibratePlaneCommand());
  return out;
}

}  // namespace flatscan
