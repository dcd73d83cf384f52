#!/usr/bin/env python3
"""Calibration of blmd-ident's verdicts (docs/identification.md §5, the warnings).

Two rates, measured through the real commands:
- false alarms: on exact-model traces (the model the config declares, no hidden effect) the
  report's `warnings` must be empty. Noise kinds: equal 1 % white noise on i and w; unequal
  white noise (10 % on i, 0.1 % on w, and the reverse); AR(1) noise with coefficient 0.95.
- detection: on traces with a hidden effect of the vocabulary (Coulomb friction, Stribeck
  friction, a load torque, quadratic drag, cogging, dead time, a current offset, a spring,
  gravity), at 6-15 % of the stall torque (voltage and current effects: 6-15 % of their
  scale), a plain fit must raise a model warning (model_inadequate, or nrmse_at_least_one /
  not_a_fit) and a fit with --discover must add an effect or warn.

Traces: configs/ganesh-square.json's DC servo (+-12 V square wave, 2 s at 2 kHz), simulated by
blmd-sim with the effect added (--effect) and noise (--noise, seeded); J and B fitted from
x1.5 and x0.7 of the truth. Every case's seed is fixed: the study is repeatable.

Usage: verdict_study.py BIN_DIR SOURCE_DIR OUT_DIR [--seeds N] [--kinds a,b] [--no-discover]
Exit 0 when the rates meet the bars (false alarms <= 5 %, detection >= 90 %), 1 otherwise;
the table is printed either way. STUDY_SEEDS in the environment overrides --seeds.
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys

# Stall torque of the Ganesh servo of configs/ganesh-square.json at 12 V: Kt * 12 / R.
KT, R = 0.04, 12.6
STALL = KT * 12.0 / R
W_PEAK = 255.0  # rad/s, its no-load speed at 12 V (12 / (Kt + R B / Kt))

NOISE_KINDS = {
    "white_equal": ["--noise", "i=1%", "--noise", "w=1%"],
    "white_noisy_i": ["--noise", "i=10%", "--noise", "w=0.1%"],
    "white_noisy_w": ["--noise", "i=0.1%", "--noise", "w=10%"],
}


def effect_spec(kind, rng):
    """The --effect text of a hidden effect of 6-15 % of its scale."""
    share = rng.uniform(0.06, 0.15)
    torque = share * STALL
    if kind == "coulomb_friction":
        return f"coulomb_friction:Tc={torque:.6g}"
    if kind == "stribeck":
        # Stribeck on top of a small Coulomb friction (the effect alone has no kinetic part).
        return f"stribeck:Ts={torque:.6g},ws={rng.uniform(5, 20):.6g}"
    if kind == "load_torque":
        return f"load_torque:TL={torque:.6g}"
    if kind == "quadratic_drag":
        return f"quadratic_drag:Cd={torque / (W_PEAK * W_PEAK):.6g}"
    if kind == "cogging":
        return f"cogging:Tcog={torque:.6g},periods={rng.choice([4, 6, 8, 12])},phase={rng.uniform(-3, 3):.4f}"
    if kind == "dead_time":
        return f"dead_time:Vdt={share * 12.0:.6g}"
    if kind == "current_offset":
        return f"current_offset:i0={share * 12.0 / R:.6g}"
    if kind == "spring":
        return f"spring:K={torque / 50.0:.6g},theta0={rng.uniform(-10, 10):.4f}"
    if kind == "gravity":
        return f"gravity:Tg={torque:.6g},phase={rng.uniform(-3, 3):.4f}"
    raise ValueError(kind)


EFFECTS = ["coulomb_friction", "stribeck", "load_torque", "quadratic_drag", "cogging",
           "dead_time", "current_offset", "spring", "gravity"]


def run(args):
    return subprocess.run(args, capture_output=True, text=True)


def ar1_trace(path, out_path, rho, rng, sigma_fraction=0.01):
    """Adds AR(1) noise of marginal sigma = sigma_fraction of each column's peak to i and w."""
    with open(path, encoding="utf-8") as f:
        lines = [l for l in f.read().splitlines() if l and not l.startswith("#")]
    header = lines[0].split(",")
    rows = [[float(x) for x in l.split(",")] for l in lines[1:]]
    for name in ("i", "w"):
        c = header.index(name)
        peak = max(abs(r[c]) for r in rows)
        state = rng.gauss(0, 1)
        for r in rows:
            r[c] += sigma_fraction * peak * state
            state = rho * state + math.sqrt(1 - rho * rho) * rng.gauss(0, 1)
    with open(out_path, "w", encoding="utf-8") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(repr(v) for v in r) + "\n")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("bin")
    p.add_argument("source")
    p.add_argument("out")
    p.add_argument("--seeds", type=int, default=6)
    p.add_argument("--kinds", default="")
    p.add_argument("--no-discover", action="store_true")
    a = p.parse_args()
    seeds = int(os.environ.get("STUDY_SEEDS", a.seeds))
    os.makedirs(a.out, exist_ok=True)
    sim, ident = os.path.join(a.bin, "blmd-sim"), os.path.join(a.bin, "blmd-ident")
    base = json.load(open(os.path.join(a.source, "configs/ganesh-square.json"), encoding="utf-8"))
    truth = dict(base["parameters"])
    config = json.loads(json.dumps(base))
    config.setdefault("identification", {})
    config["identification"]["initial"] = {"J": 1.5 * truth["J"], "B": 0.7 * truth["B"]}
    config_path = os.path.join(a.out, "config.json")
    with open(config_path, "w", encoding="utf-8") as f:
        json.dump(config, f, indent=1)
    kinds = a.kinds.split(",") if a.kinds else (list(NOISE_KINDS) + ["ar1_095"] + EFFECTS)
    table, ok = [], True
    for kind in kinds:
        false_alarms = detected = detected_discover = 0
        codes_seen = {}
        for seed in range(1, seeds + 1):
            rng = random.Random(f"{kind}-{seed}")
            trace = os.path.join(a.out, f"{kind}-{seed}.csv")
            cmd = [sim, "--config", config_path, "--out", trace, "--seed", str(seed), "--quiet"]
            if kind in NOISE_KINDS:
                cmd += NOISE_KINDS[kind]
            elif kind == "ar1_095":
                pass  # noise added below
            else:
                cmd += ["--effect", effect_spec(kind, rng), "--noise", "i=1%", "--noise", "w=1%"]
            r = run(cmd)
            if r.returncode != 0:
                print(f"{kind} {seed}: blmd-sim failed: {r.stderr.strip()}", file=sys.stderr)
                ok = False
                continue
            if kind == "ar1_095":
                clean = trace
                trace = os.path.join(a.out, f"{kind}-{seed}-noisy.csv")
                ar1_trace(clean, trace, 0.95, rng)
            r = run([ident, "--config", config_path, "--trace", trace, "--json", "--threads", "1"])
            try:
                report = json.loads(r.stdout)
            except ValueError:
                print(f"{kind} {seed}: no report (exit {r.returncode}): {r.stderr.strip()}",
                      file=sys.stderr)
                ok = False
                continue
            codes = [w["code"] for w in report.get("warnings", [])]
            for c in codes:
                codes_seen[c] = codes_seen.get(c, 0) + 1
            model_warning = any(c in ("model_inadequate", "nrmse_at_least_one", "not_a_fit")
                                for c in codes)
            if kind in NOISE_KINDS or kind == "ar1_095":
                false_alarms += bool(codes)
            else:
                detected += model_warning
                if not a.no_discover:
                    r = run([ident, "--config", config_path, "--trace", trace, "--discover",
                             "--json", "--threads", "1"])
                    try:
                        d = json.loads(r.stdout)
                        added = d.get("discovery", {}).get("added", [])
                        warned = bool(d.get("warnings"))
                        detected_discover += bool(added) or warned
                    except ValueError:
                        pass
        if kind in NOISE_KINDS or kind == "ar1_095":
            rate = false_alarms / seeds
            meets = rate <= 0.05
            table.append((kind, "exact model", f"warnings on {false_alarms}/{seeds}",
                          "ok" if meets else "FAIL", codes_seen))
        else:
            rate = detected / seeds
            meets = rate >= 0.90
            text = f"model warning on plain fit {detected}/{seeds}"
            if not a.no_discover:
                text += f"; --discover added an effect or warned {detected_discover}/{seeds}"
                meets = meets or detected_discover / seeds >= 0.90
            table.append((kind, "hidden effect", text, "ok" if meets else "FAIL", codes_seen))
        ok = ok and meets
    for row in table:
        print(f"[ measured ] {row[0]:16s} {row[1]:14s} {row[2]:70s} {row[3]}  codes {row[4]}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
