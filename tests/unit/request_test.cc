// The requests built from the flags' text forms (app/request.h), which the commands and
// the Python package share, and PrepareFitTraces (ident/fit/trace_input.h) for traces in memory.
// Oracles: the config's own values for every default; a trace in memory prepares exactly
// (bit for bit) as the CSV file it came from; each bad value its one message.
#include "app/request.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/ident/fit/trace_input.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

const std::string kNoload = "configs/ganesh-noload.json";
const std::string kNoloadStep = "testdata/ganesh-noload-step.csv";

IdentSettings OneTrace() {
  IdentSettings settings;
  settings.traces.push_back({SourcePath(kNoloadStep), std::nullopt});
  return settings;
}

std::string InputMessage(const std::function<void()>& call) {
  try {
    call();
  } catch (const InputError& error) {
    return error.what();
  }
  return "(no InputError)";
}

TEST(IdentRequest, DefaultsAreTheConfigs) {
  const Config config = LoadConfig(SourcePath(kNoload));
  const IdentRequest request = MakeIdentRequest(config, kNoload, OneTrace());
  EXPECT_EQ(request.config_path, kNoload);
  EXPECT_EQ(request.observe, config.identification.observe);
  EXPECT_EQ(request.method, config.identification.method.empty() ? std::string("ceres")
                                                                 : config.identification.method);
  ASSERT_EQ(request.free.size(), config.identification.free.size());
  for (std::size_t k = 0; k < request.free.size(); ++k) {
    EXPECT_EQ(request.free[k].name, config.identification.free[k]);
    EXPECT_EQ(request.free[k].initial,
              config.identification.initial.Get(config.identification.free[k]));
  }
  ASSERT_EQ(request.traces.size(), 1u);
  EXPECT_EQ(request.traces[0].trace.rows(), 10001u);
  EXPECT_FALSE(request.discover);
  EXPECT_EQ(request.options.seed, 1u);
}

TEST(IdentRequest, SettingsOverrideAndMethodOptionsFollowTheMethod) {
  Config config = LoadConfig(SourcePath(kNoload));
  config.identification.method = "powell";
  config.identification.options = {{"algorithm", "praxis"}};
  IdentSettings settings = OneTrace();
  settings.observe = "w";
  settings.free = "J";
  settings.initials = {"J=3e-05"};
  // The config's options go with its own method only.
  EXPECT_EQ(MakeIdentRequest(config, kNoload, settings).options.method_options,
            nlohmann::json({{"algorithm", "praxis"}}));
  settings.method = "ceres";
  settings.method_options = {"max_iterations=20"};
  const IdentRequest request = MakeIdentRequest(config, kNoload, settings);
  EXPECT_EQ(request.method, "ceres");
  EXPECT_EQ(request.options.method_options, nlohmann::json({{"max_iterations", "20"}}));
  EXPECT_EQ(request.observe, std::vector<std::string>{"w"});
  ASSERT_EQ(request.free.size(), 1u);
  EXPECT_EQ(request.free[0].name, "J");
  EXPECT_EQ(request.free[0].initial, 3e-5);
}

TEST(IdentRequest, BadSettingsHaveTheCommandsMessages) {
  const Config config = LoadConfig(SourcePath(kNoload));
  IdentSettings empty_observe = OneTrace();
  empty_observe.observe = "";
  EXPECT_EQ(InputMessage([&] { MakeIdentRequest(config, kNoload, empty_observe); }),
            "--observe: empty (valid: i, w, theta)");
  IdentSettings bad_observe = OneTrace();
  bad_observe.observe = "q";
  EXPECT_EQ(InputMessage([&] { MakeIdentRequest(config, kNoload, bad_observe); }),
            "--observe: 'q' is not an output of model dc_servo (valid: i,w,theta)");
  IdentSettings not_free = OneTrace();
  not_free.initials = {"R=10"};
  EXPECT_EQ(InputMessage([&] { MakeIdentRequest(config, kNoload, not_free); }),
            "--initial R: 'R' is not a free parameter, so it has no start value (free: J, B; "
            "free it with --free)");
}

TEST(SweepRequest, ObserveMessagesListTheOutputsAsBlmdSurfaceDoes) {
  SweepSettings settings;
  settings.trace = {SourcePath(kNoloadStep), std::nullopt};
  settings.grids = {"J=1e-5:5e-5:3"};
  settings.observe = "q";
  const Config config = LoadConfig(SourcePath(kNoload));
  EXPECT_EQ(InputMessage([&] { MakeSweepRequest(config, settings); }),
            "--observe: 'q' is not an output of model dc_servo (valid: i, w, theta)");
  settings.observe = std::nullopt;
  const SweepRequest request = MakeSweepRequest(config, settings);
  ASSERT_EQ(request.axes.size(), 1u);
  EXPECT_EQ(request.axes[0].Spec(), "J=1e-05:5e-05:3");
  EXPECT_EQ(request.observe, config.identification.observe);
  settings.grids = {"J=1e-5:5e-5:2000", "B=1e-5:1:2000"};
  EXPECT_NE(InputMessage([&] {
              MakeSweepRequest(config, settings);
            }).find("is more than the cap of 1000000 points"),
            std::string::npos);
  settings.force = true;
  settings.grids = {"J=1e-5:5e-5:3", "J=1e-5:5e-5:3"};
  EXPECT_EQ(InputMessage([&] { MakeSweepRequest(config, settings); }), "--grid: 'J' given twice");
}

TEST(PrepareFitTraces, InMemoryEqualsTheFileBitForBit) {
  const std::string path = SourcePath(kNoloadStep);
  TraceInputOptions options;
  options.required = {"i", "w"};
  options.scales["w"] = 0.5;
  const InitialState initial;
  const std::vector<FitTrace> from_file = LoadFitTraces(path, options, initial);
  Trace data = ReadTraceCsv(path);
  data.comments.clear();
  const std::vector<FitTrace> in_memory = PrepareFitTraces(data, "traces[0]", "", options, initial);
  ASSERT_EQ(from_file.size(), 1u);
  ASSERT_EQ(in_memory.size(), 1u);
  EXPECT_EQ(in_memory[0].path, "traces[0]");
  EXPECT_EQ(in_memory[0].sha256, "");
  EXPECT_EQ(in_memory[0].trace.names(), from_file[0].trace.names());
  for (const auto& name : from_file[0].trace.names()) {
    EXPECT_EQ(in_memory[0].trace.Column(name), from_file[0].trace.Column(name)) << name;
  }
  EXPECT_EQ(in_memory[0].input.values, from_file[0].input.values);
}

TEST(PrepareFitTraces, ColumnsTheFitReadsMustBeFinite) {
  Trace data = ReadTraceCsv(SourcePath(kNoloadStep));
  data.comments.clear();
  TraceInputOptions options;
  options.required = {"i", "w"};
  data.Column("w")[10] = std::nan("");
  EXPECT_EQ(InputMessage([&] { PrepareFitTraces(data, "traces[0]", "", options, {}); }),
            "traces[0]:12:4: column 'w' is not a finite number (nan)");
  options.required = {"i"};  // w unused: left as it is
  EXPECT_EQ(PrepareFitTraces(data, "traces[0]", "", options, {}).size(), 1u);
  data.Column("t")[5] = data.Column("t")[4];
  // A repeated stamp names --duplicate-time (which arrays take too, as files do: before,
  // the message had no hint and the flag did not apply to a trace in memory).
  EXPECT_EQ(InputMessage([&] { PrepareFitTraces(data, "traces[0]", "", options, {}); }),
            "traces[0]:7:1: time 't' must strictly increase (0.0004 repeats 0.0004 of line 6); "
            "for several rows logged at one instant use --duplicate-time first|mean");
  options.duplicate_time = DuplicateTime::kFirst;
  const std::vector<FitTrace> merged = PrepareFitTraces(data, "traces[0]", "", options, {});
  ASSERT_EQ(merged.size(), 1u);
  EXPECT_EQ(merged[0].trace.rows(), data.rows() - 1);
  EXPECT_EQ(merged[0].trace.Column("u")[5], data.Column("u")[6]);
}

TEST(Noise, ParsedAsBlmdSimParsesIt) {
  const std::vector<NoiseSpec> noise = ParseNoise({"i=1%", "w=0.5"});
  ASSERT_EQ(noise.size(), 2u);
  EXPECT_TRUE(noise[0].relative);
  EXPECT_EQ(noise[0].sigma, 0.01);
  EXPECT_FALSE(noise[1].relative);
  EXPECT_EQ(noise[1].sigma, 0.5);
  EXPECT_EQ(InputMessage([] { ParseNoise({"t=1"}); }),
            "--noise t: 't' takes no noise (time must increase); noise an output column");
}

}  // namespace
}  // namespace blmd::testing
