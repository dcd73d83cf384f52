#include "blmd/report/export.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/io/files.h"
#include "blmd/sim/effects.h"
#include "blmd/version.h"
#include "report/config_document.h"

namespace blmd {
namespace {

using nlohmann::json;

json Matrix(const Eigen::MatrixXd& m) {
  json rows = json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    json row = json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    rows.push_back(row);
  }
  return rows;
}

// Round-trip exact text of a double for a script (%.17g).
std::string Exact(double v) { return FormatExact17(v); }

std::string MatlabMatrix(const Eigen::MatrixXd& m) {
  std::string out = "[";
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    if (r) out += "; ";
    for (Eigen::Index c = 0; c < m.cols(); ++c) out += (c ? ", " : "") + Exact(m(r, c));
  }
  return out + "]";
}

std::string MatlabRow(const std::vector<double>& v) {
  std::string out = "[";
  for (std::size_t k = 0; k < v.size(); ++k) out += (k ? ", " : "") + Exact(v[k]);
  return out + "]";
}

std::string MatlabNames(const std::vector<std::string>& names) {
  std::string out = "{";
  for (std::size_t k = 0; k < names.size(); ++k) out += (k ? ", '" : "'") + names[k] + "'";
  return out + "}";
}

// The 95 % half-width of a reported interval, NaN when there is none.

}  // namespace

json LinearModelJson(const LinearModel& model) {
  json out;
  out["available"] = model.available;
  if (!model.available) {
    out["reason"] = model.reason;
    return out;
  }
  out["input"] = model.input;
  out["assumption"] = model.assumption;
  out["states"] = model.states;
  out["outputs"] = model.outputs;
  out["state_space"] = {{"A", Matrix(model.A)},
                        {"B", Matrix(model.B)},
                        {"C", Matrix(model.C)},
                        {"D", Matrix(model.D)}};
  json functions = json::object();
  for (const auto& tf : TransferFunctions(model)) {
    functions[tf.output] = {{"numerator", tf.numerator}, {"denominator", tf.denominator}};
  }
  out["transfer_functions"] = functions;
  return out;
}

json ModelConfigJson(const Config& config, const ParameterSet& values,
                     const std::vector<FreeParameter>& free, const IdentReport& report) {
  json doc = ConfigDocumentOf(config);
  if (!doc.contains("name")) doc["name"] = config.name;
  SetModelValues(config, values, &doc);
  json& ident = doc["identification"];
  if (!ident.is_object()) ident = json::object();
  ident.erase("initial");  // the fitted values are the start
  json names = json::array(), bounds = json::object();
  for (const auto& p : free) {
    names.push_back(p.name);
    bounds[p.name] = {p.lower, p.upper};
  }
  ident["free"] = names;
  ident["bounds"] = bounds;
  // Every setting that shaped the fit, as it ran (flags applied): a refit from this config
  // reproduces the report.
  const IdentificationSettings& settings = config.identification;
  ident["observe"] = settings.observe;
  ident["error"] = settings.error;
  if (settings.error == "equation") {
    ident["filter_hz"] = settings.filter_hz;
    ident["decimate"] = settings.decimate;
  } else {
    ident.erase("filter_hz");
    ident.erase("decimate");
  }
  if (settings.method.empty()) {
    ident.erase("method");
  } else {
    ident["method"] = settings.method;
  }
  if (settings.options.is_object() && !settings.options.empty()) {
    ident["options"] = settings.options;
  } else {
    ident.erase("options");
  }
  ident["weighting"] = settings.weighting;
  if (settings.noise_std.empty()) {
    ident.erase("noise_std");
  } else {
    ident["noise_std"] = settings.noise_std;
  }
  ident["effect_angle"] = settings.effect_angle;
  // A fit from the reference refits from the reference (identification.md §9b).
  if (settings.simulate_from == "reference") {
    ident["simulate_from"] = settings.simulate_from;
  } else {
    ident.erase("simulate_from");
  }
  // Provenance and the intervals, as a comment.
  json intervals = json::object();
  for (const auto& [name, p] : report.final_model.parameters) {
    json entry = {{"value", p.estimate.value}};
    if (!p.unit.empty()) entry["unit"] = p.unit;
    if (p.free && p.estimate.has_interval) {
      entry["ci95"] = {p.estimate.ci95_low, p.estimate.ci95_high};
      entry["interval_method"] = p.estimate.interval_method;
    }
    intervals[name] = entry;
  }
  json traces = json::array();
  for (const auto& t : report.traces) traces.push_back({{"path", t.path}, {"sha256", t.sha256}});
  json notes = {{"identified_by", std::string("blmd-ident ") + kVersion},
                {"from_config", report.config_path},
                {"traces", traces},
                {"parameters", intervals}};
  const ErrorFigures& fit = report.final_model.fit.errors;
  if (fit.ok && std::isfinite(fit.nrmse)) notes["fit_nrmse"] = fit.nrmse;
  if (report.discovery) notes["discovery_added"] = report.discovery->added;
  SetNotes(config, std::move(notes), &doc);
  return doc;
}

std::string MatlabScript(const IdentReport& report) {
  const LinearModel& m = report.linear_model;
  std::ostringstream out;
  out << "% The linear part of the model identified by blmd-ident " << kVersion << "\n"
      << "% config " << report.config_path << " ('" << report.config_name << "'), model "
      << report.model << "\n";
  for (const auto& t : report.traces)
    out << "% trace " << t.path << " (sha256 " << t.sha256 << ")\n";
  for (const auto& [name, p] : report.final_model.parameters) {
    out << "%   " << name << " = " << Exact(p.estimate.value)
        << (p.unit.empty() ? "" : " " + p.unit);
    if (p.free && p.estimate.has_interval) {
      out << "  (95 %: [" << Exact(p.estimate.ci95_low) << ", " << Exact(p.estimate.ci95_high)
          << "], " << p.estimate.interval_method << ")";
    }
    out << "\n";
  }
  if (!m.available) {
    out << "% No linear part: " << m.reason << "\n"
        << "error('blmd:noLinearModel', '%s', '" << m.reason << "');\n";
    return out.str();
  }
  out << "% Input " << m.input << "; " << m.assumption << ".\n"
      << "% MATLAB: Control System Toolbox; Octave: pkg load control\n"
      << "if exist('OCTAVE_VERSION', 'builtin'), pkg load control; end\n"
      << "A = " << MatlabMatrix(m.A) << ";\n"
      << "B = " << MatlabMatrix(m.B) << ";\n"
      << "C = " << MatlabMatrix(m.C) << ";\n"
      << "D = " << MatlabMatrix(m.D) << ";\n"
      << "sys = ss(A, B, C, D, 'StateName', " << MatlabNames(m.states) << ", 'InputName', 'u', "
      << "'OutputName', " << MatlabNames(m.outputs) << ");\n";
  for (const auto& tf : TransferFunctions(m)) {
    out << "G_" << tf.output << " = tf(" << MatlabRow(tf.numerator) << ", "
        << MatlabRow(tf.denominator) << ");  % u -> " << tf.output << "\n";
  }
  return out.str();
}

}  // namespace blmd
