#!/usr/bin/env python3
"""two_mass on dc_servo (docs/effects.md): DC servos driving a load through a flexible shaft,
from a simulator of our own, fitted with a dc_servo config (R, L, Kt, Kb at the motor's
values, J and B free: the Ganesh workflow) with --discover. Each case: R 1 .. 13 ohm, the
armature's L/R 1 .. 20 ms, Kt = Kb 0.02 .. 0.1, total inertia 1e-5 .. 1e-4 kg m^2, load/motor
inertia ratio 0.3 .. 3, anti-resonance 15 .. 100 Hz, shaft damping ratio 0.03, viscous
damping on both sides, a voltage input (PRBS, chirp or square wave, tests/studies/two_mass.py),
current and motor speed measured with white noise of 0.5 .. 2 % of their RMS, 2 kHz for 4 s.
The simulation is exact for a held voltage (the zero-order-hold matrix exponential of)

    L di/dt     = u - R i - Kb wm
    Jm dwm/dt   = Kt i - K (thm - thl) - c (wm - wl) - bm wm
    Jl dwl/dt   =        K (thm - thl) + c (wm - wl) - bl wl

The controls are rigid shafts (J = Jm + Jl, B = bm + bl) with the same inputs, under white and
AR(1) 0.95 noise. Prints one line per record and the counts: two_mass added, the resonance f_r
within 5 %, J within 2 %, the ratio within 20 %, the 95 % intervals of J, the ratio, f_a and f_r
covering the truth; for the controls, any effect added.

    tests/studies/two_mass_dc_servo.py [CASES] [BUILD_DIR]   # default 20 cases of each group
"""
import json
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import two_mass  # noqa: E402  (expm, simulate, the inputs, the report's figures)

ARGS = sys.argv[1:]
CASES = int(ARGS[0]) if ARGS else 20
BIN = os.path.join(ARGS[1] if len(ARGS) > 1 else os.path.join(two_mass.ROOT, "build"), "bin")
RATE, DURATION = two_mass.RATE, two_mass.DURATION


def record(seed, rigid, ar):
    rng = np.random.default_rng(seed)
    kind = ["prbs", "chirp", "square"][seed % 3]
    R = rng.uniform(1.0, 13.0)
    L = R * math.exp(rng.uniform(math.log(1e-3), math.log(2e-2)))
    Kt = rng.uniform(0.02, 0.1)
    J = math.exp(rng.uniform(math.log(1e-5), math.log(1e-4)))
    ratio = rng.uniform(0.3, 3.0)
    fa = math.exp(rng.uniform(math.log(15.0), math.log(100.0)))
    Jm, Jl = J / (1 + ratio), J * ratio / (1 + ratio)
    K = Jl * (2 * math.pi * fa) ** 2
    c = 2 * 0.03 * math.sqrt(K * Jl)
    bm, bl = [J * rng.uniform(0.05, 0.5) for _ in range(2)]
    n = int(DURATION * RATE)
    u = two_mass.input_signal(kind, rng, n, 6.0)
    dt = 1.0 / RATE
    if rigid:  # x = [i, w, theta]
        a = np.array([[-R / L, -Kt / L, 0.0],
                      [Kt / J, -(bm + bl) / J, 0.0],
                      [0.0, 1.0, 0.0]])
        b = np.array([1.0 / L, 0.0, 0.0])
    else:  # x = [i, wm, thm, wl, thl]
        a = np.array([[-R / L, -Kt / L, 0, 0, 0],
                      [Kt / Jm, -(c + bm) / Jm, -K / Jm, c / Jm, K / Jm],
                      [0, 1, 0, 0, 0],
                      [0, c / Jl, K / Jl, -(c + bl) / Jl, -K / Jl],
                      [0, 0, 0, 1, 0]], dtype=float)
        b = np.array([1.0 / L, 0.0, 0.0, 0.0, 0.0])
    x = two_mass.simulate(a, b, u, dt)
    i, w = x[:, 0], x[:, 1]
    columns = []
    for y in (i, w):
        level = rng.uniform(0.005, 0.02) * math.sqrt(np.mean(y ** 2))
        noise = rng.normal(0.0, 1.0, n)
        if ar:
            for k in range(1, n):
                noise[k] = 0.95 * noise[k - 1] + math.sqrt(1 - 0.95 ** 2) * noise[k]
        columns.append(y + level * noise)
    truth = {"kind": kind, "R": R, "L": L, "Kt": Kt, "J": J, "B": bm + bl, "ratio": ratio,
             "fa": fa, "fr": fa * math.sqrt(1 + ratio)}
    return np.column_stack([np.arange(n) * dt, u, columns[0], columns[1]]), truth


def fit(data, truth, scratch):
    trace = os.path.join(scratch, "trace.csv")
    np.savetxt(trace, data, delimiter=",", header="t,u,i,w", comments="", fmt="%.10g")
    config = os.path.join(scratch, "config.json")
    with open(config, "w") as f:
        json.dump({"name": "dc servo", "model": "dc_servo",
                   "parameters": {"R": truth["R"], "L": truth["L"], "Kt": truth["Kt"],
                                  "Kb": truth["Kt"], "J": 2e-5, "B": 2e-5},
                   "simulation": {"dt": 1.0 / RATE},
                   "identification": {"free": ["J", "B"], "observe": ["i", "w"]}}, f)
    report = os.path.join(scratch, "r.json")
    if os.path.exists(report):
        os.remove(report)
    subprocess.run([os.path.join(BIN, "blmd-ident"), "--config", config, "--trace", trace,
                    "--quiet", "--threads", "2", "--discover", "--report", report],
                   capture_output=True, text=True)
    if not os.path.exists(report):
        return None
    with open(report) as f:
        return json.load(f)


def main():
    groups = [("two-mass", False, False), ("rigid, white", True, False),
              ("rigid, AR(1) 0.95", True, True)]
    print("| group | seed | input | L/R ms | ratio | f_a Hz | f_r Hz | J error | effects | "
          "f_r error | ratio error | warnings |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for name, rigid, ar in groups:
            total = any_effect = 0
            tally = two_mass.TwoMassTally()
            for seed in range(CASES):
                data, truth = record(2000 + seed, rigid, ar)
                report = fit(data, truth, scratch)
                total += 1
                if report is None:
                    print(f"| {name} | {seed} | {truth['kind']} | failed |")
                    continue
                codes = sorted({w["code"] for w in report.get("warnings", [])})
                effects = report.get("effects", [])
                any_effect += bool(effects)
                fr_text, ratio_text = tally.add(two_mass.two_mass_figures(report, truth))
                j = report["parameters"]["J"]["value"]
                print(f"| {name} | {seed} | {truth['kind']} | {1e3 * truth['L'] / truth['R']:.1f} | "
                      f"{truth['ratio']:.2f} | {truth['fa']:.1f} | {truth['fr']:.1f} | "
                      f"{100 * (j / truth['J'] - 1):+.2f} % | {', '.join(effects) or '-'} | "
                      f"{fr_text} | {ratio_text} | {', '.join(codes) or '-'} |", flush=True)
            print(f"{name}: two_mass added on {tally.added}/{total}, any effect on "
                  f"{any_effect}/{total}", flush=True)
            tally.print_summary(name)


if __name__ == "__main__":
    main()
