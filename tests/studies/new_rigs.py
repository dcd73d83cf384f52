#!/usr/bin/env python3
"""The public records of testdata/realdata fitted as a new user would (docs/real-data.md,
"Records found for this release"): the starting config of `blmd-ident --init-config
rigid_load` (configs/real/delta-a3.json: only its name and description changed), the
columns as the files name them, `--discover`, no selection and no cut-off. Where that run
warns, the next step its warning names is followed and the run repeated; a next step
the repeated run's warnings name is followed in turn (at most two steps). Prints one
line per record and step: J with its 95 % interval, the independent estimate and whether the
interval covers it, the effects added and the warnings.

    tests/studies/new_rigs.py [BUILD_DIR]        # default $BUILD_DIR, else build/
"""
import glob
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.path.join(sys.argv[1] if len(sys.argv) > 1 else
                   os.path.join(ROOT, os.environ.get("BUILD_DIR", "build")), "bin")
DATA = os.path.join(ROOT, "testdata", "realdata")
CONFIG = os.path.join(ROOT, "configs", "real", "delta-a3.json")

# record, independent J (kg m^2) and its source (each folder's README, "Independent estimate")
RECORDS = [
    ("delta_a3_servo/lorenz_jm_1.csv", 1.93e-4, "three estimates over ten runs, +-2 %"),
    ("delta_a3_servo/lorenz_jm_2.csv", 1.93e-4, "three estimates over ten runs, +-2 %"),
    ("asen3801_reaction_wheel/rw_T10_run1.csv", 1.099e-4, "regression at 2 Hz, +-30 % (bootstrap)"),
    ("asen3801_reaction_wheel/rw_T5_run1.csv", 0.937e-4, "regression at 2 Hz, +-30 % (bootstrap)"),
    ("asen3801_reaction_wheel/rw_T6767_run1.csv", 0.918e-4, "regression at 2 Hz, +-30 % (bootstrap)"),
    ("mcgill_qnet_dcmotor/qnet_step2V_torque.csv", 2.08e-5, "regression at 3-20 Hz, both runs"),
    ("mcgill_qnet_dcmotor/qnet_step4V6V_torque.csv", 2.08e-5, "regression at 3-20 Hz, both runs"),
    ("ultra_mk2_odrive_flywheel/flywheel_ramp_0p1Nm_per_s.csv", 1.97e-5, "regression at 2 Hz; CAD"),
    ("ultra_mk2_odrive_flywheel/noflywheel_steps.csv", 7.15e-6, "regression at 2 Hz"),
    ("asen3801_sc_base/base_T10_run1.csv", 5.4e-3, "regression with a 1/rev term, +-25 %"),
    ("asen3200_reaction_wheel_2018/unit01_T10_run05.csv", 1.31e-4, "slope difference, this run"),
    ("asen3200_reaction_wheel_2018/unit07_T10_run21.csv", 1.30e-4, "slope difference, this run"),
    ("asen3200_reaction_wheel_2018/unit07_T10_run22.csv", 1.12e-4, "slope difference, this run"),
    ("asen3200_reaction_wheel_2018/unit07_T10_run23.csv", 1.03e-4, "slope difference, this run"),
    ("asb_srv02_cnc_steps/m0_p2V.csv", 3.83e-3, "datasheet and CAD, home pose"),
    ("asb_srv02_cnc_steps/m0_m2V.csv", 3.83e-3, "datasheet and CAD, home pose"),
    ("asb_srv02_cnc_steps/m0_*.csv", 3.83e-3, "datasheet and CAD, home pose (six steps)"),
]


def run(args):
    with tempfile.TemporaryDirectory() as scratch:
        report = os.path.join(scratch, "r.json")
        done = subprocess.run([os.path.join(BIN, "blmd-ident")] + args + ["--report", report,
                              "--quiet", "--threads", "2"], capture_output=True, text=True)
        if not os.path.exists(report):
            return None, done.stderr.strip()
        with open(report) as f:
            return json.load(f), done.stderr.strip()


def next_flags(report):
    """The flags the report's warnings name as the next step (--error, --derive, --initial)."""
    flags = []
    for w in report.get("warnings", []):
        text = w["message"]
        if "--error equation" in text and "--error" not in flags:
            flags += ["--error", "equation"]
        if "(--derive w=theta)" in text and "--derive" not in flags:
            flags += ["--derive", "w=theta"]
        for m in re.finditer(r"--initial ([A-Za-z_]+)=([-0-9.e+]+)", text):
            flags += ["--initial", m.group(1) + "=" + m.group(2)]
    return flags


def line(name, step, report, truth):
    j = report["parameters"]["J"]
    low, high = j.get("ci95") or [float("nan"), float("nan")]
    covers = low <= truth <= high
    interval = f"[{low:.4g}, {high:.4g}]" if low == low else "none"
    added = (report.get("discovery") or {}).get("added", [])
    codes = sorted({w["code"] for w in report.get("warnings", [])})
    print(f"| {name} | {step} | {j['value']:.4g} | {interval} | {truth:.4g} | "
          f"{100 * (j['value'] / truth - 1):+.1f} % | {'yes' if covers else 'no'} | "
          f"{', '.join(added) or '-'} | {', '.join(codes) or '-'} |")
    return j["value"], covers


def main():
    print("| record | run | J | 95 % | independent | error | covers | added | warnings |")
    print("|---|---|---|---|---|---|---|---|---|")
    for record, truth, source in RECORDS:
        files = sorted(glob.glob(os.path.join(DATA, record)))
        args = ["--config", CONFIG] + [x for f in files for x in ("--trace", f)] + ["--discover"]
        report, err = run(args)
        flags = []
        if report is None:
            # An error's next step (a record of the angle alone: --observe theta) is followed
            # as a warning's would be.
            m = re.search(r"\((--observe [a-z]+)\)", err)
            if not m:
                print(f"| {record} | new user | no report ({err}) | | | | | | |")
                continue
            print(f"| {record} | new user | exit 2: names {m.group(1)} | | | | | | |")
            flags = m.group(1).split()
            report, err = run(args + flags)
            if report is None:
                print(f"| {record} | {' '.join(flags)} | no report ({err}) | | | | | | |")
                continue
            line(record, " ".join(flags), report, truth)
        else:
            line(record, "new user", report, truth)
        for _ in range(2):  # the next step of each run's warnings, in turn, at most twice
            used = list(zip(flags[::2], flags[1::2]))
            named = next_flags(report)
            step = [p for p in zip(named[::2], named[1::2]) if p not in used and
                    not (p[0] == "--initial" and p[1].split("=")[0] in
                         [v.split("=")[0] for f, v in used if f == "--initial"])]
            if not step:
                break
            flags += [x for p in step for x in p]
            report, err = run(args + flags)
            if report is None:
                print(f"| {record} | {' '.join(flags)} | no report ({err}) | | | | | | |")
                break
            line(record, " ".join(flags), report, truth)


if __name__ == "__main__":
    main()
