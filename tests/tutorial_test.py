#!/usr/bin/env python3
"""Runs docs/tutorial.md as a reader would and checks the numbers it quotes.

Usage: tutorial_test.py SOURCE_DIR BIN_DIR WORK_DIR

The page's ```sh blocks (scripts/doc-sh-blocks) run in order in one `bash -euo pipefail`
in a fresh WORK_DIR, with BIN_DIR first on PATH, BLMD_REALDATA pointing at the real data
($BLMD_REALDATA, else SOURCE_DIR/../shared/realdata, made absolute) and xdg-open replaced
by a stub that records the file it was asked to open. Then the reports the page writes are
read and checked:

- every figure in QUOTED below appears in the page's text as written there, and the run
  gives it within 0.1 % (or half a unit of its last quoted digit, when that is larger);
- the page's claims: discovery adds what the page says, M, Fv and Fc within 1 % of the
  published EMPS values, the offset within 0.05 N, each published value inside its 95 %
  interval, the HTML report written and opened.

Exit 0 when all hold, 1 otherwise (each failed check on a line), 77 (ctest SKIP_RETURN_CODE)
when the EMPS data are absent. The log of the run is WORK_DIR/tutorial.log. With
BLMD_REPORT_SINK set (tests/CMakeLists.txt) the JSON reports are copied there for the
schema suite.
"""

import json
import math
import os
import shutil
import subprocess
import sys

PUBLISHED = {"J": 95.1089, "B": 203.5034, "Tc": 20.3935, "TL": -3.1648}  # EMPS PDF §3.4

# (what, report, getter, the figure as the page quotes it)
QUOTED = [
    ("first fit J", "final", lambda r: r["discovery"]["before"]["parameters"]["J"]["value"], "95.2567"),
    ("first fit B", "final", lambda r: r["discovery"]["before"]["parameters"]["B"]["value"], "411.045"),
    ("first fit NRMSE", "final", lambda r: r["discovery"]["before"]["fit"]["nrmse"], "0.181"),
    ("first fit simulated w NRMSE", "final",
     lambda r: r["discovery"]["before"]["fit"]["simulated"]["nrmse"], "0.189"),
    ("first fit by-sign-of-w t", "final",
     lambda r: r["discovery"]["before"]["residual"]["columns"]["u"]["by_sign_of_w"]["t"], "22.9"),
    ("open discovery B", "open", lambda r: r["parameters"]["B"]["value"], "202.891"),
    ("open discovery J", "open", lambda r: r["parameters"]["J"]["value"], "95.1067"),
    ("open discovery Tc", "open", lambda r: r["parameters"]["Tc"]["value"], "20.4547"),
    ("open discovery dB", "open", lambda r: r["parameters"]["dB"]["value"], "-39.3521"),
    ("open discovery NRMSE", "open", lambda r: r["fit"]["nrmse"], "0.03424"),
    ("final B", "final", lambda r: r["parameters"]["B"]["value"], "202.647"),
    ("final B ci95 low", "final", lambda r: r["parameters"]["B"]["ci95"][0], "197.07"),
    ("final B ci95 high", "final", lambda r: r["parameters"]["B"]["ci95"][1], "208.38"),
    ("final J", "final", lambda r: r["parameters"]["J"]["value"], "95.0775"),
    ("final J ci95 low", "final", lambda r: r["parameters"]["J"]["ci95"][0], "94.542"),
    ("final J ci95 high", "final", lambda r: r["parameters"]["J"]["ci95"][1], "95.616"),
    ("final TL", "final", lambda r: r["parameters"]["TL"]["value"], "-3.15699"),
    ("final Tc", "final", lambda r: r["parameters"]["Tc"]["value"], "20.482"),
    ("final NRMSE", "final", lambda r: r["fit"]["nrmse"], "0.0434"),
    ("final simulated w NRMSE", "final", lambda r: r["fit"]["simulated"]["nrmse"], "0.04956"),
    ("validation NRMSE", "final", lambda r: r["validation"]["nrmse"], "0.06133"),
    ("validation simulated w NRMSE", "final", lambda r: r["validation"]["simulated"]["nrmse"],
     "0.0733"),
]

ADDED = {"open": ["coulomb_friction", "asymmetric_viscous"],
         "final": ["coulomb_friction", "load_torque"]}


def tolerance(quoted):
    """0.1 % of the figure, or half a unit of its last digit when that is larger."""
    digits = quoted.lstrip("-")
    decimals = len(digits.split(".")[1]) if "." in digits else 0
    return max(1e-3 * abs(float(quoted)), 0.5 * 10.0 ** -decimals) * (1 + 1e-9)


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    source, bin_dir, work = (os.path.abspath(a) for a in argv)
    data = os.environ.get("BLMD_REALDATA") or os.path.join(source, "..", "shared", "realdata")
    data = os.path.abspath(data)
    needed = [os.path.join(data, "emps", n)
              for n in ("emps_estimation.csv", "emps_validation_pulses.csv")]
    missing = [n for n in needed if not os.path.isfile(n)]
    if missing:
        print("SKIP: the EMPS data are absent (%s); set BLMD_REALDATA to the folder holding "
              "emps/" % ", ".join(missing))
        return 77

    page = os.path.join(source, "docs", "tutorial.md")
    with open(page, encoding="utf-8") as f:
        text = f.read()
    script = subprocess.run([sys.executable, os.path.join(source, "scripts", "doc-sh-blocks"), page],
                            check=True, capture_output=True, text=True).stdout

    shutil.rmtree(work, ignore_errors=True)
    stub = os.path.join(work, ".stub-bin")
    os.makedirs(stub)
    opened = os.path.join(work, ".opened")
    with open(os.path.join(stub, "xdg-open"), "w") as f:
        f.write('#!/bin/sh\n[ -f "$1" ] || { echo "xdg-open: no file $1" >&2; exit 1; }\n'
                'realpath "$1" >> "%s"\necho "(xdg-open $1: stubbed by the test)"\n' % opened)
    os.chmod(os.path.join(stub, "xdg-open"), 0o755)
    script_path = os.path.join(work, "tutorial.sh")
    with open(script_path, "w") as f:
        f.write(script)
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([stub, bin_dir, env.get("PATH", "")])
    env["BLMD_REALDATA"] = data
    log_path = os.path.join(work, "tutorial.log")
    with open(log_path, "w") as log:
        run = subprocess.run(["bash", "-euo", "pipefail", script_path], cwd=work, env=env,
                             stdout=log, stderr=subprocess.STDOUT)
    with open(log_path, encoding="utf-8", errors="replace") as f:
        log_text = f.read()
    sys.stdout.write(log_text)
    if run.returncode != 0:
        print("FAIL: the tutorial's commands exited with %d (log: %s)" % (run.returncode, log_path))
        return 1

    out = os.path.join(work, "emps-tutorial")
    failures = []
    reports = {}
    for key, name in (("open", "open.json"), ("final", "emps-report.json")):
        try:
            with open(os.path.join(out, name), encoding="utf-8") as f:
                reports[key] = json.load(f)
        except (OSError, ValueError) as error:
            failures.append("cannot read %s: %s" % (name, error))
    if failures:
        print("\n".join("FAIL: " + f for f in failures))
        return 1

    checked = 0
    for what, key, get, quoted in QUOTED:
        if quoted not in text:
            failures.append("%s: the page does not quote %s" % (what, quoted))
        try:
            value = float(get(reports[key]))
        except (KeyError, IndexError, TypeError, ValueError) as error:
            failures.append("%s: not in the report (%r)" % (what, error))
            continue
        checked += 1
        if not (math.isfinite(value) and abs(value - float(quoted)) <= tolerance(quoted)):
            failures.append("%s: the page quotes %s, the run gives %.8g" % (what, quoted, value))
    for key, effects in ADDED.items():
        added = reports[key]["discovery"]["added"]
        if added != effects:
            failures.append("%s run: discovery added %s, the page says %s" % (key, added, effects))
    final = reports["final"]["parameters"]
    for name, reference in PUBLISHED.items():
        value = final[name]["value"]
        low, high = final[name]["ci95"]
        if name == "TL":
            if abs(value - reference) > 0.05:
                failures.append("offset %.5g N is more than 0.05 N from %.5g" % (value, reference))
        elif abs(value - reference) > 0.01 * abs(reference):
            failures.append("%s = %.6g is more than 1 %% from %.6g" % (name, value, reference))
        if not low <= reference <= high:
            failures.append("%s: the published %.6g is outside [%.6g, %.6g]" % (name, reference,
                                                                                low, high))
    html = os.path.join(out, "emps-report.html")
    if not os.path.isfile(html) or os.path.getsize(html) < 10000:
        failures.append("emps-report.html missing or short")
    else:
        with open(html, encoding="utf-8") as f:
            page_html = f.read()
        for needle in ("<html", "coulomb_friction", "load_torque"):
            if needle not in page_html:
                failures.append("emps-report.html lacks %r" % needle)
    try:
        with open(opened) as f:
            if os.path.realpath(html) not in f.read().split("\n"):
                failures.append("xdg-open was not asked to open emps-report.html")
    except OSError:
        failures.append("xdg-open was not run")

    sink = os.environ.get("BLMD_REPORT_SINK")
    if sink:
        os.makedirs(sink, exist_ok=True)
        for key, name in (("open", "open.json"), ("final", "emps-report.json")):
            shutil.copy(os.path.join(out, name), os.path.join(sink, "report-tutorial-" + name))

    if failures:
        print("\n".join("FAIL: " + f for f in failures))
        return 1
    print("tutorial: %d quoted figures and %d claims hold (data: %s)"
          % (checked, len(ADDED) + 2 * len(PUBLISHED) + 2, data))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
