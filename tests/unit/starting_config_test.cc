// The starting config of each model (io/starting_config.h, blmd-sim --init-config): the loader
// accepts it as it is, it holds every parameter of the model at its typical value, its notes
// give each parameter's unit, description, sign rule and default range as the model does, and
// the typical values are those of the bundled config they come from. That the config runs and
// identifies J and B is tests/cli/init_config_cli_test.cc's (through the commands).
#include "blmd/io/starting_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/sim/effects.h"
#include "blmd/sim/model.h"
#include "support/test_support.h"

namespace blmd {
namespace {

using testing::SourcePath;

TEST(StartingConfig, EveryModelLoadsWithEveryParameterAtItsTypicalValue) {
  for (const Model* model : ModelRegistry()) {
    const std::string name(model->name());
    SCOPED_TRACE(name);
    const std::string text = StartingConfigText(name);
    ASSERT_EQ(text.back(), '\n');
    Config config;
    ASSERT_NO_THROW(config = ParseConfig(text, name + ".json"));
    EXPECT_EQ(config.model, model);
    EXPECT_TRUE(config.effects.empty());
    EXPECT_EQ(config.identification.free, (std::vector<std::string>{"J", "B"}));
    EXPECT_NO_THROW(config.experiment.CheckRunnable());
    EXPECT_EQ(config.simulation.dt, model->default_settings().dt);
    const nlohmann::json json = nlohmann::json::parse(text);
    for (const ParamInfo& info : model->parameters()) {
      SCOPED_TRACE(info.name);
      // Every parameter written out, the optional ones too, at a value the model accepts.
      ASSERT_TRUE(json["parameters"].contains(info.name));
      EXPECT_EQ(json["parameters"][info.name].get<double>(), info.typical);
      EXPECT_EQ(config.parameters.Get(info.name), info.typical);
      if (info.positive) {
        EXPECT_GT(info.typical, 0.0);
      }
      if (info.non_negative) {
        EXPECT_GE(info.typical, 0.0);
      }
      EXPECT_GE(info.typical, info.default_lower);
      EXPECT_LE(info.typical, info.default_upper);
      const nlohmann::json& note = json["notes"]["parameters"][info.name];
      EXPECT_EQ(note["unit"], info.unit);
      EXPECT_EQ(note["description"], info.meaning);
      EXPECT_EQ(note["typical"].get<double>(), info.typical);
      EXPECT_EQ(note["sign"], info.positive ? "> 0" : (info.non_negative ? ">= 0" : "any"));
      EXPECT_EQ(note["bounds"], nlohmann::json::array({info.default_lower, info.default_upper}));
      EXPECT_EQ(note.contains("optional"), info.optional);
    }
    EXPECT_EQ(json["parameters"].size(), model->parameters().size());
    // The effects the model can carry, and only those.
    std::size_t applicable = 0;
    for (const EffectInfo& effect : EffectRegistry()) {
      const bool applies =
          std::find(effect.models.begin(), effect.models.end(), name) != effect.models.end();
      applicable += applies ? 1 : 0;
      EXPECT_EQ(json["notes"]["effects"].contains(effect.name), applies) << effect.name;
    }
    EXPECT_EQ(json["notes"]["effects"].size(), applicable);
  }
}

// The typical values are the bundled configs' (the provenance the model sources name).
TEST(StartingConfig, TypicalValuesAreThoseOfTheBundledConfigs) {
  for (const auto& [model, source] :
       {std::pair<std::string, std::string>{"dc_servo", "configs/ganesh-square.json"},
        {"blmd", "configs/blmd-d31x.json"},
        {"rigid_load", "tests/schema/rigid-truth.json"}}) {
    SCOPED_TRACE(model);
    const Config bundled = LoadConfig(SourcePath(source));
    ASSERT_EQ(bundled.model->name(), model);
    for (const ParamInfo& info : bundled.model->parameters()) {
      EXPECT_EQ(info.typical, bundled.parameters.Get(info.name)) << info.name;
    }
  }
}

TEST(StartingConfig, UnknownModelListsTheValidOnes) {
  try {
    StartingConfigText("dc_motor");
    FAIL() << "no error";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(), "unknown model 'dc_motor' (valid: blmd, dc_servo, rigid_load)");
  }
}

// Keys in the order of docs/config.md, so that the printed file reads top-down.
TEST(StartingConfig, KeysInTheOrderOfTheConfigReference) {
  const nlohmann::ordered_json config = StartingConfig(FindModel("dc_servo"));
  std::vector<std::string> keys;
  for (const auto& item : config.items()) keys.push_back(item.key());
  EXPECT_EQ(keys,
            (std::vector<std::string>{"name", "description", "notes", "model", "parameters",
                                      "effects", "simulation", "experiment", "identification"}));
}

}  // namespace
}  // namespace blmd
