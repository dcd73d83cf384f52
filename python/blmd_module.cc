// _blmd: the C++ side of the Python package `blmd` (docs/python.md). It builds the requests
// through the library's request layer (app/request.h, as the commands do), runs
// Identify, Sweep or a simulation with the GIL released, and hands back plain values: the
// report as JSON text, traces and surfaces as NumPy arrays. python/blmd/__init__.py turns
// Python arguments into the settings' text forms and the results into the documented API.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "app/request.h"
#include "blmd/app/identify.h"
#include "blmd/app/sweep.h"
#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/run.h"
#include "blmd/version.h"
#include "io/flags.h"

namespace py = pybind11;

namespace {

// A config given as a file path, or as JSON text (a Python dict dumped) labelled `label`.
struct ConfigSource {
  std::string path_or_label;
  std::optional<std::string> text;

  blmd::Config Load() const {
    return text ? blmd::ParseConfig(*text, path_or_label) : blmd::LoadConfig(path_or_label);
  }
  // Recorded in a surface CSV: the SHA-256 of the file, or of the text.
  std::string Sha256() const {
    return blmd::Sha256Hex(text ? *text : blmd::ReadFileText(path_or_label));
  }
};

ConfigSource ToConfigSource(const py::tuple& config) {
  ConfigSource source;
  source.path_or_label = config[0].cast<std::string>();
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

// identify(config, settings) -> (report JSON text, converged, termination)
py::tuple Identify(const py::tuple& config_arg, blmd::IdentSettings settings,
                   const py::list& traces, const py::list& validation) {
  const ConfigSource config = ToConfigSource(config_arg);
  settings.traces = ToTraceSources(traces);
  settings.validation = ToTraceSources(validation);
  std::string report;
  bool converged = false;
  std::string termination;
  {
    py::gil_scoped_release release;
    blmd::IdentRequest request =
        blmd::MakeIdentRequest(config.Load(), config.path_or_label, settings);
    const blmd::IdentOutcome outcome = blmd::Identify(std::move(request));
    report = ReportJsonText(outcome);
    converged = outcome.converged();
    termination = outcome.first_fit.summary.termination;
  }
  return py::make_tuple(report, converged, termination);
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
  const ConfigSource config = ToConfigSource(config_arg);
  settings.trace = ToTraceSource(trace);
  auto signals = std::make_shared<SignalCheck>();
  blmd::SweepRequest request;
  blmd::SweepOutcome outcome;
  bool interrupted = false;
  {
    py::gil_scoped_release release;
    request = blmd::MakeSweepRequest(config.Load(), settings);
    request.config_sha256 = config.Sha256();
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
  const ConfigSource config_source = ToConfigSource(config_arg);
  std::optional<blmd::TraceSource> input_source;
  if (!input.is_none()) input_source = ToTraceSource(input);
  blmd::Trace trace;
  std::string failure;
  {
    py::gil_scoped_release release;
    // blmd-sim's order (apps/blmd-sim/main.cc).
    blmd::Config config = config_source.Load();
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
      failure = blmd::SimulationFailureMessage(config_source.path_or_label, config, status);
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

}  // namespace

PYBIND11_MODULE(_blmd, m) {
  m.doc() = "C++ side of the blmd package (docs/python.md); use blmd, not _blmd";
  m.attr("__version__") = blmd::kVersion;
  py::register_exception<blmd::InputError>(m, "InputError", PyExc_ValueError);

  py::class_<blmd::DialectSettings>(m, "DialectSettings")
      .def(py::init<>())
      .def_readwrite("delimiter", &blmd::DialectSettings::delimiter)
      .def_readwrite("duplicate_time", &blmd::DialectSettings::duplicate_time);
  py::class_<blmd::TraceSettings, blmd::DialectSettings>(m, "TraceSettings")
      .def(py::init<>())
      .def_readwrite("columns", &blmd::TraceSettings::columns)
      .def_readwrite("scales", &blmd::TraceSettings::scales)
      .def_readwrite("derives", &blmd::TraceSettings::derives)
      .def_readwrite("selects", &blmd::TraceSettings::selects)
      .def_readwrite("split", &blmd::TraceSettings::split)
      .def_readwrite("initial_state", &blmd::TraceSettings::initial_state);
  py::class_<blmd::ErrorSettings>(m, "ErrorSettings")
      .def(py::init<>())
      .def_readwrite("kind", &blmd::ErrorSettings::kind)
      .def_readwrite("filter_hz", &blmd::ErrorSettings::filter_hz)
      .def_readwrite("decimate", &blmd::ErrorSettings::decimate);
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
  m.def("surface", &Surface, py::arg("config"), py::arg("settings"), py::arg("trace"));
  m.def("simulate", &Simulate, py::arg("config"), py::arg("effects"), py::arg("noise"),
        py::arg("seed"), py::arg("input"), py::arg("dialect"));
}
