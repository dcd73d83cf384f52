// A blmd-ident report (the --report JSON) read back from its file, checked once: what the drift
// guard (blmd-ident --baseline), blmd-tune --from-report and the Python package take from it.
#pragma once

#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "blmd/io/config.h"

namespace blmd {

// One entry of the report's "parameters": the final model's value, whether it was fitted,
// and its 95 % interval when the report gives one.
struct StoredParameter {
  std::string name;
  double value = 0.0;
  bool free = false;
  bool at_bound = false;    // the report says the bound, not the data, set it
  bool has_bounds = false;  // the search bounds the fit used (its "bounds")
  double bound_low = std::numeric_limits<double>::quiet_NaN();
  double bound_high = std::numeric_limits<double>::quiet_NaN();
  bool has_ci95 = false;
  double ci95_low = std::numeric_limits<double>::quiet_NaN();
  double ci95_high = std::numeric_limits<double>::quiet_NaN();
};

class StoredReport {
 public:
  // Reads `path` (at most 256 MiB) as a blmd-ident report: a JSON object with "tool":
  // "blmd-ident", whose "parameters" object has a numeric "value" for each entry, and whose
  // "effects" (when present) is a list of names. `role` names the file in messages
  // ("baseline report", "identification report"). InputError "PATH:LINE:COL: why" otherwise.
  static StoredReport Load(const std::string& path, const std::string& role);
  // The same on a report's JSON text in memory (the Python package's dicts); `path` labels it
  // in messages and is its path().
  static StoredReport Parse(const std::string& text, const std::string& path,
                            const std::string& role);

  const std::string& path() const { return document_.path(); }
  const std::string& sha256() const { return sha256_; }
  // The report's model; empty when it names none.
  const std::string& model() const { return model_; }
  // The final model's effects; has_effects() false when the report has no "effects" list.
  bool has_effects() const { return has_effects_; }
  // Whether the report ran discovery (a "discovery" block): advice then is not --discover.
  bool ran_discovery() const { return document_.root().contains("discovery"); }
  // Where the final model's residual follows the input's past most, Hz (the adequacy check's
  // flagged "u (past)" test: dynamics the model lacks, docs/discovery.md §7b); 0 when it does
  // not, or the report does not say.
  double input_past_frequency_hz() const;
  const std::vector<std::string>& effects() const { return effects_; }
  // In the report's order.
  const std::vector<StoredParameter>& parameters() const { return parameters_; }
  const StoredParameter* FindParameter(const std::string& name) const;
  // A parameter that discovery fixed when it added `effect` (a cogging's periods per
  // revolution: not fitted, so not among "parameters"), from the report's discovery steps;
  // nullptr when the report has none.
  const double* FindFixedParameter(const std::string& effect, const std::string& name) const;
  // The final model's NRMSE on its fit traces (fit.nrmse); NaN when the report gives none.
  double nrmse() const { return nrmse_; }
  // Per observed column: the noise standard deviation the fit used (noise.columns.C.std: the
  // residual's, or --noise-std's), in the column's unit. Empty when the report gives none.
  const std::map<std::string, double>& noise_std() const { return noise_std_; }
  // Per free parameter: the interval's variance over the white-noise variance on this record
  // (method_summary.details.interval.variance_ratio: what the residual's colour cost). Empty
  // when the report gives none (methods other than ceres do not record it).
  const std::map<std::string, double>& variance_ratio() const { return variance_ratio_; }
  // The report's warnings, code and message, in its order.
  const std::vector<std::pair<std::string, std::string>>& warnings() const { return warnings_; }

  // InputError unless the report's model is `model`: "<theirs> "X", <ours> Y" (the report's
  // model first, quoted, or "(none)"), at the report's "model" value.
  void RequireModel(const std::string& model, const std::string& theirs,
                    const std::string& ours) const;
  // InputError naming the file and the line and column of the value at the JSON `pointer`.
  [[noreturn]] void Fail(const std::string& pointer, const std::string& message) const {
    document_.Fail(pointer, message);
  }

 private:
  explicit StoredReport(JsonDocument document) : document_(std::move(document)) {}

  JsonDocument document_;
  std::string sha256_;
  std::string model_;
  bool has_model_ = false;
  bool has_effects_ = false;
  std::vector<std::string> effects_;
  std::vector<StoredParameter> parameters_;
  std::map<std::string, std::map<std::string, double>> step_parameters_;  // effect -> name -> value
  double nrmse_ = std::numeric_limits<double>::quiet_NaN();
  std::map<std::string, double> noise_std_, variance_ratio_;
  std::vector<std::pair<std::string, std::string>> warnings_;
};

// Why the report's final model is not to be acted on (tuned, or designed for), one line
// each: NRMSE >= 1 (no better than predicting the mean), a parameter at its bound, and the
// report's own warnings that say the model is incomplete or the fit failed
// (model_inadequate, unexplained_structure, not_a_fit, not_converged, nrmse_at_least_one,
// decision_unstable), and where its residual follows the input's past (the frequency, which a
// loop's crossover must stay well below). Empty when none applies.
std::vector<std::string> ReportInadequacy(const StoredReport& report);

// The report's final model on `config` (of the same model): the report's effects that the
// config lacks are added with the report's values, and every parameter of the report takes
// its value. InputError at the report's line and column for a report of another model or
// config (an effect the config declares and the report's final model lacks, a parameter
// neither the model nor its effects know) or a value the parameter cannot take. What
// blmd-tune --from-report and blmd-design --from-report start from.
void ApplyFinalModel(const StoredReport& report, Config* config);

}  // namespace blmd
