#include <iostream>
#include <string>

#include "flatscan/exe/commands.h"
#include "flatscan/station/recipe.h"

namespace flatscan {
namespace {

class RecipeCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("recipe", "Recipes: one YAML file per part type, for `flatscan station`.");
    sub_->require_subcommand(1);
    CLI::App* check = sub_->add_subcommand(
        "check", "Check a recipe (keys, files, pinned hashes, plane calibrated with the rig) and print what a station "
                 "will do with it (exit 0 valid, 2 not).");
    check->footer("Example: flatscan recipe check shield.yml\nThe recipe's keys: docs/station.md, \"Recipes\".");
    check->add_option("recipe", recipe_, "recipe file (YAML)")->required();
  }

  int Run() override {
    std::cout << DescribeRecipe(LoadRecipe(recipe_));
    return 0;
  }

 private:
  std::string recipe_;
};

}  // namespace

std::unique_ptr<Command> MakeRecipeCommand() { return std::make_unique<RecipeCommand>(); }

}  // namespace flatscan
