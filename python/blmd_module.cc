// _blmd: the C++ side of the Python package `blmd` (docs/python.md). It builds the requests
// from the commands' settings (IdentSettings, SweepSettings, TuneSettings, DesignSettings:
// app/request.h, app/tune_run.h, app/experiment_design_run.h, as the commands do), with configs,
// reports and traces given as files or in memory, runs Identify, Sweep, a simulation,
// RunTune or RunDesign with the GIL released, and hands back plain values: reports and configs
// as JSON text, traces, surfaces and the identified model's covariance and fit as NumPy
// arrays. python/blmd/__init__.py turns Python arguments into the settings' text forms and the
// results into the documented API.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "../apps/blmd-ident/batch.h"
#include "app/experiment_design_run.h"
#include "app/request.h"
#include "app/tune_run.h"
#include "blmd/app/fleet.h"
#include "blmd/app/identify.h"
#include "blmd/app/sweep.h"
#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/io/starting_config.h"
#include "blmd/report/design_report.h"
#include "blmd/report/export.h"
#include "blmd/report/tune_report.h"
#include "blmd/run.h"
#include "blmd/version.h"
#include "io/flags.h"
#include "report/config_document.h"

namespace py = pybind11;

namespace {

// A config or a report given as a file path, or as JSON text (a Python dict dumped) that the
// path labels.
blmd::JsonSource ToJsonSource(const py::tuple& config) {
  blmd::JsonSource source;
  source.path = config[0].cast<std::string>();
  if (!config[1].is_none()) source.text = config[1].cast<std::string>();
  return source;
}

// A 1-D array of doubles (any sequence of numbers converts); InputError naming the column.
std::vector<double> ToColumn(const std::string& where, const std::string& name,
                             const py::handle& values) {
  // Null (the Python error cleared) when the values do not convert to doubles.
  const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
  if (!array) {
    throw blmd::InputError(where + ": column '" + name + "' is not an array of numbers");
  }
  if (array.ndim() != 1) {
    throw blmd::InputError(where + ": column '" + name + "' has " + std::to_string(array.ndim()) +
                           " dimensions; a column is 1-D");
  }
  return std::vector<double>(array.data(), array.data() + array.size());
}

// Columns in memory as a trace: a Python dict column -> 1-D array, all of one length.
blmd::Trace ToTrace(const std::string& where, const py::dict& columns) {
  blmd::Trace trace;
  std::string first;
  for (const auto& [key, values] : columns) {
    const std::string name = py::str(key);
    std::vector<double> column = ToColumn(where, name, values);
    if (trace.num_columns() > 0 && column.size() != trace.rows()) {
      throw blmd::InputError(where + ": column '" + name + "' has " +
                             std::to_string(column.size()) + " values, column '" + first + "' " +
                             std::to_string(trace.rows()) + "; columns must be of one length");
    }
    if (trace.Has(name)) throw blmd::InputError(where + ": column '" + name + "' given twice");
    if (first.empty()) first = name;
    trace.Append(name, std::move(column));
  }
  return trace;
}

// One trace argument: a path (str) or a (name, dict of columns) pair.
blmd::TraceSource ToTraceSource(const py::handle& item) {
  if (py::isinstance<py::str>(item)) return {item.cast<std::string>(), std::nullopt};
  const auto pair = item.cast<py::tuple>();
  const std::string name = pair[0].cast<std::string>();
  return {name, ToTrace(name, pair[1].cast<py::dict>())};
}

std::vector<blmd::TraceSource> ToTraceSources(const py::list& items) {
  std::vector<blmd::TraceSource> sources;
  for (const auto& item : items) sources.push_back(ToTraceSource(item));
  return sources;
}

py::array_t<double> ToArray(const std::vector<double>& values) {
  py::array_t<double> array(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), array.mutable_data());
  return array;
}

// The one place where an identification's outcome becomes the report's JSON (the --report
// file of blmd-ident). Should IdentOutcome::report become a typed struct, this becomes its
// ToJson.
std::string ReportJsonText(const blmd::IdentOutcome& outcome) {
  return nlohmann::json(outcome.report).dump();
}

// What blmd.identify's result object adds to the report: the final model's free parameters
// (their order: outcome.final_free), their covariance, the model re-simulated on the fit's
// traces, and the config that --write-config writes.
struct FinalModel {
  std::vector<std::string> names;
  std::vector<double> x;
  Eigen::MatrixXd cov;
  std::vector<std::string> columns;  // the observed columns
  // Per trace, per observed column: the simulated values and measured - simulated, at the
  // samples the cost compares (the trace's rows; with the equation error its filtered ones).
  std::vector<std::vector<std::vector<double>>> fitted, residual;
  std::string simulation_failure;  // why a trace could not be simulated ("" when all were)
  std::string config_text;         // blmd-ident --write-config's document
};

// The covariance the report's intervals stand for: diag(std)·corr·diag(std), with std the
// report's per-parameter standard deviation (physical units, after any widening by the
// spread between traces) and corr the report's correlation (that of the HAC sandwich, which
// a positive rescaling per parameter leaves unchanged). Without a correlation matrix only the
// variances are known: the off-diagonal entries are NaN, as is a parameter without interval.
Eigen::MatrixXd ReportCovariance(const blmd::IdentReport& report,
                                 const std::vector<std::string>& names) {
  const blmd::ModelReport& model = report.final_model;
  const auto n = static_cast<Eigen::Index>(names.size());
  std::vector<double> sd(names.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<Eigen::Index> in_correlation(names.size(), -1);
  for (std::size_t j = 0; j < names.size(); ++j) {
    const auto found = model.parameters.find(names[j]);
    if (found != model.parameters.end() && found->second.estimate.has_interval)
      sd[j] = found->second.estimate.std;
    const auto& listed = model.correlation.names;
    const auto at = std::find(listed.begin(), listed.end(), names[j]);
    if (model.correlation.available && at != listed.end())
      in_correlation[j] = static_cast<Eigen::Index>(at - listed.begin());
  }
  Eigen::MatrixXd cov = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index k = 0; k < n; ++k) {
      const auto uj = static_cast<std::size_t>(j), uk = static_cast<std::size_t>(k);
      if (j == k) {
        cov(j, k) = sd[uj] * sd[uj];
      } else if (in_correlation[uj] >= 0 && in_correlation[uk] >= 0) {
        cov(j, k) =
            sd[uj] * model.correlation.correlation(in_correlation[uj], in_correlation[uk]) * sd[uk];
      }
    }
  }
  return cov;
}

FinalModel FinalModelOf(const blmd::IdentOutcome& outcome) {
  FinalModel final_model;
  for (const auto& p : outcome.final_free) {
    final_model.names.push_back(p.name);
    final_model.x.push_back(outcome.final_parameters.Get(p.name));
  }
  final_model.cov = ReportCovariance(outcome.report, final_model.names);
  final_model.config_text = blmd::ModelConfigJson(outcome.final_config, outcome.final_parameters,
                                                  outcome.final_free, outcome.report)
                                .dump();
  if (!outcome.problem) return final_model;
  // The final model on the first problem's traces (the same data; the final problem of
  // discovery is not kept by Identify), simulated by the library, as the cost does.
  const blmd::FitProblem problem(outcome.final_config, outcome.problem->traces(),
                                 outcome.problem->observe(), outcome.final_free);
  final_model.columns = problem.observe();
  for (std::size_t k = 0; k < problem.traces().size(); ++k) {
    blmd::Trace simulated;
    const blmd::SimStatus status = problem.Simulate(k, final_model.x, &simulated);
    std::vector<std::vector<double>> fitted, residual;
    if (!status.ok()) {
      final_model.simulation_failure =
          blmd::SimulationFailureMessage(problem.traces()[k].path, problem.config(), status);
    } else {
      const blmd::Trace& measured = problem.measured(k);
      for (const auto& column : final_model.columns) {
        const std::vector<double>& sim = simulated.Column(column);
        const std::vector<double>& meas = measured.Column(column);
        std::vector<double> difference(meas.size());
        for (std::size_t r = 0; r < meas.size() && r < sim.size(); ++r)
          difference[r] = meas[r] - sim[r];
        fitted.push_back(sim);
        residual.push_back(std::move(difference));
      }
    }
    final_model.fitted.push_back(std::move(fitted));
    final_model.residual.push_back(std::move(residual));
  }
  return final_model;
}

py::array_t<double> ToMatrix(const Eigen::MatrixXd& matrix) {
  py::array_t<double> array(
      {static_cast<py::ssize_t>(matrix.rows()), static_cast<py::ssize_t>(matrix.cols())});
  auto view = array.mutable_unchecked<2>();
  for (Eigen::Index j = 0; j < matrix.rows(); ++j)
    for (Eigen::Index k = 0; k < matrix.cols(); ++k)
      view(static_cast<py::ssize_t>(j), static_cast<py::ssize_t>(k)) = matrix(j, k);
  return array;
}

py::dict FinalModelDict(const FinalModel& final_model) {
  py::dict out;
  out["names"] = final_model.names;
  out["x"] = ToArray(final_model.x);
  out["cov"] = ToMatrix(final_model.cov);
  py::list fitted, residual;
  for (std::size_t k = 0; k < final_model.fitted.size(); ++k) {
    py::dict fitted_k, residual_k;
    for (std::size_t c = 0; c < final_model.fitted[k].size(); ++c) {
      fitted_k[py::str(final_model.columns[c])] = ToArray(final_model.fitted[k][c]);
      residual_k[py::str(final_model.columns[c])] = ToArray(final_model.residual[k][c]);
    }
    fitted.append(fitted_k);
    residual.append(residual_k);
  }
  out["fitted"] = fitted;
  out["residual"] = residual;
  out["simulation_failure"] = final_model.simulation_failure;
  out["config"] = final_model.config_text;
  return out;
}

// identify(config, settings) -> (report JSON text, converged, termination, final model dict)
py::tuple Identify(const py::tuple& config_arg, blmd::IdentSettings settings,
                   const py::list& traces, const py::list& validation) {
  const blmd::JsonSource config = ToJsonSource(config_arg);
  settings.traces = ToTraceSources(traces);
  settings.validation = ToTraceSources(validation);
  std::string report;
  bool converged = false;
  std::string termination;
  FinalModel final_model;
  {
    py::gil_scoped_release release;
    blmd::IdentRequest request =
        blmd::MakeIdentRequest(blmd::LoadConfig(config), config.path, settings);
    const blmd::IdentOutcome outcome = blmd::Identify(std::move(request));
    report = ReportJsonText(outcome);
    converged = outcome.converged();
    termination = outcome.first_fit.summary.termination;
    final_model = FinalModelOf(outcome);
  }
  return py::make_tuple(report, converged, termination, FinalModelDict(final_model));
}

// model_config(config, effects, values) -> the config document with the model's parameters
// at `values` and `effects` added where the config lacks them (JSON text): what
// --write-config writes in "parameters" and "effects" (report/config_document.h), for a
// report given without its result object.
std::string ModelConfig(const py::tuple& config_arg,
                        const std::map<std::string, std::map<std::string, double>>& effects,
                        const std::map<std::string, double>& values) {
  const blmd::JsonSource source = ToJsonSource(config_arg);
  py::gil_scoped_release release;
  blmd::Config config = blmd::LoadConfig(source);
  for (const auto& [name, parameters] : effects) {
    if (std::find(config.effects.begin(), config.effects.end(), name) != config.effects.end())
      continue;
    blmd::ParameterSet effect_values;
    for (const auto& [key, value] : parameters) effect_values.Set(key, value);
    config.AddEffect(name, effect_values);
  }
  blmd::ParameterSet all = config.parameters;
  for (const auto& [name, value] : values) {
    if (!all.Has(name)) {
      throw blmd::InputError("write_config: '" + name + "' is not a parameter of the config's " +
                             std::string(config.model->name()) + " model or its effects");
    }
    all.Set(name, value);
  }
  nlohmann::json doc = blmd::ConfigDocumentOf(config);
  blmd::SetModelValues(config, all, &doc);
  blmd::SanitizeJson(&doc);
  return doc.dump();
}

// tune(config, report, settings) -> (report JSON text, refused, refusal, closed-loop config
// JSON text); `config` and `report` (None: none) are (path or label, text or None) pairs.
py::tuple Tune(const py::tuple& config_arg, const py::object& report_arg,
               const blmd::TuneSettings& settings) {
  std::string report, refusal, config;
  bool refused = false;
  const blmd::JsonSource config_json = ToJsonSource(config_arg);
  std::optional<blmd::JsonSource> report_json;
  if (!report_arg.is_none()) report_json = ToJsonSource(report_arg.cast<py::tuple>());
  {
    py::gil_scoped_release release;
    const blmd::TuneReport tuned =
        blmd::RunTune(config_json, report_json ? &*report_json : nullptr, settings);
    refused = tuned.result.refused;
    refusal = tuned.result.refusal;
    if (!refused) {
      report = nlohmann::json(tuned).dump();
      config = blmd::ClosedLoopConfigJson(tuned).dump();
    }
  }
  return py::make_tuple(report, refused, refusal, config);
}

// design(config, settings, report, trace) -> (report JSON text, ok, reason, config JSON text
// ("" without a design)); `report` None or a (path or label, text or None) pair, `trace` None
// or a path or (label, columns).
py::tuple Design(const py::tuple& config_arg, blmd::DesignSettings settings,
                 const py::object& report_arg, const py::object& trace_arg) {
  std::string report, reason, config_text;
  bool ok = false;
  const blmd::JsonSource config_source = ToJsonSource(config_arg);
  if (!report_arg.is_none()) {
    const blmd::JsonSource report_source = ToJsonSource(report_arg.cast<py::tuple>());
    settings.from_report = report_source.path;
    settings.from_report_text = report_source.text;
  }
  if (!trace_arg.is_none()) {
    blmd::TraceSource trace = ToTraceSource(trace_arg);
    settings.trace_path = trace.path;
    settings.trace_data = std::move(trace.data);
  }
  {
    py::gil_scoped_release release;
    const blmd::Config config = blmd::LoadConfig(config_source);
    const blmd::DesignRequest request = blmd::MakeDesignRequest(config, config_source, settings);
    const blmd::DesignReport designed = blmd::RunDesign(request);
    report = blmd::DesignReportJson(designed).dump();
    ok = designed.ok;
    reason = designed.reason;
    if (ok && !designed.evaluate_trace)
      config_text = blmd::DesignConfigJson(config, designed).dump();
  }
  return py::make_tuple(report, ok, reason, config_text);
}

// Ctrl-C during a sweep: the progress callback checks Python's signals on the thread that
// called (the others only see the flag); a pending KeyboardInterrupt stops the sweep (no
// further points are started) and is raised when it has returned.
struct SweepInterrupted {};
class SignalCheck {
 public:
  SignalCheck() : caller_(std::this_thread::get_id()) {}
  ~SignalCheck() {
    if (type_ || value_ || traceback_) {
      py::gil_scoped_acquire acquire;
      Py_XDECREF(type_);
      Py_XDECREF(value_);
      Py_XDECREF(traceback_);
    }
  }
  void operator()() {
    if (interrupted_.load()) throw SweepInterrupted{};
    if (std::this_thread::get_id() != caller_) return;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_check_ < std::chrono::milliseconds(50)) return;
    last_check_ = now;
    py::gil_scoped_acquire acquire;
    if (PyErr_CheckSignals() != 0) {
      PyErr_Fetch(&type_, &value_, &traceback_);
      interrupted_.store(true);
      throw SweepInterrupted{};
    }
  }
  // With the GIL held: the pending Python exception raised.
  [[noreturn]] void Raise() {
    PyErr_Restore(type_, value_, traceback_);
    type_ = value_ = traceback_ = nullptr;
    throw py::error_already_set();
  }

 private:
  std::thread::id caller_;
  std::chrono::steady_clock::time_point last_check_ = std::chrono::steady_clock::now();
  std::atomic<bool> interrupted_{false};
  PyObject* type_ = nullptr;
  PyObject* value_ = nullptr;
  PyObject* traceback_ = nullptr;
};

// surface(config, settings) -> dict of the sweep's results (assembled by blmd.surface).
py::dict Surface(const py::tuple& config_arg, blmd::SweepSettings settings,
                 const py::handle& trace) {
  const blmd::JsonSource config = ToJsonSource(config_arg);
  settings.trace = ToTraceSource(trace);
  auto signals = std::make_shared<SignalCheck>();
  blmd::SweepRequest request;
  blmd::SweepOutcome outcome;
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    request = blmd::MakeSweepRequest(blmd::LoadConfig(config), settings);
    request.config_sha256 = blmd::Sha256Hex(config.Text());
    request.progress = [signals](std::size_t, std::size_t) { (*signals)(); };
    try {
      outcome = blmd::Sweep(request);
    } catch (const SweepInterrupted&) {
      interrupted = true;
    }
  }
  if (interrupted) signals->Raise();
  const std::size_t count = outcome.points.size(), columns = request.observe.size();
  py::list names, values;
  for (const auto& axis : request.axes) {
    names.append(axis.name);
    std::vector<double> axis_values;
    for (int k = 0; k < axis.count; ++k) axis_values.push_back(axis.Value(k));
    values.append(ToArray(axis_values));
  }
  py::array_t<double> cost(static_cast<py::ssize_t>(count));
  py::array_t<double> mse({static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(columns)});
  auto cost_view = cost.mutable_unchecked<1>();
  auto mse_view = mse.mutable_unchecked<2>();
  for (std::size_t k = 0; k < count; ++k) {
    const blmd::Evaluation& evaluation = outcome.points[k].evaluation;
    const auto index = static_cast<py::ssize_t>(k);
    cost_view(index) = evaluation.ok ? evaluation.cost : std::numeric_limits<double>::infinity();
    for (std::size_t c = 0; c < columns; ++c) {
      mse_view(index, static_cast<py::ssize_t>(c)) =
          evaluation.ok ? evaluation.mse[c] : std::numeric_limits<double>::quiet_NaN();
    }
  }
  py::dict result;
  result["names"] = names;
  result["values"] = values;
  result["log"] = [&] {
    py::list log;
    for (const auto& axis : request.axes) log.append(axis.log_scale);
    return log;
  }();
  result["observe"] = request.observe;
  result["cost"] = cost;
  result["mse"] = mse;
  result["best"] = outcome.best < count ? py::object(py::int_(outcome.best)) : py::none();
  result["minima"] = outcome.minima;
  result["failed"] = outcome.failed;
  result["failure_reasons"] = outcome.failure_reasons;
  result["csv"] = outcome.csv;
  result["trace_sha256"] = outcome.trace_sha256;
  result["config_sha256"] = request.config_sha256;
  result["wall_time_s"] = outcome.wall_time_s;
  return result;
}

// simulate(config, effects, noise, seed, input, dialect) -> (column names, arrays, failure
// message): blmd-sim's --effect, --noise, --seed, --input and its --delimiter and
// --duplicate-time.
py::tuple Simulate(const py::tuple& config_arg, const std::vector<std::string>& effects,
                   const std::vector<std::string>& noise_specs, std::uint64_t seed,
                   const py::handle& input, const blmd::DialectSettings& dialect) {
  const blmd::JsonSource config_source = ToJsonSource(config_arg);
  std::optional<blmd::TraceSource> input_source;
  if (!input.is_none()) input_source = ToTraceSource(input);
  blmd::Trace trace;
  std::string failure;
  {
    py::gil_scoped_release release;
    // blmd-sim's order (apps/blmd-sim/main.cc).
    blmd::Config config = blmd::LoadConfig(config_source);
    for (const auto& spec : effects) {
      const auto [name, values] = blmd::ParseEffectSpec(spec);
      config.AddEffect(name, values);
    }
    std::vector<blmd::NoiseSpec> noise = blmd::ParseNoise(noise_specs);
    blmd::InputSignal recorded;
    if (input_source) {
      const std::string& where = input_source->path;
      if (input_source->data) {
        // Columns in memory: what the CSV reader checks of a --input file.
        const blmd::Trace& data = *input_source->data;
        for (const char* name : {"t", "u"}) {
          if (!data.Has(name)) {
            throw blmd::InputError(where + ": missing required column '" + std::string(name) +
                                   "' (have: " + blmd::Join(data.names(), ",") + ")");
          }
        }
        const auto& t = data.Column("t");
        for (std::size_t k = 0; k < data.rows(); ++k) {
          for (const char* name : {"t", "u", "open"}) {
            if (data.Has(name) && !std::isfinite(data.Column(name)[k])) {
              throw blmd::InputError(where + ": column '" + std::string(name) + "' row " +
                                     std::to_string(k) + " is not a finite number (" +
                                     blmd::DisplayNumber(data.Column(name)[k]) + ")");
            }
          }
          if (k > 0 && !(t[k] > t[k - 1])) {
            throw blmd::InputError(where + ": time 't' must strictly increase (row " +
                                   std::to_string(k) + ": " + blmd::DisplayNumber(t[k]) +
                                   (t[k] == t[k - 1] ? " repeats " : " follows ") +
                                   blmd::DisplayNumber(t[k - 1]) + ")");
          }
        }
        if (data.rows() == 0) throw blmd::InputError(where + ": no rows");
        recorded = blmd::RecordedInput(data, where, config);
      } else {
        recorded = blmd::RecordedInput(blmd::ReadInputTrace(where, dialect), where, config);
      }
    } else {
      config.experiment.CheckRunnable();  // the config's own time base
    }
    const blmd::SimStatus status = input_source ? blmd::RunRecordedInput(config, recorded, &trace)
                                                : blmd::RunExperiment(config, &trace);
    if (!status.ok()) {
      failure = blmd::SimulationFailureMessage(config_source.path, config, status);
    } else {
      blmd::AddNoise(&noise, seed, &trace);
    }
  }
  py::list names, columns;
  if (failure.empty()) {
    for (std::size_t c = 0; c < trace.num_columns(); ++c) {
      names.append(trace.names()[c]);
      columns.append(ToArray(trace.Column(c)));
    }
  }
  return py::make_tuple(names, columns, failure);
}

// ---- blmd.fleet (docs/fleet.md): the rows of a manifest as plain dicts (Dask pickles them
// to its workers), each run by the command's own row runner (apps/blmd-ident/batch.h).

py::dict RowDict(const blmd::FleetRow& row) {
  py::dict d;
  d["line"] = row.line;
  d["id"] = row.id;
  d["drive"] = row.drive;
  d["date"] = row.date;
  d["config"] = row.config;
  d["traces"] = row.traces;
  d["baseline"] = row.baseline;
  d["args"] = row.args;
  d["error"] = row.error;
  return d;
}

blmd::FleetRow RowFromDict(const py::dict& d) {
  blmd::FleetRow row;
  row.line = d["line"].cast<long>();
  row.id = d["id"].cast<std::string>();
  row.drive = d["drive"].cast<std::string>();
  row.date = d["date"].cast<std::string>();
  row.config = d["config"].cast<std::string>();
  row.traces = d["traces"].cast<std::vector<std::string>>();
  row.baseline = d["baseline"].cast<std::string>();
  row.args = d["args"].cast<std::vector<std::string>>();
  row.error = d["error"].cast<std::string>();
  return row;
}

py::list FleetManifest(const std::string& path) {
  py::list rows;
  for (const blmd::FleetRow& row : blmd::ReadFleetManifest(path)) rows.append(RowDict(row));
  return rows;
}

// The flags every row gets, checked as blmd-ident --batch checks its command line.
void FleetCheckArgs(const std::vector<std::string>& args) {
  blmd::app::CheckRowArguments(args, "");
  CLI::App app{"blmd.fleet"};
  blmd::app::IdentFlags flags;
  flags.Add(app, /*batch=*/true);
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);
    blmd::app::RefuseEmptyValues(app, {"--observe", "--free", "--candidates"});
  } catch (const CLI::ParseError& error) {
    throw blmd::InputError(std::string("args: ") + blmd::InputError::OneLine(error.what()));
  }
}

// One row: (its line of the table as JSON text, whether it was taken from the folder).
py::tuple FleetRunRow(const py::dict& row_dict, const std::vector<std::string>& common,
                      const std::string& out_dir, const std::string& baseline_dir, double alpha,
                      int threads) {
  const blmd::FleetRow row = RowFromDict(row_dict);
  blmd::app::BatchOptions options;
  options.out_dir = out_dir;
  options.baseline_dir = baseline_dir;
  options.rule.alpha = alpha;
  options.row_threads = std::max(1, threads);
  bool reused = false;
  std::string line;
  {
    py::gil_scoped_release release;
    line = blmd::app::RunFleetRow(row, common, options, &reused).dump();
  }
  return py::make_tuple(line, reused);
}

// The table, its JSON lines and fleet.html from the rows' lines (JSON text; "" for a row that
// did not run: an error row, with the manifest's message when it has one).
py::dict FleetFinish(const py::list& row_dicts, const std::vector<std::string>& lines,
                     const std::string& out_dir, const std::string& baseline_dir,
                     bool store_baselines) {
  std::vector<blmd::FleetRow> rows;
  std::vector<nlohmann::json> parsed;
  for (std::size_t k = 0; k < row_dicts.size(); ++k) {
    rows.push_back(RowFromDict(row_dicts[k].cast<py::dict>()));
    const blmd::FleetRow& row = rows.back();
    if (!row.error.empty()) {
      parsed.push_back(blmd::FleetErrorResult(row, row.error));
    } else if (k < lines.size() && !lines[k].empty()) {
      parsed.push_back(nlohmann::json::parse(lines[k]));
    } else {
      parsed.push_back(
          blmd::FleetErrorResult(row, "did not finish (run the batch again to resume)"));
    }
  }
  const blmd::FleetSummary s =
      blmd::WriteFleetOutputs(rows, std::move(parsed), out_dir, baseline_dir, store_baselines);
  py::dict d;
  d["rows"] = s.rows;
  d["ok"] = s.ok;
  d["drift"] = s.drift;
  d["error"] = s.error;
  d["baselines_stored"] = s.baselines_stored;
  d["exit_code"] = s.ExitCode();
  return d;
}

}  // namespace

PYBIND11_MODULE(_blmd, m) {
  m.doc() = "C++ side of the blmd package (docs/python.md); use blmd, not _blmd";
  m.attr("__version__") = blmd::kVersion;
  py::register_exception<blmd::InputError>(m, "InputError", PyExc_ValueError);

  py::class_<blmd::DialectSettings>(m, "DialectSettings")
      .def(py::init<>())
      .def_readwrite("delimiter", &blmd::DialectSettings::delimiter)
      .def_readwrite("duplicate_time", &blmd::DialectSettings::duplicate_time)
      .def_readwrite("no_header", &blmd::DialectSettings::no_header)
      .def_readwrite("sample_rate", &blmd::DialectSettings::sample_rate);
  py::class_<blmd::TraceSettings, blmd::DialectSettings>(m, "TraceSettings")
      .def(py::init<>())
      .def_readwrite("columns", &blmd::TraceSettings::columns)
      .def_readwrite("scales", &blmd::TraceSettings::scales)
      .def_readwrite("derives", &blmd::TraceSettings::derives)
      .def_readwrite("selects", &blmd::TraceSettings::selects)
      .def_readwrite("split", &blmd::TraceSettings::split)
      .def_readwrite("initial_state", &blmd::TraceSettings::initial_state)
      .def_readwrite("resample", &blmd::TraceSettings::resample);
  py::class_<blmd::ErrorSettings>(m, "ErrorSettings")
      .def(py::init<>())
      .def_readwrite("kind", &blmd::ErrorSettings::kind)
      .def_readwrite("filter_hz", &blmd::ErrorSettings::filter_hz)
      .def_readwrite("decimate", &blmd::ErrorSettings::decimate)
      .def_readwrite("simulate_from", &blmd::ErrorSettings::simulate_from);
  py::class_<blmd::IdentSettings>(m, "IdentSettings")
      .def(py::init<>())
      .def_readwrite("method", &blmd::IdentSettings::method)
      .def_readwrite("baseline", &blmd::IdentSettings::baseline)
      .def_readwrite("observe", &blmd::IdentSettings::observe)
      .def_readwrite("free", &blmd::IdentSettings::free)
      .def_readwrite("candidates", &blmd::IdentSettings::candidates)
      .def_readwrite("initials", &blmd::IdentSettings::initials)
      .def_readwrite("method_options", &blmd::IdentSettings::method_options)
      .def_readwrite("seed", &blmd::IdentSettings::seed)
      .def_readwrite("threads", &blmd::IdentSettings::threads)
      .def_readwrite("max_evaluations", &blmd::IdentSettings::max_evaluations)
      .def_readwrite("verbose", &blmd::IdentSettings::verbose)
      .def_readwrite("discover", &blmd::IdentSettings::discover)
      .def_readwrite("bic_margin", &blmd::IdentSettings::bic_margin)
      .def_readwrite("min_share", &blmd::IdentSettings::min_share)
      .def_readwrite("max_effects", &blmd::IdentSettings::max_effects)
      .def_readwrite("error", &blmd::IdentSettings::error)
      .def_readwrite("preparation", &blmd::IdentSettings::preparation);
  py::class_<blmd::SweepSettings>(m, "SweepSettings")
      .def(py::init<>())
      .def_readwrite("grids", &blmd::SweepSettings::grids)
      .def_readwrite("observe", &blmd::SweepSettings::observe)
      .def_readwrite("shard", &blmd::SweepSettings::shard)
      .def_readwrite("force", &blmd::SweepSettings::force)
      .def_readwrite("threads", &blmd::SweepSettings::threads)
      .def_readwrite("error", &blmd::SweepSettings::error)
      .def_readwrite("preparation", &blmd::SweepSettings::preparation);

  m.def("identify", &Identify, py::arg("config"), py::arg("settings"), py::arg("traces"),
        py::arg("validation"));
  m.def("model_config", &ModelConfig, py::arg("config"), py::arg("effects"), py::arg("values"));
  m.def(
      "starting_config", [](const std::string& model) { return blmd::StartingConfigText(model); },
      py::arg("model"));
  py::class_<blmd::TuneSettings>(m, "TuneSettings")
      .def(py::init<>())
      .def_readwrite("loop", &blmd::TuneSettings::loop)
      .def_readwrite("crossover_hz", &blmd::TuneSettings::crossover_hz)
      .def_readwrite("phase_margin_deg", &blmd::TuneSettings::phase_margin_deg)
      .def_readwrite("limits", &blmd::TuneSettings::limits)
      .def_readwrite("step", &blmd::TuneSettings::step)
      .def_readwrite("duration", &blmd::TuneSettings::duration)
      .def_readwrite("integral_ratio", &blmd::TuneSettings::integral_ratio)
      .def_readwrite("filter_ratio", &blmd::TuneSettings::filter_ratio)
      .def_readwrite("threads", &blmd::TuneSettings::threads)
      .def_readwrite("sample_rate_hz", &blmd::TuneSettings::sample_rate_hz)
      .def_readwrite("current_bandwidth_hz", &blmd::TuneSettings::current_bandwidth_hz)
      .def_readwrite("position_crossover_hz", &blmd::TuneSettings::position_crossover_hz)
      .def_readwrite("delay_samples", &blmd::TuneSettings::delay_samples)
      .def_readwrite("notch", &blmd::TuneSettings::notch);
  m.def("tune", &Tune, py::arg("config"), py::arg("report"), py::arg("settings"));
  py::class_<blmd::DesignSettings>(m, "DesignSettings")
      .def(py::init<>())
      .def_readwrite("duration", &blmd::DesignSettings::duration)
      .def_readwrite("limits", &blmd::DesignSettings::limits)
      .def_readwrite("noises", &blmd::DesignSettings::noises)
      .def_readwrite("family", &blmd::DesignSettings::family)
      .def_readwrite("target", &blmd::DesignSettings::target)
      .def_readwrite("trace", &blmd::DesignSettings::trace)
      .def_readwrite("threads", &blmd::DesignSettings::threads);
  m.def("design", &Design, py::arg("config"), py::arg("settings"), py::arg("report"),
        py::arg("trace"));
  m.def("surface", &Surface, py::arg("config"), py::arg("settings"), py::arg("trace"));
  m.def("simulate", &Simulate, py::arg("config"), py::arg("effects"), py::arg("noise"),
        py::arg("seed"), py::arg("input"), py::arg("dialect"));
  m.def("fleet_manifest", &FleetManifest, py::arg("path"));
  m.def("fleet_check_args", &FleetCheckArgs, py::arg("args"));
  m.def("fleet_prepare", &blmd::PrepareFleetFolder, py::arg("out"));
  m.def("fleet_run_row", &FleetRunRow, py::arg("row"), py::arg("common"), py::arg("out"),
        py::arg("baseline_dir"), py::arg("alpha"), py::arg("threads"));
  m.def("fleet_finish", &FleetFinish, py::arg("rows"), py::arg("lines"), py::arg("out"),
        py::arg("baseline_dir"), py::arg("store_baselines"));
}
