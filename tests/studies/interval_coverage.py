#!/usr/bin/env python3
"""Coverage of the 95 % intervals of J and B on records made by a simulator that is not the
tool's own (docs/uncertainty.md §3, "Against an independent simulator").

The records: DC servos around the Ganesh et al. (2012) no-load motor (R, L, Kt, Kb as in
configs/ganesh-square.json; J 0.6-3x and B 0.5-3x the paper's values, drawn uniformly), driven
by a +-12 V square wave of 1 s period for 2 s at 2 kHz. The simulator here is the exact
zero-order-hold discretisation of the linear model (the matrix exponential of the augmented
state matrix, by scaling and squaring), written in numpy and sharing no code with blmd-sim.
Noise of 0.5 % of each column's peak is added to i and w, white or AR(1) with coefficient
0.95 (stationary, same variance). Each record is fitted as a user would: blmd-ident with the
config's defaults (Ceres, noise weighting), J and B free from the paper's values.

Prints, per noise kind, how many of the 95 % intervals cover the truth, the mean and RMS of
the standardised error (value - truth) / std, and exits 1 when a coverage lies outside
93-97 %.

    tests/studies/interval_coverage.py [RECORDS] [BUILD_DIR]     # default 600 of each kind
"""
import json
import math
import os
import random
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RECORDS = int(sys.argv[1]) if len(sys.argv) > 1 else 600
BIN = os.path.join(sys.argv[2] if len(sys.argv) > 2 else
                   os.path.join(ROOT, os.environ.get("BUILD_DIR", "build")), "bin")
FS, DURATION, AMPLITUDE, PERIOD, NOISE = 2000.0, 2.0, 12.0, 1.0, 0.005


def expm(a):
    """exp(a) by scaling and squaring of a 24-term Taylor series (a is 4x4 and well scaled)."""
    norm = np.linalg.norm(a, 1)
    s = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0 else 0
    scaled = a / 2.0 ** s
    result = np.eye(len(a))
    term = np.eye(len(a))
    for k in range(1, 25):
        term = term @ scaled / k
        result = result + term
    for _ in range(s):
        result = result @ result
    return result


def simulate(p):
    """i, w, theta of L di/dt = u - R i - Kb w, J dw/dt = Kt i - B w, u held between samples."""
    a = np.array([[-p["R"] / p["L"], -p["Kb"] / p["L"], 0.0],
                  [p["Kt"] / p["J"], -p["B"] / p["J"], 0.0],
                  [0.0, 1.0, 0.0]])
    m = np.zeros((4, 4))
    m[:3, :3] = a
    m[0, 3] = 1.0 / p["L"]
    step = expm(m / FS)
    ad, bd = step[:3, :3], step[:3, 3]
    n = int(round(DURATION * FS)) + 1
    t = np.arange(n) / FS
    u = np.where((t % PERIOD) < PERIOD / 2 - 1e-12, AMPLITUDE, -AMPLITUDE)
    x = np.zeros(3)
    states = np.zeros((n, 3))
    for k in range(n):
        states[k] = x
        x = ad @ x + bd * u[k]
    return t, u, states


def record(seed, rho, scratch):
    rng = random.Random(seed * 7919 + int(rho * 100))
    config = json.load(open(os.path.join(ROOT, "configs", "ganesh-square.json")))
    nominal = dict(config["parameters"])
    truth = dict(nominal, J=nominal["J"] * rng.uniform(0.6, 3.0),
                 B=nominal["B"] * rng.uniform(0.5, 3.0))
    config["parameters"] = truth
    config["identification"]["initial"] = {"J": nominal["J"], "B": nominal["B"]}
    t, u, states = simulate(truth)
    columns = {"t": t, "u": u, "i": states[:, 0].copy(), "w": states[:, 1].copy(),
               "theta": states[:, 2]}
    for name in ("i", "w"):
        sigma = NOISE * np.abs(columns[name]).max()
        e = rng.gauss(0.0, sigma)
        for k in range(len(t)):
            columns[name][k] += e
            e = rho * e + math.sqrt(1.0 - rho * rho) * rng.gauss(0.0, sigma)
    config_path = os.path.join(scratch, "config.json")
    trace_path = os.path.join(scratch, "trace.csv")
    report_path = os.path.join(scratch, "report.json")
    with open(config_path, "w") as f:
        json.dump(config, f)
    np.savetxt(trace_path, np.column_stack([columns[k] for k in ("t", "u", "i", "w", "theta")]),
               delimiter=",", header="t,u,i,w,theta", comments="", fmt="%.12g")
    if os.path.exists(report_path):
        os.remove(report_path)
    subprocess.run([os.path.join(BIN, "blmd-ident"), "--config", config_path, "--trace",
                    trace_path, "--report", report_path, "--quiet"], capture_output=True)
    with open(report_path) as f:
        report = json.load(f)
    out = {}
    for name in ("J", "B"):
        p = report["parameters"][name]
        out[name] = (p["ci95"][0] <= truth[name] <= p["ci95"][1],
                     (p["value"] - truth[name]) / p["std"])
    return out


def main():
    ok = True
    print("| noise | parameter | covered | coverage | mean z | RMS z |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for rho, label in ((0.0, "white"), (0.95, "AR(1) 0.95")):
            results = [record(seed, rho, scratch) for seed in range(1, RECORDS + 1)]
            for name in ("J", "B"):
                covered = sum(r[name][0] for r in results)
                z = np.array([r[name][1] for r in results])
                share = covered / len(results)
                ok = ok and 0.93 <= share <= 0.97
                print("| %s | %s | %d/%d | %.1f %% | %+.2f | %.2f |" % (
                    label, name, covered, len(results), 100 * share, z.mean(),
                    math.sqrt((z * z).mean())))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
