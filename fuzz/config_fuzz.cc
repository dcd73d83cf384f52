// libFuzzer target for the config loader (blmd::ParseConfig, docs/config.md). Besides "no
// crash, no sanitizer report, no other exception", every input ends as an InputError whose
// message is one printable line starting with the file name, or as a config that keeps the
// loader's promises: a model, finite parameter values the model accepts, a positive dt, a
// run of at most 1e10 steps and 1e8 samples, every free parameter known and starting inside
// its non-empty bounds.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "blmd/error.h"
#include "blmd/io/config.h"

namespace {

[[noreturn]] void Broken(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "config_fuzz: %s %s\n", what, detail.c_str());
  std::abort();
}

void CheckConfig(const blmd::Config& config) {
  if (!config.model) Broken("no model");
  for (const auto& [name, value] : config.parameters.entries()) {
    if (!std::isfinite(value)) Broken("non-finite parameter", name);
  }
  if (!config.model->Validate(config.parameters, config.simulation).empty())
    Broken("invalid parameters");
  if (!(config.simulation.dt > 0.0)) Broken("dt not positive");
  const auto& experiment = config.experiment;
  if (!(experiment.duration > 0.0) || !(experiment.sample_rate > 0.0)) Broken("empty experiment");
  // An experiment that cannot be run keeps its one-line error for blmd-sim (issue 18 item 2);
  // one that can keeps the run-length promises.
  if (!experiment.invalid.empty()) {
    if (experiment.invalid.rfind("/fuzz/config.json", 0) != 0) {
      Broken("experiment message does not start with the file name:", experiment.invalid);
    }
    for (const char c : experiment.invalid) {
      const auto byte = static_cast<unsigned char>(c);
      if (byte < 0x20 || byte == 0x7f)
        Broken("control character in the message:", experiment.invalid);
    }
  } else {
    if (!(experiment.duration / config.simulation.dt <= 1e10)) Broken("too many steps");
    if (!(experiment.duration * experiment.sample_rate <= 1e8)) Broken("too many samples");
  }
  for (const auto& name : config.identification.free) {
    if (!config.parameters.Has(name)) Broken("unknown free parameter", name);
    const auto [lower, upper] = config.Bounds(name);
    if (!(lower < upper)) Broken("empty bounds", name);
    const double start = config.identification.initial.Has(name)
                             ? config.identification.initial.Get(name)
                             : config.parameters.Get(name);
    if (!(start >= lower && start <= upper)) Broken("start outside the bounds", name);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string path = "/fuzz/config.json";  // recorded inputs resolve under /fuzz/
  try {
    CheckConfig(blmd::ParseConfig(text, path));
  } catch (const blmd::InputError& error) {
    const std::string message = error.what();
    // A recorded input's CSV errors name that file, under the config's folder.
    if (message.rfind("/fuzz/", 0) != 0 && message.rfind("/", 0) != 0) {
      Broken("message does not start with the file name:", message);
    }
    for (const char c : message) {
      const auto byte = static_cast<unsigned char>(c);
      if (byte < 0x20 || byte == 0x7f) Broken("control character in the message:", message);
    }
  }
  return 0;
}
