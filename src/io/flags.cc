#include "io/flags.h"

#include <charconv>
#include <cmath>

#include "blmd/error.h"
#include "blmd/sim/effects.h"

namespace blmd {
double ParseNumber(const std::string& text, const std::string& context) {
  double value = 0.0;
  const char* first = text.data();
  if (!text.empty() && *first == '+') ++first;
  const auto result = std::from_chars(first, text.data() + text.size(), value);
  if (text.empty() || result.ec != std::errc() || result.ptr != text.data() + text.size() ||
      !std::isfinite(value)) {
    throw InputError(context + ": '" + text + "' is not a finite number");
  }
  return value;
}

std::pair<std::string, std::string> ParseTextAssignment(const std::string& text,
                                                        const std::string& flag) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) {
    throw InputError(flag + " '" + text + "': expected NAME=VALUE");
  }
  return {text.substr(0, eq), text.substr(eq + 1)};
}

std::pair<std::string, double> ParseAssignment(const std::string& text, const std::string& flag) {
  const auto [name, value] = ParseTextAssignment(text, flag);
  return {name, ParseNumber(value, flag + " " + name)};
}

namespace {

// The flat parameter name (ParamInfo::name) of `key`, the name inside effect `effect`'s
// object (ParamInfo::config_key: gravity's `phase` is gravity_phase). Keys that are no
// parameter of the effect, and unknown effects, pass unchanged for Config::AddEffect to
// refuse; a flat name that differs from its key is refused here, naming the key.
std::string EffectParameterName(const std::string& effect, const std::string& key) {
  for (const auto& info : EffectRegistry()) {
    if (info.name != effect) continue;
    std::vector<std::string> keys;
    for (const auto& p : info.parameters) keys.push_back(p.config_key());
    for (const auto& p : info.parameters) {
      if (p.config_key() == key) return p.name;
      if (p.name == key) {
        std::string valid;
        for (const auto& k : keys) valid += (valid.empty() ? "" : ", ") + k;
        throw InputError("effect '" + effect + "' has no parameter '" + key + "' (did you mean '" +
                         p.config_key() + "'?); valid: " + valid);
      }
    }
  }
  return key;
}

}  // namespace

std::pair<std::string, ParameterSet> ParseEffectSpec(const std::string& text) {
  const auto colon = text.find(':');
  const std::string name = text.substr(0, colon);
  if (name.empty()) throw InputError("--effect '" + text + "': expected NAME:KEY=VALUE[,...]");
  ParameterSet values;
  if (colon != std::string::npos) {
    std::string rest = text.substr(colon + 1);
    std::size_t start = 0;
    while (start <= rest.size()) {
      const auto comma = rest.find(',', start);
      const std::string item =
          rest.substr(start, comma == std::string::npos ? rest.npos : comma - start);
      const auto [key, value] = ParseAssignment(item, "--effect " + name);
      values.Set(EffectParameterName(name, key), value);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  return {name, values};
}

std::vector<std::string> ParseNameList(const std::string& text, const std::string& flag) {
  std::vector<std::string> names;
  std::size_t start = 0;
  while (true) {
    const auto comma = text.find(',', start);
    std::string item = text.substr(start, comma == std::string::npos ? text.npos : comma - start);
    while (!item.empty() && item.front() == ' ') item.erase(item.begin());
    while (!item.empty() && item.back() == ' ') item.pop_back();
    if (item.empty()) throw InputError(flag + " '" + text + "': empty name in the list");
    names.push_back(item);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return names;
}

}  // namespace blmd
