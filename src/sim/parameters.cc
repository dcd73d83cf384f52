#include "blmd/sim/parameters.h"

#include <stdexcept>

namespace blmd {

bool ParameterSet::Has(std::string_view name) const {
  for (const auto& [key, value] : entries_) {
    if (key == name) return true;
  }
  return false;
}

double ParameterSet::Get(std::string_view name) const {
  for (const auto& [key, value] : entries_) {
    if (key == name) return value;
  }
  throw std::out_of_range("no parameter '" + std::string(name) + "'");
}

double ParameterSet::GetOr(std::string_view name, double fallback) const {
  for (const auto& [key, value] : entries_) {
    if (key == name) return value;
  }
  return fallback;
}

void ParameterSet::Set(const std::string& name, double value) {
  for (auto& [key, v] : entries_) {
    if (key == name) {
      v = value;
      return;
    }
  }
  entries_.emplace_back(name, value);
}

}  // namespace blmd
