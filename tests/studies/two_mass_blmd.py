#!/usr/bin/env python3
"""Two-mass shafts behind the BLMD drive (two_mass on blmd, docs/model-blmd.md §10a): records
of the D31x-class drive of configs/blmd-d31x.json on random flexible shafts, made with
blmd-sim (the tool's own simulator: no independent PWM drive simulator exists here), fitted
from a rigid config as a new user would (J and B free from a start 2x off, --discover).

Each case: total inertia 5e-4 .. 2e-3 kg m^2, load/motor ratio 0.3 .. 3, anti-resonance
15 .. 80 Hz, shaft damping ratio 0.03 .. 0.08, load damping share 0 .. 0.5, B 2e-4 .. 1e-3;
a PRBS (clock 2 ms, a whole number of samples) or a chirp 2 .. 200 Hz of the torque demand,
0.6 s at 5 kHz, dt 2 us, white noise of 0.5 .. 2 % of w's RMS on w. Prints one line per
record and the counts: two_mass added, the resonance within 5 %, J within 2 %, the ratio
within 20 %, the 95 % intervals covering J, the ratio and f_a, and any warning.

    tests/studies/two_mass_blmd.py [CASES] [BUILD_DIR]   # default 6 cases, build/
"""
import json
import math
import os
import random
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CASES = int(sys.argv[1]) if len(sys.argv) > 1 else 6
BIN = os.path.join(sys.argv[2] if len(sys.argv) > 2 else
                   os.path.join(ROOT, os.environ.get("BUILD_DIR", "build")), "bin")
DRIVE = {"Ud": 310, "Rs": 1.0, "Ls": 0.004, "Ke": 0.3, "p": 3, "Kc": 1.1, "Kf": 0.5, "Kp": 8,
         "Ki": 16000, "Vtri": 10, "Tpwm": 2e-4, "delta": 2e-5}
SIMULATION = {"dt": 2e-6, "regula_falsi": True}


def run(args):
    done = subprocess.run(args, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(" ".join(args) + ": " + done.stderr.strip())


def covers(parameters, name, value):
    low, high = parameters[name]["ci95"]
    return low <= value <= high


def main():
    rng = random.Random(11)
    tally = {"added": 0, "fr": 0, "J": 0, "ratio": 0, "cover_J": 0, "cover_ratio": 0,
             "cover_fa": 0, "warned": 0}
    print("| case | input | ratio | fa | added | J error | fr error | ratio error | covers J, r, fa | warnings |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        for case in range(CASES):
            J = math.exp(rng.uniform(math.log(5e-4), math.log(2e-3)))
            B = math.exp(rng.uniform(math.log(2e-4), math.log(1e-3)))
            ratio = math.exp(rng.uniform(math.log(0.3), math.log(3.0)))
            fa = math.exp(rng.uniform(math.log(15.0), math.log(80.0)))
            zeta, share = rng.uniform(0.03, 0.08), rng.uniform(0.0, 0.5)
            noise = rng.uniform(0.5, 2.0)
            kind = "prbs" if case % 2 == 0 else "chirp"
            signal = ({"type": "prbs", "amplitude": 1.0, "clock": 0.002, "order": 8,
                       "seed": case + 1} if kind == "prbs" else
                      {"type": "chirp", "amplitude": 1.0, "f0": 2.0, "f1": 200.0})
            truth = {"name": "truth", "model": "blmd", "parameters": dict(DRIVE, J=J, B=B),
                     "effects": {"two_mass": {"inertia_ratio": ratio, "anti_resonance_hz": fa,
                                              "shaft_damping_ratio": zeta,
                                              "load_damping_share": share}},
                     "simulation": SIMULATION,
                     "experiment": {"input": signal, "duration": 0.6, "sample_rate": 5000}}
            rigid = {"name": "rigid", "model": "blmd", "parameters": dict(DRIVE, J=2 * J, B=2 * B),
                     "simulation": SIMULATION,
                     "experiment": {"input": {"type": "step", "amplitude": 1}, "duration": 0.1},
                     "identification": {"free": ["J", "B"], "observe": ["w"]}}
            paths = {name: os.path.join(folder, f"{name}{case}.json")
                     for name in ("truth", "rigid", "report")}
            for name, config in (("truth", truth), ("rigid", rigid)):
                with open(paths[name], "w") as out:
                    json.dump(config, out)
            trace = os.path.join(folder, f"trace{case}.csv")
            run([os.path.join(BIN, "blmd-sim"), "--config", paths["truth"], "--out", trace,
                 "--noise", f"w={noise:.3f}%", "--seed", str(case + 1), "--quiet"])
            run([os.path.join(BIN, "blmd-ident"), "--config", paths["rigid"], "--trace", trace,
                 "--discover", "--threads", "2", "--quiet", "--report", paths["report"]])
            with open(paths["report"]) as report_file:
                report = json.load(report_file)
            added = report["discovery"]["added"]
            warnings = [w["code"] for w in report["warnings"]]
            tally["warned"] += bool(warnings)
            row = [str(case), kind, f"{ratio:.2f}", f"{fa:.1f}", ",".join(added) or "-"]
            if "two_mass" in added:
                tally["added"] += 1
                p = report["parameters"]
                fr = fa * math.sqrt(1 + ratio)
                errors = {"J": p["J"]["value"] / J - 1,
                          "fr": report["derived"]["resonance_hz"]["value"] / fr - 1,
                          "ratio": p["inertia_ratio"]["value"] / ratio - 1}
                tally["J"] += abs(errors["J"]) <= 0.02
                tally["fr"] += abs(errors["fr"]) <= 0.05
                tally["ratio"] += abs(errors["ratio"]) <= 0.20
                cover = [covers(p, "J", J), covers(p, "inertia_ratio", ratio),
                         covers(p, "anti_resonance_hz", fa)]
                for name, ok in zip(("cover_J", "cover_ratio", "cover_fa"), cover):
                    tally[name] += ok
                row += [f"{100 * errors['J']:+.2f} %", f"{100 * errors['fr']:+.2f} %",
                        f"{100 * errors['ratio']:+.1f} %", "".join("y" if c else "n" for c in cover)]
            else:
                row += ["-", "-", "-", "-"]
            row.append(",".join(warnings) or "-")
            print("| " + " | ".join(row) + " |", flush=True)
    n = tally["added"]
    print(f"two_mass added on {n}/{CASES}; of those: fr within 5 % {tally['fr']}/{n}, J within 2 % "
          f"{tally['J']}/{n}, ratio within 20 % {tally['ratio']}/{n}; 95 % intervals cover J "
          f"{tally['cover_J']}/{n}, ratio {tally['cover_ratio']}/{n}, fa {tally['cover_fa']}/{n}; "
          f"a warning on {tally['warned']}/{CASES}")


if __name__ == "__main__":
    main()
