// Bash completion of the commands (completions/blmd.bash, docs/cli.md "Completion"):
//  - its lists are the commands' own: the flags of each command's --help (and of blmd-surface
//    merge and plot), the model, effect and optimiser registries, the models' output columns;
//  - real bash, given COMP_WORDS and COMP_CWORD as readline sets them, offers exactly the
//    expected candidates: flags, file names (configs: *.json and folders), optimisers,
//    effects (one, or a comma list), models, columns, the choices of a flag, subcommands.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/ident/optimizers/optimizer.h"
#include "blmd/sim/effects.h"
#include "blmd/sim/model.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::BinPath;
using testing::CommandResult;
using testing::SourcePath;
using testing::TempDir;

using Words = std::vector<std::string>;

std::string Quoted(const std::string& word) {  // one word for /bin/sh
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

Words Split(const std::string& text) {
  Words words;
  std::istringstream in(text);
  for (std::string word; in >> word;) words.push_back(word);
  std::sort(words.begin(), words.end());
  return words;
}

// The value of a variable the completion script defines, as sorted words.
Words ScriptList(const std::string& variable) {
  const CommandResult result =
      testing::Run("bash -c " + Quoted("source " + SourcePath("completions/blmd.bash") +
                                       " && printf '%s' \"$" + variable + "\""));
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  return Split(result.out);
}

// The long flags of a --help text (its "Options:" lines, before the footer), sorted.
Words HelpFlags(const std::string& help) {
  std::set<std::string> flags;
  std::istringstream in(help.substr(0, help.find("\nExit status:")));
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("  -", 0) != 0) continue;
    std::istringstream names(line.substr(2, line.find(' ', 2) - 2));
    for (std::string name; std::getline(names, name, ',');)
      if (name.rfind("--", 0) == 0) flags.insert(name);
  }
  return Words(flags.begin(), flags.end());
}

TEST(Completion, ListsAreTheCommandsOwn) {
  for (const auto& [variable, arguments] :
       {std::pair<std::string, std::string>{"_blmd_ident_flags", "blmd-ident --help"},
        {"_blmd_sim_flags", "blmd-sim --help"},
        {"_blmd_surface_flags", "blmd-surface --help"},
        {"_blmd_tune_flags", "blmd-tune --help"},
        {"_blmd_design_flags", "blmd-design --help"},
        {"_blmd_export_flags", "blmd-export --help"},
        {"_blmd_track_flags", "blmd-track --help"},
        {"_blmd_surface_merge_flags", "blmd-surface merge --help"},
        {"_blmd_surface_plot_flags", "blmd-surface plot --help"}}) {
    SCOPED_TRACE(arguments);
    const CommandResult help = testing::Run(BinPath("") + arguments);
    ASSERT_EQ(help.exit_code, 0) << help.err;
    const Words flags = HelpFlags(help.out);
    EXPECT_GE(flags.size(), 2u);
    EXPECT_EQ(ScriptList(variable), flags);
  }
  Words models, effects, methods;
  std::set<std::string> columns = {"u"};
  for (const Model* model : ModelRegistry()) {
    models.emplace_back(model->name());
    for (const std::string& column : model->outputs()) columns.insert(column);
  }
  for (const EffectInfo& effect : EffectRegistry()) effects.push_back(effect.name);
  for (const Optimizer* optimizer : OptimizerRegistry()) methods.emplace_back(optimizer->name());
  for (Words* list : {&models, &effects, &methods}) std::sort(list->begin(), list->end());
  EXPECT_EQ(ScriptList("_blmd_models"), models);
  EXPECT_EQ(ScriptList("_blmd_effects"), effects);
  EXPECT_EQ(ScriptList("_blmd_methods"), methods);
  EXPECT_EQ(ScriptList("_blmd_columns"), Words(columns.begin(), columns.end()));
}

// What bash offers for the command line `words`, the last one being completed (sorted).
class Completer {
 public:
  Completer() {
    dir_.Write("a.json", "{}");
    dir_.Write("b.csv", "t,u\n");
    dir_.Write("notes.txt", "");
    std::filesystem::create_directory(dir_.File("sub"));
    driver_ = driver_dir_.Write("driver.sh",
                                "source \"$1\"; shift\n"
                                "COMP_WORDS=(\"$@\"); COMP_CWORD=$((${#COMP_WORDS[@]} - 1))\n"
                                "\"_blmd_${1#blmd-}\"\n"
                                "printf '%s\\n' \"${COMPREPLY[@]}\" | LC_ALL=C sort\n");
  }
  Words Complete(const Words& words) const {
    std::string line = "cd " + dir_.path() + " && bash " + driver_ + " " +
                       Quoted(SourcePath("completions/blmd.bash"));
    for (const std::string& word : words) line += " " + Quoted(word);
    const CommandResult result = testing::Run(line);
    EXPECT_EQ(result.exit_code, 0) << result.err;
    EXPECT_EQ(result.err, "");
    Words candidates;
    std::istringstream in(result.out);
    for (std::string candidate; std::getline(in, candidate);)
      if (!candidate.empty()) candidates.push_back(candidate);
    return candidates;
  }

 private:
  TempDir dir_;         // the files to complete
  TempDir driver_dir_;  // the script that completes, kept out of them
  std::string driver_;
};

TEST(Completion, RealBashOffersExactlyTheseCandidates) {
  const Completer bash;
  const struct {
    Words words;
    Words expected;
  } cases[] = {
      // Flags.
      {{"blmd-ident", "--met"}, {"--method"}},
      {{"blmd-ident", "--fail-on"}, {"--fail-on-warning"}},
      {{"blmd-ident", "--config", "a.json", "--tr"}, {"--trace"}},
      {{"blmd-sim", "--in"}, {"--init-config", "--input"}},
      {{"blmd-surface", "--sh"}, {"--shard"}},
      // Files: a config is JSON (or in a folder), a trace any file.
      {{"blmd-ident", "--config", ""}, {"a.json", "sub"}},
      {{"blmd-ident", "--report", ""}, {"a.json", "sub"}},
      {{"blmd-ident", "--trace", ""}, {"a.json", "b.csv", "notes.txt", "sub"}},
      {{"blmd-ident", "--trace", "b"}, {"b.csv"}},
      {{"blmd-sim", "--input", "n"}, {"notes.txt"}},
      {{"blmd-surface", "--config", "a"}, {"a.json"}},
      // --flag=value, split at '=' by readline.
      {{"blmd-ident", "--config", "=", ""}, {"a.json", "sub"}},
      {{"blmd-ident", "--method", "=", "c"}, {"ceres", "classic"}},
      // Names from the registries.
      {{"blmd-ident", "--method", ""}, {"ceres", "classic", "fsd", "powell"}},
      {{"blmd-ident", "--method", "p"}, {"powell"}},
      {{"blmd-sim", "--init-config", ""}, {"blmd", "dc_servo", "rigid_load"}},
      {{"blmd-sim", "--init-config", "r"}, {"rigid_load"}},
      {{"blmd-sim", "--effect", "co"}, {"cogging:", "coulomb_friction:"}},
      {{"blmd-sim", "--effect", "s"}, {"spring:", "stribeck:"}},
      {{"blmd-ident", "--candidates", "s"}, {"spring", "stribeck"}},
      {{"blmd-ident", "--candidates", "coulomb_friction,lo"}, {"coulomb_friction,load_torque"}},
      {{"blmd-ident", "--candidates", "coulomb_friction,c"},
       {"coulomb_friction,cogging", "coulomb_friction,current_offset"}},
      // Columns and choices.
      {{"blmd-ident", "--observe", "i,t"}, {"i,theta"}},
      {{"blmd-sim", "--noise", "w"}, {"w="}},
      {{"blmd-ident", "--derive", ""}, {"w=theta"}},
      {{"blmd-surface", "--error", ""}, {"equation", "output"}},
      {{"blmd-ident", "--initial-state", ""}, {"config", "trace"}},
      {{"blmd-sim", "--duplicate-time", "m"}, {"mean"}},
      {{"blmd-surface", "--delimiter", ""}, {",", ";", "tab"}},
      {{"blmd-ident", "--resample", ""}, {"auto"}},
      {{"blmd-design", "--resample", "0.00"}, {}},  // a step of the user's own
      // A value of the user's own: nothing offered.
      {{"blmd-ident", "--seed", ""}, {}},
      {{"blmd-surface", "--grid", "J"}, {}},
      // blmd-surface's subcommands, their flags and files.
      {{"blmd-surface", "m"}, {"merge"}},
      {{"blmd-surface", "p"}, {"plot"}},
      {{"blmd-surface", "merge", ""}, {"b.csv", "sub"}},
      {{"blmd-surface", "merge", "b.csv", "--"}, {"--help", "--out"}},
      {{"blmd-surface", "plot", "b.csv", "--"}, {"--help", "--quiet", "--svg", "--title"}},
      // blmd-tune: its flags, the input report, the loop, the limits.
      {{"blmd-tune", "--fr"}, {"--from-report"}},
      {{"blmd-tune", "--from-report", ""}, {"a.json", "sub"}},
      {{"blmd-tune", "--loop", ""}, {"position", "speed"}},
      {{"blmd-tune", "--limit", ""}, {"i=", "u="}},
      {{"blmd-tune", "--crossover", ""}, {}},
      // blmd-design: its flags, families, limits, files.
      {{"blmd-design", "--fa"}, {"--fail-on-warning", "--family"}},
      {{"blmd-design", "--family", ""}, {"all", "chirp", "prbs", "square", "steps"}},
      {{"blmd-design", "--limit", "t"}, {"theta="}},
      {{"blmd-design", "--write-input", "b"}, {"b.csv"}},
      {{"blmd-design", "--write-config", ""}, {"a.json", "sub"}},
      {{"blmd-design", "--duration", ""}, {}},
  };
  for (const auto& [words, expected] : cases) {
    std::string line;
    for (const std::string& word : words) line += "'" + word + "' ";
    SCOPED_TRACE(line);
    EXPECT_EQ(bash.Complete(words), expected);
  }
}

}  // namespace
}  // namespace blmd
