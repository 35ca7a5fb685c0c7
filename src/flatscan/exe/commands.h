#pragma once
// One class per subcommand: Register() adds its options to the CLI, Run() does the
// work and returns the exit code. Each lives in its own <name>_command.cc and stays
// thin: it parses flags into the library's options, calls the library, prints.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace flatscan {

class Command {
 public:
  virtual ~Command() = default;
  virtual void Register(CLI::App& app) = 0;
  virtual int Run() = 0;
  bool Parsed() const { return sub_ != nullptr && sub_->parsed(); }
  // The flag that fills a library field (the library's InputError names fields,
  // util/error.h); empty when this command has no such flag.
  std::string FlagOf(const std::string& field) const {
    const auto it = flag_of_field_.find(field);
    return it == flag_of_field_.end() ? std::string() : it->second;
  }

 protected:
  // `option` fills the library field `field`: errors in it are reported under the flag.
  CLI::Option* Fills(CLI::Option* option, const std::string& field) {
    flag_of_field_[field] = option->get_name();
    return option;
  }
  CLI::App* sub_ = nullptr;

 private:
  std::map<std::string, std::string> flag_of_field_;
};

std::unique_ptr<Command> MakeSimulateCommand();
std::unique_ptr<Command> MakeDemoCommand();
std::unique_ptr<Command> MakeInspectCommand();
std::unique_ptr<Command> MakeEdgesCommand();
std::unique_ptr<Command> MakeEvaluateCommand();
std::unique_ptr<Command> MakeEvaluateEdgesCommand();
std::unique_ptr<Command> MakeCaptureCalibrationCommand();
std::unique_ptr<Command> MakeCalibrateRigCommand();
std::unique_ptr<Command> MakeImportRigCommand();
std::unique_ptr<Command> MakeCalibratePlaneCommand();
std::unique_ptr<Command> MakeRecipeCommand();
std::unique_ptr<Command> MakeStationCommand();
std::unique_ptr<Command> MakeResultsCommand();
std::unique_ptr<Command> MakeReportCommand();
std::unique_ptr<Command> MakeCamerasCommand();
std::unique_ptr<Command> MakeGaugeCommand();

inline std::vector<std::unique_ptr<Command>> MakeCommands() {
  std::vector<std::unique_ptr<Command>> out;
  out.push_back(MakeDemoCommand());
  out.push_back(MakeSimulateCommand());
  out.push_back(MakeInspectCommand());
  out.push_back(MakeEdgesCommand());
  out.push_back(MakeEvaluateCommand());
  out.push_back(MakeEvaluateEdgesCommand());
  out.push_back(MakeCaptureCalibrationCommand());
  out.push_back(MakeCalibrateRigCommand());
  out.push_back(MakeImportRigCommand());
  out.push_back(MakeCalibratePlaneCommand());
  out.push_back(MakeRecipeCommand());
  out.push_back(MakeStationCommand());
  out.push_back(MakeResultsCommand());
  out.push_back(MakeReportCommand());
  out.push_back(MakeCamerasCommand());
  out.push_back(MakeGaugeCommand());
  return out;
}

}  // namespace flatscan
