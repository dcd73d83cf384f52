#!/usr/bin/env python3
"""Identification from the reference (docs/identification.md §9b) on closed-loop records from a
simulator of our own: a rigid shaft J dw/dt = u - B w (exact zero-order hold) under a digital
speed PI at 1 kHz with one sample of delay, conditional integration and a torque limit, fed
back the MEASURED (noisy) speed, so that the noise enters the command as on a real drive. Each
record: J 1e-3 .. 4e-3 kg m^2, B 0.01 .. 0.05 N m s/rad, the PI placed near 20 Hz
(kp = 2 pi 20 J0, ki = 2 pi 4 kp, J0 the nominal 2e-3), a square speed reference of 4 s
(period 1 s), noise 1 .. 5 % of the speed's RMS, white or AR(1) 0.95; the limit reached
(u_max 2 N m, a 60 rad/s reference) or not (u_max 50, 20 rad/s). Each record is fitted twice
with J and B free: from its reference (t, r, w: --simulate-from reference, the config holding the
controller) and directly from its command (t, u, w: the command replayed open loop). Prints
per case the bias of J and B in standard errors (mean of (estimate - truth)/its standard
error), the share of 95 % intervals covering the truth, and the spread (standard deviation of
the relative error) of each approach.

    tests/studies/reference_input.py [RECORDS] [BUILD_DIR]   # default 40 records per case
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
TS, DURATION, J0 = 1e-3, 4.0, 2e-3
KP = 2 * math.pi * 20 * J0
KI = 2 * math.pi * 4 * KP


def record(seed, ar, saturating):
    rng = np.random.default_rng(seed)
    J, B = rng.uniform(1e-3, 4e-3), rng.uniform(0.01, 0.05)
    u_max, level = (2.0, 60.0) if saturating else (50.0, 20.0)
    n = int(DURATION / TS) + 1
    t = np.arange(n) * TS
    r = level * np.where((t % 1.0) < 0.5, 1.0, -1.0)
    a = math.exp(-B / J * TS)
    g = (1 - a) / B  # the held torque's gain over a step
    noise = rng.normal(0.0, 1.0, n)
    if ar:
        for k in range(1, n):
            noise[k] = 0.95 * noise[k - 1] + math.sqrt(1 - 0.95 ** 2) * noise[k]
    sigma = rng.uniform(0.01, 0.05) * level / math.sqrt(2)
    w = np.zeros(n)
    w_meas = np.zeros(n)
    u = np.zeros(n)
    integral, pending = 0.0, 0.0
    for k in range(n):
        w_meas[k] = w[k] + sigma * noise[k]
        # the drive: the command computed from this sample takes effect one sample later
        e = r[k] - w_meas[k]
        candidate = integral + KI * TS * e
        v = KP * e + candidate
        if not ((v > u_max and e > 0) or (v < -u_max and e < 0)):
            integral = candidate
        command = min(max(KP * e + integral, -u_max), u_max)
        u[k] = pending
        pending = command
        if k + 1 < n:
            w[k + 1] = a * w[k] + g * u[k]
    return {"J": J, "B": B, "u_max": u_max, "t": t, "r": r, "u": u, "w": w_meas}


def fit(rec, scratch, reference):
    config = {"name": "loop", "model": "rigid_load",
              "parameters": {"J": J0, "B": 0.03, "Kt": 1.0},
              "simulation": {"dt": TS},
              "experiment": {"pid": {"loop": "speed", "Kp": KP, "Ki": KI, "u_max": rec["u_max"],
                                     "sample_rate": 1.0 / TS, "delay": 1}},
              "identification": {"free": ["J", "B"], "observe": ["w"]}}
    path = os.path.join(scratch, "config.json")
    with open(path, "w") as f:
        json.dump(config, f)
    trace = os.path.join(scratch, "trace.csv")
    columns = ["t", "r", "w"] if reference else ["t", "u", "w"]
    np.savetxt(trace, np.column_stack([rec[c] for c in columns]), delimiter=",",
               header=",".join(columns), comments="", fmt="%.12g")
    report = os.path.join(scratch, "report.json")
    args = [os.path.join(BIN, "blmd-ident"), "--config", path, "--trace", trace, "--quiet",
            "--threads", "1", "--report", report]
    if reference:
        args += ["--simulate-from", "reference"]
    done = subprocess.run(args, capture_output=True, text=True)
    if done.returncode != 0:
        return None
    with open(report) as f:
        r = json.load(f)
    return r["parameters"], {w["code"] for w in r.get("warnings", [])}


def main():
    print("| case | approach | records | J bias (SE) | J covered | J spread | B bias (SE) | "
          "B covered | B spread | reference_saturated |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for ar in (False, True):
            for saturating in (False, True):
                case = f"{'AR(1) 0.95' if ar else 'white'}, limit {'reached' if saturating else 'not reached'}"
                results = {True: [], False: []}
                for k in range(RECORDS):
                    rec = record(5000 + k + (1000 if ar else 0) + (2000 if saturating else 0),
                                 ar, saturating)
                    for reference in (True, False):
                        fitted = fit(rec, scratch, reference)
                        if fitted is None:
                            continue
                        p, codes = fitted
                        row = {"saturated": "reference_saturated" in codes}
                        for name in ("J", "B"):
                            truth = rec[name]
                            lo, hi = p[name]["ci95"]
                            row[name] = ((p[name]["value"] - truth) / p[name]["std"],
                                         lo <= truth <= hi, p[name]["value"] / truth - 1)
                        results[reference].append(row)
                for reference in (True, False):
                    rows = results[reference]
                    cells = []
                    for name in ("J", "B"):
                        z = [r[name][0] for r in rows]
                        cov = sum(r[name][1] for r in rows)
                        rel = [r[name][2] for r in rows]
                        cells += [f"{np.mean(z):+.2f}", f"{cov}/{len(rows)}",
                                  f"{100 * np.std(rel):.3f} %"]
                    warned = sum(r["saturated"] for r in rows)
                    print(f"| {case} | {'reference' if reference else 'command (direct)'} | "
                          f"{len(rows)}/{RECORDS} | " + " | ".join(cells) + f" | {warned} |",
                          flush=True)


if __name__ == "__main__":
    main()
