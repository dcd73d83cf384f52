#!/usr/bin/env python3
"""Design from what was achieved (docs/design.md §7a): for every real-rig report of
docs/real-data.md, blmd-design --from-report REPORT --trace THE-SAME-RECORD predicts the
95 % half-width of each fitted parameter for the recorded input; the table puts it beside the
half-width the fit achieved (the report's own interval) and gives their ratio. The
prediction uses the report's final model, its noise and its variance ratios (what the
record's residual cost beyond white noise); without the ratios it is the white-noise
prediction, also shown.

The commands are those of the page, run as written by the same extraction as
scripts/real-data-reports, with blmd-ident replaced by blmd-design: the trace preparation
flags are kept (--column, --scale, --derive, --select, --initial-state, --resample, ...),
the identification flags dropped (--discover, --candidates, --max-effects, --validate).
A record that design cannot replay as one open-loop experiment (several experiments of a
--split, a coast-down) is listed with design's reason.

    tests/studies/design_from_report.py [BUILD_DIR]     # needs ../shared/realdata
"""
import json
import os
import subprocess
import sys
import tempfile

import real_data_commands

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.path.join(sys.argv[1] if len(sys.argv) > 1 else
                   os.path.join(ROOT, os.environ.get("BUILD_DIR", "build")), "bin")
DATA = os.environ.get("BLMD_REALDATA", os.path.join(ROOT, "..", "shared", "realdata"))

SHELL = r'''set -euo pipefail
blmd_ident() {  # the same record through blmd-design --from-report
  local args=() report="" skip=0 previous=""
  for argument in "$@"; do
    if ((skip)); then
      skip=0
      [[ $previous == --report ]] && report=$argument
      previous=$argument
      continue
    fi
    case $argument in
      --discover) ;;
      --candidates|--max-effects|--validate|--threads) skip=1 ;;
      --report) skip=1 ;;
      *) args+=("$argument") ;;
    esac
    previous=$argument
  done
  [[ -n $report ]] || return 0
  local out="$OUT/$(basename "${report%.json}").design.json"
  echo "$report $out" >> "$OUT/pairs"
  "$DESIGN" "${args[@]}" --from-report "$report" --quiet --report "$out" \
    2> "${out%.json}.err" || true
}
'''


def main():
    if not os.path.isdir(DATA):
        print("no real data at " + DATA, file=sys.stderr)
        return 2
    rows = []
    with tempfile.TemporaryDirectory() as out:
        env = dict(os.environ, OUT=out, DESIGN=os.path.join(BIN, "blmd-design"))
        subprocess.run(["bash", "-c", real_data_commands.script(ROOT, DATA, SHELL)], cwd=ROOT, env=env, check=True)
        for line in open(os.path.join(out, "pairs")):
            report_path, design_path = line.split()
            report = json.load(open(os.path.join(ROOT, report_path)))
            name = os.path.basename(report_path)[:-5]
            if not os.path.exists(design_path):
                reason = open(design_path[:-5] + ".err").read().strip().splitlines()
                rows.append((name, None, reason[-1] if reason else "no output"))
                continue
            design = json.load(open(design_path))
            if not design.get("ok"):
                reason = open(design_path[:-5] + ".err").read().strip().splitlines()
                rows.append((name, None, reason[-1] if reason else "not ok"))
                continue
            factors = design.get("from_report", {}).get("variance_factor", {})
            for parameter, predicted in design["design"]["predicted"].items():
                p = report["parameters"].get(parameter, {})
                if "ci95" not in p:
                    continue
                achieved = 0.5 * (p["ci95"][1] - p["ci95"][0])
                white = predicted["ci95_halfwidth"] / max(factors.get(parameter, 1.0), 1e-300) ** 0.5
                rows.append((name, parameter, (predicted["ci95_halfwidth"], achieved, white,
                                               p.get("interval_method", ""))))
    print("| report | parameter | predicted ± | achieved ± | ratio | white-noise prediction | ratio |")
    print("|---|---|---|---|---|---|---|")
    ratios = []
    for name, parameter, value in rows:
        if parameter is None:
            reason = value.replace(os.path.abspath(DATA), "$D").replace(DATA, "$D")
            reason = reason.replace(os.path.abspath(BIN) + "/", "").replace(BIN + "/", "")
            print("| %s | — | not replayed: %s | | | | |" % (name, reason.replace("|", "/")))
            continue
        predicted, achieved, white, method = value
        ratio = predicted / achieved
        ratios.append(ratio)
        print("| %s | %s | %.3g | %.3g%s | %.2f | %.3g | %.2f |" % (
            name, parameter, predicted, achieved,
            "" if method == "hac_prewhitened" else " (%s)" % method, ratio, white,
            white / achieved))
    inside = sum(1 for r in ratios if 0.5 <= r <= 2.0)
    print("within a factor of 2: %d of %d parameters" % (inside, len(ratios)), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
