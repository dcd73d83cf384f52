// A trace: named columns of equal length, the first of which is usually time `t`.
// The standard columns and their SI units are listed in docs/trace-format.md.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace blmd {

class Trace {
 public:
  Trace() = default;

  std::size_t rows() const { return columns_.empty() ? 0 : columns_.front().size(); }
  std::size_t num_columns() const { return names_.size(); }
  const std::vector<std::string>& names() const { return names_; }

  // Index of a column, or -1 when absent.
  int Find(std::string_view name) const;
  bool Has(std::string_view name) const { return Find(name) >= 0; }

  // Column by name; throws std::out_of_range naming the column when absent.
  const std::vector<double>& Column(std::string_view name) const;
  std::vector<double>& Column(std::string_view name);
  const std::vector<double>& Column(std::size_t index) const { return columns_[index]; }
  std::vector<double>& Column(std::size_t index) { return columns_[index]; }

  // Adds (or replaces) a column; its length must equal rows() unless the trace is empty.
  std::vector<double>& Set(const std::string& name, std::vector<double> values);
  // Adds a column the caller knows is not there yet (no search: a reader adding 200 000
  // columns stays linear); same length rule as Set.
  void Append(std::string name, std::vector<double> values);
  void Rename(std::string_view from, const std::string& to);

  // Free text lines written as "# ..." before the header.
  std::vector<std::string> comments;

 private:
  std::vector<std::string> names_;
  std::vector<std::vector<double>> columns_;
};

}  // namespace blmd
