#!/usr/bin/env python3
"""Records with standstill and a quantised encoder (docs/real-data.md, "Standstill, encoders
and loops: a simulator study"). Each case is a random rigid shaft (J 1e-4 .. 5e-3 kg m^2,
B such that the mechanical time constant J/B is 0.3 .. 3 s) with no friction, Coulomb friction
or Coulomb + Stribeck friction (10 .. 25 % of the drive's torque), driven either open loop
(torque steps with 0.8 s pauses, which friction holds) or by the drive's position loop (P
over a speed PI, position steps with holds between them), 1 kHz for 8 s. The angle is
quantised to an encoder of 2 000 .. 20 000 counts per turn and the speed derived from it
(--derive w=theta); the recorded torque gets white noise of 0.5 % of its peak. It is fitted as
a user would: J and B free from a start 3x off, --discover, and, where the report says the
record is closed loop, the equation error its warning advises.

Counts, per friction kind and loop: friction added when present, nothing added when absent,
spring or gravity added (never right: the rotor is free), and J within 3 %.

    tests/studies/standstill_study.py [CASES] [BUILD_DIR]      # default 24 cases, build/
"""
import json
import math
import os
import random
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CASES = int(sys.argv[1]) if len(sys.argv) > 1 else 24
BIN = os.path.join(sys.argv[2] if len(sys.argv) > 2 else
                   os.path.join(ROOT, os.environ.get("BUILD_DIR", "build")), "bin")


def ident(config, trace, extra, scratch):
    report = os.path.join(scratch, "r.json")
    if os.path.exists(report):
        os.remove(report)
    subprocess.run([os.path.join(BIN, "blmd-ident"), "--config", config, "--trace", trace,
                    "--derive", "w=theta", "--discover", "--quiet", "--threads", "2",
                    "--report", report] + extra, capture_output=True, text=True)
    if not os.path.exists(report):
        return None
    with open(report) as f:
        return json.load(f)


def case(seed, scratch):
    rng = random.Random(seed)
    J = 10 ** rng.uniform(-4, math.log10(5e-3))
    B = J / rng.uniform(0.3, 3.0)
    friction = ["none", "coulomb", "stribeck"][seed % 3]
    closed = (seed // 3) % 2 == 1
    counts = rng.choice([2000, 5000, 10000, 20000])
    T = 0.5 * J * 200.0  # the drive's torque: 200 rad/s^2 on the shaft alone
    effects = {}
    if friction != "none":
        effects["coulomb_friction"] = {"Tc": rng.uniform(0.10, 0.25) * T}
    if friction == "stribeck":
        effects["stribeck"] = {"Ts": 0.5 * effects["coulomb_friction"]["Tc"], "ws": rng.uniform(0.5, 2.0)}
    if closed:
        experiment = {"input": {"type": "steps", "times": [0.2, 2.2, 4.2, 6.2],
                                "values": [6.0, 1.0, -5.0, 0.0]},
                      "pid": {"loop": "position", "Kp": 15.0, "speed_Kp": 40.0 * J,
                              "speed_Ki": 400.0 * J, "u_max": 4.0 * T, "sample_rate": 1000},
                      "duration": 8.0, "sample_rate": 1000}
    else:
        experiment = {"input": {"type": "steps", "times": [0.2, 1.0, 1.8, 2.6, 3.4, 4.2, 5.0, 5.8],
                                "values": [T, 0.0, -T, 0.0, 0.6 * T, 0.0, -0.6 * T, 0.0]},
                      "duration": 8.0, "sample_rate": 1000}
    truth = {"name": "truth", "model": "rigid_load", "parameters": {"J": J, "B": B, "Kt": 1.0},
             "simulation": {"dt": 1e-4}, "experiment": experiment}
    if effects:
        truth["effects"] = effects
    truth_path = os.path.join(scratch, "truth.json")
    with open(truth_path, "w") as f:
        json.dump(truth, f)
    raw = os.path.join(scratch, "raw.csv")
    done = subprocess.run([os.path.join(BIN, "blmd-sim"), "--config", truth_path, "--out", raw,
                           "--quiet"], capture_output=True, text=True)
    if done.returncode != 0:
        return None, done.stderr
    rows = [line.strip().split(",") for line in open(raw) if not line.startswith("#")]
    header, rows = rows[0], rows[1:]
    col = {name: k for k, name in enumerate(header)}
    q = 2.0 * math.pi / counts
    peak = max(abs(float(r[col["u"]])) for r in rows) or 1.0
    trace = os.path.join(scratch, "trace.csv")
    with open(trace, "w") as f:
        f.write("t,u,theta\n")
        for r in rows:
            theta = q * round(float(r[col["theta"]]) / q)
            u = float(r[col["u"]]) + rng.gauss(0.0, 0.005 * peak)
            f.write(f"{r[col['t']]},{u:.9g},{theta:.12g}\n")
    model = {"name": "fit", "model": "rigid_load",
             "parameters": {"J": 3.0 * J, "B": B / 3.0, "Kt": 1.0},
             "simulation": {"dt": 1e-4}, "experiment": {"duration": 8.0, "sample_rate": 1000},
             "identification": {"free": ["J", "B"], "observe": ["w"]}}
    config = os.path.join(scratch, "fit.json")
    with open(config, "w") as f:
        json.dump(model, f)
    report = ident(config, trace, [], scratch)
    steps = "output error"
    if report and any("--error equation" in w["message"] for w in report.get("warnings", [])):
        report = ident(config, trace, ["--error", "equation"], scratch)
        steps = "equation error (advised)"
    if report is None:
        return None, "no report"
    added = (report.get("discovery") or {}).get("added", [])
    j = report["parameters"]["J"]["value"]
    return {"seed": seed, "friction": friction, "closed": closed, "counts": counts, "J": J,
            "J_fit": j, "J_error": j / J - 1.0, "added": added, "steps": steps,
            "closed_loop_said": bool((report.get("residual") or {}).get("closed_loop"))}, ""


def main():
    results = []
    with tempfile.TemporaryDirectory() as scratch:
        for seed in range(1, CASES + 1):
            r, why = case(seed, scratch)
            if r is None:
                print(f"case {seed}: failed ({why.strip()[:200]})")
                continue
            results.append(r)
            print(f"case {seed:3d} {r['friction']:8s} {'closed' if r['closed'] else 'open  '} "
                  f"{r['counts']:5d} counts: J {r['J_error'] * 100:+6.2f} %, added "
                  f"{','.join(r['added']) or '-'} ({r['steps']})", flush=True)
    friction = [r for r in results if r["friction"] != "none"]
    none = [r for r in results if r["friction"] == "none"]
    found = sum(1 for r in friction if any(e in ("coulomb_friction", "stribeck") for e in r["added"]))
    clean = sum(1 for r in none if not r["added"])
    invented = sum(1 for r in results if any(e in ("spring", "gravity") for e in r["added"]))
    within = sum(1 for r in results if abs(r["J_error"]) <= 0.03)
    print(f"friction present, added: {found}/{len(friction)}")
    print(f"none present, nothing added: {clean}/{len(none)}")
    print(f"spring or gravity added on the free rotor: {invented}/{len(results)}")
    print(f"J within 3 %: {within}/{len(results)}")
    for loop in (False, True):
        sel = [r for r in results if r["closed"] == loop]
        print(f"  {'closed' if loop else 'open'} loop: J within 3 % {sum(1 for r in sel if abs(r['J_error']) <= 0.03)}/{len(sel)}")


if __name__ == "__main__":
    main()
