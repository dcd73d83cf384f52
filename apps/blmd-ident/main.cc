// blmd-ident: identify the free parameters of a config's model from measured traces.
#include <iostream>
#include <thread>

#include "../common/app_main.h"
#include "../common/error_flags.h"
#include "../common/trace_flags.h"
#include "blmd/ident/discovery.h"
#include "blmd/ident/optimizer.h"
#include "blmd/ident/trace_input.h"
#include "blmd/ident/trace_jackknife.h"
#include "blmd/io/config.h"
#include "blmd/io/files.h"
#include "blmd/io/flags.h"
#include "blmd/report/html_report.h"
#include "blmd/report/report.h"
#include "blmd/sim/effects.h"

int main(int argc, char** argv) {
  CLI::App app{"blmd-ident: identify J, B (and any other free parameter) from a recorded trace"};
  blmd::app::AddVersionFlag(app, "blmd-ident");
  std::string config_path, method, observe_text, free_text, report_path, initial_state = "config";
  std::string html_path, split;
  std::vector<std::string> selects;
  std::vector<std::string> traces, validates, columns, scales, derives, method_options, initials;
  std::uint64_t seed = 1;
  int threads = 0, max_evaluations = 0;
  bool json = false, quiet = false, discover = false, verbose = false;
  double bic_margin = 10.0;
  int max_effects = 3;
  std::string candidates_text;
  double fail_above = -1.0;
  blmd::app::ErrorFlags error_flags;
  blmd::app::TraceFlags trace_flags;
  app.add_option("--config", config_path, "model and identification set-up (JSON)")->required();
  app.add_option("--trace", traces, "measured trace CSV (repeatable: one fit over all)")
      ->required();
  app.add_option("--validate", validates, "held-out trace CSV to report the error on (repeatable)");
  app.add_option("--method", method, "ceres|powell|fsd|classic (default: config, else ceres)");
  app.add_option("--observe", observe_text, "trace columns in the cost, e.g. i,w");
  app.add_option("--free", free_text, "parameters to identify, e.g. J,B");
  app.add_option("--initial", initials, "start value NAME=VALUE (repeatable)");
  app.add_option("--option", method_options,
                 "method option KEY=VALUE (repeatable), e.g. algorithm=praxis");
  app.add_option("--max-evaluations", max_evaluations,
                 "cost evaluation budget (0: method default)");
  app.add_option("--initial-state", initial_state, "config|trace: initial w, theta, i")
      ->check(CLI::IsMember({"config", "trace"}));
  app.add_flag("--discover", discover, "find the effects the model lacks, add them, refit");
  app.add_option("--bic-margin", bic_margin,
                 "discovery: BIC fall needed to add an effect (default 10)")
      ->check(blmd::app::PositiveNumber());
  app.add_option("--max-effects", max_effects, "discovery: most effects to add (default 3)")
      ->check(CLI::Range(1, 20));
  app.add_option("--candidates", candidates_text,
                 "discovery: effects to consider, e.g. coulomb_friction,load_torque");
  app.add_option("--report", report_path, "write the JSON report here");
  app.add_flag("--json", json, "print the JSON report on stdout instead of the summary");
  app.add_option("--html", html_path,
                 "write the visual report (one self-contained HTML file) here");
  app.add_option("--column", columns,
                 "map a standard column to a header, NAME=HEADER (repeatable)");
  app.add_option("--scale", scales, "multiply a column, NAME=FACTOR (repeatable)");
  app.add_option("--derive", derives, "derive a velocity from a position, e.g. w=theta");
  app.add_option("--select", selects,
                 "keep the rows with NAME in VALUE[,VALUE...] or LO:HI (repeatable)");
  app.add_option("--split", split,
                 "cut each trace into one experiment per block of equal COLUMN values");
  app.add_option("--seed", seed, "random seed (fsd)")->check(blmd::app::NonNegativeWholeNumber());
  app.add_option("--threads", threads, "worker threads (0: all cores)")
      ->check(blmd::app::NonNegativeWholeNumber());
  app.add_flag("--quiet", quiet, "print nothing but errors");
  app.add_option("--fail-above-nrmse", fail_above, "exit 3 when the final NRMSE exceeds X")
      ->check(blmd::app::NonNegativeNumber());
  bool fail_on_warning = false;
  app.add_flag("--fail-on-warning", fail_on_warning,
               "exit 3 when the report has a warning about the final model (docs/report.md)");
  app.add_flag("--verbose", verbose, "also print the solvers' own log (Ceres) on stderr");
  error_flags.Add(app,
                  "simulate and compare the motion, or compare the input the model needs along the "
                  "measured motion");
  trace_flags.Add(app);

  return blmd::app::Main(
      app, argc, argv,
      [&]() -> int {
        threads = blmd::app::CapThreads(threads);
        // Every output checked before any work: writable, not an input, not another output.
        std::vector<blmd::NamedPath> input_files = {{"--config", config_path}};
        for (const auto& path : traces) input_files.push_back({"--trace", path});
        for (const auto& path : validates) input_files.push_back({"--validate", path});
        blmd::CheckOutputs({{"--report", report_path}, {"--html", html_path}}, input_files);
        blmd::Config config = blmd::LoadConfig(config_path);
        // A selecting flag given empty selects nothing: exit 2 with the valid choices.
        auto join = [](const std::vector<std::string>& names) {
          std::string out;
          for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
          return out;
        };
        if (app.count("--observe") > 0 && observe_text.empty()) {
          throw blmd::InputError("--observe: empty (valid: " + join(config.model->outputs()) + ")");
        }
        if (app.count("--free") > 0 && free_text.empty()) {
          std::vector<std::string> names;
          for (const auto& [name, value] : config.parameters.entries()) names.push_back(name);
          throw blmd::InputError("--free: empty (valid: " + join(names) + ")");
        }
        if (app.count("--candidates") > 0 && candidates_text.empty()) {
          std::vector<std::string> effects;
          for (const auto& effect : blmd::EffectRegistry()) effects.push_back(effect.name);
          throw blmd::InputError("--candidates: empty (valid: " + join(effects) + ")");
        }
        for (const auto& text : initials) {
          const auto [name, value] = blmd::ParseAssignment(text, "--initial");
          config.identification.initial.Set(name, value);
        }
        const std::vector<std::string> observe = error_flags.Apply(&config, observe_text);
        const bool equation_error = config.identification.error == "equation";
        if (method.empty())
          method = config.identification.method.empty() ? "ceres" : config.identification.method;
        const blmd::Optimizer& optimizer = blmd::FindOptimizer(method);
        const std::vector<std::string> outputs = config.model->outputs();
        for (const auto& name : observe) {
          if (equation_error) break;
          if (std::find(outputs.begin(), outputs.end(), name) == outputs.end()) {
            std::string valid;
            for (const auto& o : outputs) valid += (valid.empty() ? "" : ",") + o;
            throw blmd::InputError("--observe: '" + name + "' is not an output of model " +
                                   std::string(config.model->name()) + " (valid: " + valid + ")");
          }
        }
        const std::vector<std::string> free_names = free_text.empty()
                                                        ? config.identification.free
                                                        : blmd::ParseNameList(free_text, "--free");
        for (const auto& text : initials) {
          const std::string name = blmd::ParseAssignment(text, "--initial").first;
          if (std::find(free_names.begin(), free_names.end(), name) == free_names.end()) {
            std::string valid;
            for (const auto& f : free_names) valid += (valid.empty() ? "" : ", ") + f;
            throw blmd::InputError("--initial " + name + ": '" + name +
                                   "' is not a free parameter, so it has no start value (free: " +
                                   valid + "; free it with --free)");
          }
        }
        const auto free = blmd::MakeFreeParameters(config, free_names);

        blmd::TraceInputOptions input_options;
        input_options.delimiter = trace_flags.Delimiter();
        input_options.duplicate_time = trace_flags.Duplicates();
        for (const auto& text : columns) {
          const auto [name, header] = blmd::ParseTextAssignment(text, "--column");
          input_options.columns[name] = header;
        }
        for (const auto& text : scales) {
          const auto [name, factor] = blmd::ParseAssignment(text, "--scale");
          input_options.scales[name] = factor;
        }
        for (const auto& text : derives) {
          const auto [target, source] = blmd::ParseTextAssignment(text, "--derive");
          if (target != "w" || (source != "theta")) {
            throw blmd::InputError("--derive '" + text + "': supported: w=theta");
          }
          input_options.derive.emplace_back(target, source);
        }
        if (!equation_error) input_options.required = observe;
        input_options.initial_from_trace = initial_state == "trace";
        for (const auto& text : selects)
          input_options.select.push_back(blmd::ParseRowSelection(text));
        input_options.split = split;

        nlohmann::json options_json = config.identification.method == method
                                          ? config.identification.options
                                          : nlohmann::json::object();
        for (const auto& text : method_options) {
          const auto [key, value] = blmd::ParseTextAssignment(text, "--option");
          options_json[key] = value;
        }
        std::vector<std::string> candidate_names;
        if (!candidates_text.empty()) {
          candidate_names = blmd::ParseNameList(candidates_text, "--candidates");
          for (const auto& name : candidate_names) blmd::FindEffect(name);
        }
        std::vector<blmd::FitTrace> fit_traces;
        for (const auto& path : traces) {
          for (auto& part : blmd::LoadFitTraces(path, input_options, config.experiment.initial)) {
            fit_traces.push_back(std::move(part));
          }
        }
        std::vector<blmd::FitTrace> validation_traces;
        for (const auto& path : validates) {
          for (auto& part : blmd::LoadFitTraces(path, input_options, config.experiment.initial)) {
            validation_traces.push_back(std::move(part));
          }
        }
        if (!report_path.empty() || !html_path.empty()) blmd::InstallCleanupOnSignal();

        const blmd::FitProblem problem(config, std::move(fit_traces), observe, free);
        std::unique_ptr<blmd::FitProblem> validation;
        if (!validation_traces.empty()) {
          validation = std::make_unique<blmd::FitProblem>(config, std::move(validation_traces),
                                                          observe, free);
        }
        blmd::OptimizerOptions options;
        options.seed = seed;
        options.threads = threads;
        options.max_evaluations = max_evaluations;
        options.method_options = options_json;
        options.verbose = verbose;
        const blmd::FitResult result = optimizer.Minimize(problem, options);
        // The spread between traces in the intervals (trace_jackknife.h): K refits, K >= 3.
        blmd::OptimizerOptions jackknife_options = options;
        jackknife_options.method_options = nlohmann::json::object();
        auto widened = [&](const blmd::FitProblem& fitted, const blmd::FitResult& fit) {
          blmd::FitResult copy = fit;
          if (fit.evaluation.ok && fit.summary.converged && fitted.traces().size() >= 3) {
            blmd::WidenByTraceJackknife(
                fitted, blmd::LeaveOneTraceOut(fitted, fit.values, jackknife_options), &copy);
          }
          return copy;
        };
        const blmd::FitResult first_result = widened(problem, result);

        blmd::ReportInputs inputs;
        inputs.config_path = config_path;
        inputs.problem = &problem;
        inputs.result = &first_result;
        inputs.validation = validation.get();
        inputs.seed = seed;
        inputs.threads = threads > 0
                             ? threads
                             : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
        nlohmann::json report = blmd::MakeReport(inputs);
        std::unique_ptr<blmd::DiscoveryResult> discovery_for_html;
        if (discover) {
          blmd::DiscoveryOptions discovery_options;
          discovery_options.bic_margin = bic_margin;
          discovery_options.max_effects = max_effects;
          discovery_options.refit.threads = threads;
          discovery_options.refit.seed = seed;
          discovery_options.refit.verbose = verbose;
          if (!candidates_text.empty()) discovery_options.candidates = candidate_names;
          if (validation) discovery_options.held_out = &validation->traces();
          const blmd::DiscoveryResult discovery =
              blmd::Discover(problem, result, discovery_options);
          if (!html_path.empty())
            discovery_for_html = std::make_unique<blmd::DiscoveryResult>(discovery);
          std::unique_ptr<blmd::FitProblem> validation_after;
          if (validation) {
            validation_after = std::make_unique<blmd::FitProblem>(
                discovery.final_config, validation->traces(), observe,
                blmd::NamedFreeParameters(discovery.final_free));
          }
          nlohmann::json discovery_json = blmd::DiscoveryJson(
              problem, result, discovery, validation.get(), validation_after.get());
          if (problem.equation_error()) {
            const auto& values = discovery.final_fit.values;
            discovery_json["simulated_after"] = blmd::SimulatedErrors(
                problem, discovery.final_config, discovery.final_free, values);
            if (validation_after && discovery_json.contains("validation")) {
              discovery_json["validation"]["simulated_after"] = blmd::SimulatedErrors(
                  *validation_after, discovery.final_config, discovery.final_free, values);
            }
            blmd::SanitizeJson(&discovery_json);
          }
          // The final model is the answer (issue 19): its parameters, fit, residual and
          // validation head the report; the first fit moves to discovery.before.
          const std::unique_ptr<blmd::FitProblem> final_problem =
              blmd::FinalProblem(problem, discovery);
          nlohmann::json headline = report;
          if (final_problem) {
            const blmd::FitResult final_result = widened(*final_problem, discovery.final_fit);
            blmd::ReportInputs final_inputs = inputs;
            final_inputs.problem = final_problem.get();
            final_inputs.result = &final_result;
            final_inputs.validation = validation_after.get();
            headline = blmd::MakeReport(final_inputs);
          }
          report = blmd::FinalModelReport(std::move(headline), report, std::move(discovery_json));
        }
        blmd::WidenForAmbiguity(&report);
        blmd::AddWarnings(&report);
        if (!report_path.empty()) blmd::WriteFileAtomically(report_path, report.dump(2) + "\n");
        if (!html_path.empty()) {
          blmd::HtmlReportOptions html_options;
          html_options.threads = threads;
          blmd::WriteHtmlReport(html_path, {&report, &problem, &result, discovery_for_html.get()},
                                html_options);
        }
        if (json) {
          std::cout << report.dump(2) << "\n";
        } else if (!quiet) {
          std::cout << blmd::HumanSummary(report);
          if (!report_path.empty()) std::cout << "report: " << report_path << "\n";
          if (!html_path.empty()) std::cout << "html report: " << html_path << "\n";
        }
        if (!result.summary.converged) {
          std::cerr << "error: the fit did not converge: " << result.summary.termination << "\n";
          return blmd::kExitFailed;
        }
        if (fail_above >= 0.0) {
          // The final model's NRMSE (after discovery when it ran: its model is the answer).
          const auto& nrmse = report["fit"]["nrmse"];
          if (nrmse.is_null() || nrmse.get<double>() > fail_above) {
            std::cerr << "error: final NRMSE "
                      << (nrmse.is_null() ? std::string("n/a") : nrmse.dump())
                      << " is above --fail-above-nrmse " << fail_above << "\n";
            return blmd::kExitGate;
          }
        }
        if (fail_on_warning && !report["warnings"].empty()) {
          std::string codes;
          for (const auto& w : report["warnings"])
            codes += (codes.empty() ? "" : ", ") + w["code"].get<std::string>();
          std::cerr << "error: " << report["warnings"].size() << " warning"
                    << (report["warnings"].size() > 1 ? "s" : "") << " (" << codes
                    << ") and --fail-on-warning\n";
          return blmd::kExitGate;
        }
        return blmd::kExitOk;
      },
      {"--observe", "--free", "--candidates"});
}
