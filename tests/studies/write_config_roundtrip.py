#!/usr/bin/env python3
"""--write-config's round trip on the documented commands (docs/export.md §1): each
blmd-ident command of docs/real-data.md that writes a report is run again with
--write-config, and the config it writes is refitted on the same trace with the same
preparation flags (--column, --scale, --derive, --select, --split, --initial-state, ...) and
nothing else: no --discover, --candidates, --error, --filter-hz, --observe, --weighting; the
written config must carry every setting that shaped the fit. The table gives, per command,
the largest relative difference between the refit's values and the first run's.

    tests/studies/write_config_roundtrip.py [REGEX] [BUILD_DIR]   # reports matching REGEX
"""
import json
import os
import subprocess
import sys
import tempfile

import real_data_commands

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PATTERN = sys.argv[1] if len(sys.argv) > 1 else "."
BIN = os.path.join(sys.argv[2] if len(sys.argv) > 2 else
                   os.path.join(ROOT, os.environ.get("BUILD_DIR", "build")), "bin")
DATA = os.environ.get("BLMD_REALDATA", os.path.join(ROOT, "..", "shared", "realdata"))

SHELL = r'''set -euo pipefail
blmd_ident() {  # the command with --write-config, then the refit from what it wrote
  local first=() refit=() report="" skip=0 keep=0 previous=""
  for argument in "$@"; do
    if ((skip)); then
      skip=0
      [[ $previous == --report ]] && report=$argument
      ((keep)) && refit+=("$argument")
      [[ $previous != --report ]] && first+=("$argument")
      previous=$argument
      continue
    fi
    case $argument in
      --report) skip=1; keep=0 ;;
      --discover) first+=("$argument") ;;
      --config|--candidates|--max-effects|--validate|--error|--filter-hz|--observe|--free|\
--method|--weighting|--noise-std|--decimate|--initial|--option|--bic-margin)
        skip=1; keep=0; first+=("$argument") ;;
      --*) skip=1; keep=1; first+=("$argument"); refit+=("$argument") ;;
      *) first+=("$argument") ;;
    esac
    # flags without a value
    case $argument in
      --discover|--quiet) skip=0 ;;
    esac
    previous=$argument
  done
  [[ -n $report && $report =~ $PATTERN ]] || return 0
  local name; name=$(basename "${report%.json}")
  "$IDENT" "${first[@]}" --quiet --report "$OUT/$name.first.json" \
    --write-config "$OUT/$name.config.json" > /dev/null 2>&1 || true
  [[ -f $OUT/$name.config.json ]] || { echo "$name -" >> "$OUT/pairs"; return 0; }
  "$IDENT" --config "$OUT/$name.config.json" "${refit[@]}" --quiet \
    --report "$OUT/$name.refit.json" > /dev/null 2>&1 || true
  echo "$name $OUT/$name.first.json $OUT/$name.refit.json" >> "$OUT/pairs"
}
'''


def main():
    if not os.path.isdir(DATA):
        print("no real data at " + DATA, file=sys.stderr)
        return 2
    script = real_data_commands.script(ROOT, DATA, SHELL)
    print("| command's report | values | largest relative difference | refit |")
    print("|---|---|---|---|")
    worst = 0.0
    with tempfile.TemporaryDirectory() as out:
        env = dict(os.environ, OUT=out, IDENT=os.path.join(BIN, "blmd-ident"), PATTERN=PATTERN)
        subprocess.run(["bash", "-c", script], cwd=ROOT, env=env, check=True)
        for line in open(os.path.join(out, "pairs")):
            words = line.split()
            if len(words) < 3 or not os.path.exists(words[2]):
                print("| %s | — | — | failed |" % words[0])
                worst = float("inf")
                continue
            first = json.load(open(words[1]))["parameters"]
            refit = json.load(open(words[2]))["parameters"]
            diff, which = 0.0, ""
            for name, p in first.items():
                a, b = p["value"], refit.get(name, {}).get("value", float("nan"))
                d = abs(b - a) / max(abs(a), 1e-300)
                if not d <= diff:
                    diff, which = d, name
            worst = max(worst, diff)
            print("| %s | %d | %.1e%s | %s |" % (words[0], len(first), diff,
                                                 " (%s)" % which if diff > 0 else "",
                                                 "same" if diff <= 1e-9 else "DIFFERS"))
    return 0 if worst <= 1e-9 else 1


if __name__ == "__main__":
    sys.exit(main())
