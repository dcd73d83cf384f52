// The end of every command's --help (docs/cli.md): the exit codes with what each means for
// that command, and worked examples. The examples run as written from the repository root
// with the commands on PATH (tests/cli/help_test.cc runs every one). The layout is the one
// help2man reads (cmake/man-page.cmake): "Exit status:" becomes the man page's EXIT STATUS
// section, "Examples:" its EXAMPLES section, each "$ " line a verbatim command (indented
// deeper than the sentence above it, which help2man would otherwise join to it).
#pragma once

#include <CLI/CLI.hpp>
#include <stdexcept>
#include <string>

namespace blmd::app {

inline std::string HelpFooter(const std::string& command) {
  if (command == "blmd-sim") {
    return R"(Exit status:
  0  the trace was written (--init-config: the config was printed)
  1  the simulation diverged, or the trace could not be written
  2  bad usage or input: a flag, the config, the --input CSV, an unknown model (one error line, nothing written)

Examples:
  A starting config for a DC servo, then a run of it with 1 % noise on i and w:
    $ blmd-sim --init-config dc_servo > my-drive.json
    $ blmd-sim --config my-drive.json --out run.csv --noise i=1% --noise w=1% --seed 1
  The Ganesh servo with a Coulomb friction its config does not declare:
    $ blmd-sim --config configs/ganesh-square.json --out hidden.csv --effect coulomb_friction:Tc=0.003)";
  }
  if (command == "blmd-ident") {
    return R"(Exit status:
  0  the fit converged (and the gates passed)
  1  the fit did not converge (the report is still written), or an output could not be written
  2  bad usage or input: a flag, the config, a trace CSV, a name or value (one error line, nothing written)
  3  a gate failed: --fail-above-nrmse or --fail-on-warning (the report is still written)

Examples:
  Fit J and B of the Ganesh servo to its step response, with the JSON report:
    $ blmd-ident --config configs/ganesh-noload.json --trace testdata/ganesh-noload-step.csv --report fit.json
  Find the effect the model lacks (here a Coulomb friction), add it, refit; with the HTML report:
    $ blmd-ident --config configs/ganesh-square.json --trace testdata/dc-hidden-coulomb.csv --discover --html report.html
  A gate for CI scripts, exit 3 when the final NRMSE is above 5 %:
    $ blmd-ident --config configs/ganesh-square.json --trace testdata/ganesh-square.csv --fail-above-nrmse 0.05 --quiet)";
  }
  if (command == "blmd-surface") {
    return R"(Exit status:
  0  the surface was written (merge: the merged file; plot: the SVG)
  1  an output could not be written
  2  bad usage or input: a flag, the config, the trace, a grid beyond the size cap without --force, shards that do not match (one error line, nothing written)

Examples:
  The cost over J and B on log axes (21 x 11 points), with a heat map:
    $ blmd-surface --config configs/ganesh-noload.json --trace testdata/ganesh-noload-step.csv --grid J=log:1e-5:5e-5:21 --grid B=log:1e-5:5e-5:11 --out jb.csv --svg jb.svg
  The same cost over J in two shards (computed anywhere), merged and drawn:
    $ blmd-surface --config configs/ganesh-noload.json --trace testdata/ganesh-noload-step.csv --grid J=1e-5:5e-5:41 --shard 1/2 --out part-1.csv
    $ blmd-surface --config configs/ganesh-noload.json --trace testdata/ganesh-noload-step.csv --grid J=1e-5:5e-5:41 --shard 2/2 --out part-2.csv
    $ blmd-surface merge part-1.csv part-2.csv --out j.csv
    $ blmd-surface plot j.csv --svg j.svg)";
  }
  if (command == "blmd-tune") {
    return R"(Exit status:
  0  the gains were found (and the report and config written)
  1  the request cannot be met: the controller cannot give the phase margin at that crossover, or the step needs more than the drive's limits (the reason on one line, nothing written); or an output could not be written
  2  bad usage or input: a flag, the config, the --from-report file (one error line, nothing written)

Examples:
  A PID position loop for the Ganesh servo at 2 Hz with 60 deg of phase margin, 24 V drive:
    $ blmd-tune --config configs/ganesh-noload.json --loop position --crossover 2 --phase-margin 60 --limit u=24
  From an identification: the final model and its 95 % box, a PI speed loop, the closed loop run by blmd-sim:
    $ blmd-ident --config configs/ganesh-square.json --trace testdata/ganesh-square.csv --report fit.json --quiet
    $ blmd-tune --config configs/ganesh-square.json --from-report fit.json --loop speed --crossover 3 --phase-margin 60 --limit u=24 --limit i=4 --report tune.json --write-config closed.json
    $ blmd-sim --config closed.json --out closed.csv)";
  }
  if (command == "blmd-design") {
    return R"(Exit status:
  0  the design was made (--trace: the recorded input was evaluated) and the outputs written
  1  no design: no candidate input is feasible within the limits, or the experiment does not tell the free parameters apart (the report is still written), or an output could not be written
  2  bad usage or input: a flag, the config, the --trace CSV, a limit or noise level (one error line, nothing written)

Examples:
  The 2 s experiment that pins J and B of the Ganesh servo down best at |u| <= 12 V, with 14 mA and 2.5 rad/s of noise on i and w; the config and the input table to play:
    $ blmd-design --config configs/ganesh-square.json --duration 2 --limit u=12 --noise i=0.014 --noise w=2.5 --write-config design.json --write-input design-input.csv
  A PRBS for J alone (A-optimal), the current at most 1 A, noise 1 % of the config's own peaks:
    $ blmd-design --config configs/ganesh-square.json --duration 2 --limit u=12 --limit i=1 --noise i=1% --noise w=1% --family prbs --target J
  How good is the experiment already run (noise from its residual against the model):
    $ blmd-design --config configs/ganesh-square.json --trace testdata/ganesh-square.csv)";
  }
  if (command == "blmd-export") {
    return R"(Exit status:
  0  the files were written
  1  an output could not be written
  2  bad usage or input: a flag, the config, the report, a final model that cannot be exported (one error line, nothing written)

Examples:
  The feed-forward of an identified servo as C99, with the J tracker for a 1 kHz loop:
    $ blmd-ident --config configs/ganesh-square.json --trace testdata/ganesh-square.csv --report fit.json --quiet
    $ blmd-export --config configs/ganesh-square.json --from-report fit.json --format c --tracker-rate 1000 --out firmware
  ODrive's inertia and anti-cogging map, and a MuJoCo joint:
    $ blmd-export --config configs/ganesh-square.json --from-report fit.json --format odrive --out odrive.json
    $ blmd-export --config configs/ganesh-square.json --from-report fit.json --format mujoco --out shaft.xml)";
  }
  if (command == "blmd-track") {
    return R"(Exit status:
  0  the track was written
  1  an output could not be written
  2  bad usage or input: a flag, the config, the report, the trace (one error line, nothing written)
  3  with --fail-on-change: J left its offline interval (changed) at the end of the trace

Examples:
  J and the load torque along a record, seeded by the identification:
    $ blmd-ident --config configs/ganesh-square.json --trace testdata/ganesh-square.csv --report fit.json --quiet
    $ blmd-track --config configs/ganesh-square.json --from-report fit.json --trace testdata/ganesh-square.csv --out track.csv)";
  }
  throw std::logic_error("HelpFooter: no footer for " + command);
}

// Ends `app`'s --help with HelpFooter(command).
inline void AddHelpFooter(CLI::App& app, const std::string& command) {
  app.footer(HelpFooter(command));
}

}  // namespace blmd::app
