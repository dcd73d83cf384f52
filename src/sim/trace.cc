#include "blmd/sim/trace.h"

#include <stdexcept>

namespace blmd {

int Trace::Find(std::string_view name) const {
  for (std::size_t k = 0; k < names_.size(); ++k) {
    if (names_[k] == name) return static_cast<int>(k);
  }
  return -1;
}

const std::vector<double>& Trace::Column(std::string_view name) const {
  const int k = Find(name);
  if (k < 0) throw std::out_of_range("trace has no column '" + std::string(name) + "'");
  return columns_[static_cast<std::size_t>(k)];
}

std::vector<double>& Trace::Column(std::string_view name) {
  const int k = Find(name);
  if (k < 0) throw std::out_of_range("trace has no column '" + std::string(name) + "'");
  return columns_[static_cast<std::size_t>(k)];
}

void Trace::Append(std::string name, std::vector<double> values) {
  if (!columns_.empty() && values.size() != rows()) {
    throw std::logic_error("Trace::Append: column '" + name + "' has " +
                           std::to_string(values.size()) + " rows, trace has " +
                           std::to_string(rows()));
  }
  names_.push_back(std::move(name));
  columns_.push_back(std::move(values));
}

std::vector<double>& Trace::Set(const std::string& name, std::vector<double> values) {
  if (!columns_.empty() && values.size() != rows()) {
    throw std::logic_error("Trace::Set: column '" + name + "' has " +
                           std::to_string(values.size()) + " rows, trace has " +
                           std::to_string(rows()));
  }
  const int k = Find(name);
  if (k >= 0) {
    columns_[static_cast<std::size_t>(k)] = std::move(values);
    return columns_[static_cast<std::size_t>(k)];
  }
  names_.push_back(name);
  columns_.push_back(std::move(values));
  return columns_.back();
}

void Trace::Rename(std::string_view from, const std::string& to) {
  const int k = Find(from);
  if (k < 0) throw std::out_of_range("trace has no column '" + std::string(from) + "'");
  names_[static_cast<std::size_t>(k)] = to;
}

}  // namespace blmd
