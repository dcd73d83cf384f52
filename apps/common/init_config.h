// --init-config MODEL, shared by blmd-sim and blmd-ident: a starting config for a model on
// stdout (docs/cli.md §1.1), alone on its command line.
#pragma once

#include <CLI/CLI.hpp>
#include <iostream>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/io/starting_config.h"
#include "blmd/run.h"
#include "blmd/sim/model.h"

namespace blmd::app {

// The models --init-config takes, for its help text.
inline std::string InitConfigModelNames() {
  std::vector<std::string> names;
  for (const Model* model : ModelRegistry()) names.emplace_back(model->name());
  return Join(names, ", ");
}

inline CLI::Option* AddInitConfigFlag(CLI::App& app, std::string* model) {
  return app
      .add_option("--init-config", *model,
                  "print a starting config for MODEL (" + InitConfigModelNames() +
                      ") on stdout and exit; no other flag")
      ->type_name("MODEL");
}

// Prints the starting config; any other flag on the line is bad input.
inline int PrintStartingConfig(const CLI::App& app, const std::string& model) {
  for (const CLI::Option* option : app.get_options()) {
    if (option->count() > 0 && option->get_name() != "--init-config") {
      throw InputError("--init-config prints a config and takes no other flag (got " +
                       option->get_name() + ")");
    }
  }
  std::string text;
  try {
    text = StartingConfigText(model);
  } catch (const InputError& error) {
    throw InputError(std::string("--init-config: ") + error.what());
  }
  std::cout << text;
  return kExitOk;
}

}  // namespace blmd::app
