#!/usr/bin/env python3
"""The online J tracker (blmd-track, docs/export.md §7) on records from a simulator of our own:
a rigid shaft J dw/dt = Kt u - B w - Tc sgn(w) (20 Euler sub-steps per sample, the torque held
between samples), J 5e-4 .. 5e-3 kg m^2, B with J/B 0.05 .. 0.5 s, Tc 0 .. 10 % of the drive's
torque, a square torque of period 0.2 .. 1 s, 1 kHz, 8 s, white noise of 0.5 % of the speed's
RMS on w. The first 4 s are identified (blmd-ident: J, B, Tc free, as a user would before
going into operation); the tracker then runs over all 8 s, with J unchanged, or multiplied by
1.3 (a load added) or 0.8 (one removed) from t = 4 s on. Prints, per case: how often `changed`
was raised at any sample (false alarms where J is unchanged; detections otherwise), the delay
of the first flag after the change, the final J's error and how often its 95 % interval covers
the J in force at the end.

    tests/studies/tracker_study.py [RECORDS] [BUILD_DIR] [MEMORY]   # 40 records per case, 1 s
"""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ARGS = sys.argv[1:]
RECORDS = int(ARGS[0]) if ARGS else 40
BIN = os.path.join(ARGS[1] if len(ARGS) > 1 else os.path.join(ROOT, "build"), "bin")
MEMORY = ARGS[2] if len(ARGS) > 2 else "1"
TS, DURATION, KT, SUB = 1e-3, 8.0, 0.5, 20


def simulate(J, B, Tc, period, factor, rng):
    n = int(round(DURATION / TS)) + 1
    t = np.arange(n) * TS
    u = np.where((t % period) < period / 2, 1.0, -1.0)
    w = np.zeros(n)
    h = TS / SUB
    x = 0.0
    for k in range(n - 1):
        Jk = J * (factor if t[k] >= 4.0 else 1.0)
        for _ in range(SUB):
            friction = Tc * np.sign(x) if x != 0.0 else 0.0
            if x == 0.0 and abs(KT * u[k]) <= Tc:
                continue  # held by friction
            x += h * (KT * u[k] - B * x - friction) / Jk
        w[k + 1] = x
    w_noisy = w + rng.normal(0.0, 0.005 * np.sqrt(np.mean(w ** 2)), n)
    return t, u, w_noisy


def run(args):
    return subprocess.run(args, capture_output=True, text=True)


def case(seed, factor, work):
    rng = np.random.default_rng(seed)
    J = math.exp(rng.uniform(math.log(5e-4), math.log(5e-3)))
    B = J / rng.uniform(0.05, 0.5)
    Tc = rng.uniform(0.0, 0.1) * KT
    period = rng.uniform(0.2, 1.0)
    t, u, w = simulate(J, B, Tc, period, factor, rng)
    record = os.path.join(work, "record.csv")
    first = os.path.join(work, "first.csv")
    with open(record, "w") as out:
        out.write("t,u,w\n")
        out.writelines("%.17g,%.17g,%.17g\n" % row for row in zip(t, u, w))
    with open(first, "w") as out:
        out.write("t,u,w\n")
        out.writelines("%.17g,%.17g,%.17g\n" % row for row in zip(t, u, w) if row[0] <= 4.0)
    config = os.path.join(work, "config.json")
    with open(config, "w") as out:
        json.dump({"name": "drive", "model": "rigid_load",
                   "parameters": {"J": 2 * J, "B": 0.5 * B, "Kt": KT},
                   "effects": {"coulomb_friction": {"Tc": 0.01}},
                   "simulation": {"dt": 1e-4},
                   "identification": {"free": ["J", "B", "Tc"], "observe": ["w"]}}, out)
    report = os.path.join(work, "fit.json")
    fit = run([os.path.join(BIN, "blmd-ident"), "--config", config, "--trace", first, "--report",
               report, "--quiet"])
    if fit.returncode != 0:
        return None
    summary = os.path.join(work, "track.json")
    track = run([os.path.join(BIN, "blmd-track"), "--config", config, "--from-report", report,
                 "--trace", record, "--out", os.path.join(work, "track.csv"), "--report",
                 summary, "--memory", MEMORY, "--quiet"])
    if track.returncode != 0:
        raise RuntimeError(track.stderr)
    s = json.load(open(summary))
    truth = J * factor
    low, high = s["final"]["J_ci95"]
    return {"flagged": s["first_change_t"] is not None,
            "delay": (s["first_change_t"] - 4.0) if s["first_change_t"] is not None else None,
            "early": s["first_change_t"] is not None and s["first_change_t"] < 4.0,
            "error": s["final"]["J"] / truth - 1.0, "covers": low <= truth <= high}


def main():
    print("| J after 4 s | records | changed raised | raised before the change | median delay (s) "
          "| final J error, median abs (max) | final interval covers |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        for factor in (1.0, 1.3, 0.8):
            rows = [r for r in (case(seed, factor, work) for seed in range(RECORDS)) if r]
            flagged = sum(r["flagged"] for r in rows)
            early = sum(r["early"] for r in rows)
            delays = [r["delay"] for r in rows if r["delay"] is not None and r["delay"] >= 0]
            errors = [abs(r["error"]) for r in rows]
            print("| x%.1f | %d | %d/%d | %d/%d | %s | %.2f %% (%.2f %%) | %d/%d |" % (
                factor, len(rows), flagged, len(rows), early, len(rows),
                "%.2f" % float(np.median(delays)) if delays else "-",
                100 * float(np.median(errors)), 100 * max(errors),
                sum(r["covers"] for r in rows), len(rows)))


if __name__ == "__main__":
    main()
