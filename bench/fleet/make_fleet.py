#!/usr/bin/env python3
"""A synthetic fleet for blmd-ident --batch and blmd.fleet.run (docs/fleet.md, "The fleet
study"): N drives of the three models with random J and B, two records each (a baseline night
and a current night), a share of drives whose J or B drifted between the nights, and a share of
current records written corrupt. Writes into OUT:

  configs/{dc,rigid,blmd}.json   one identification config per drive type (nominal J, B)
  traces/<drive>-{base,now}.csv  the records (blmd.simulate, noise on every observed column)
  baseline.csv, current.csv      the two nights' manifests
  truth.csv                      per drive: model, true J and B, drifted parameter and factor,
                                 the corruption written

Usage: make_fleet.py OUT [--drives 1000] [--seed 1] [--drift-share 0.05] [--corrupt-share 0.02]
Needs the package blmd on PYTHONPATH (build/python).
"""
import argparse
import copy
import csv
import json
import os
import random

import blmd

# The drive types: a config each, the nominal J and B, the noise on the observed columns
# (blmd.simulate's "P%" of each column's peak).
DC = {
    "name": "fleet-dc", "model": "dc_servo",
    "parameters": {"R": 2.0, "L": 0.0005, "Kt": 0.0369, "Kb": 0.0369, "J": 2.26e-5, "B": 2.26e-5},
    "simulation": {"dt": 1e-5},
    "experiment": {"input": {"type": "square", "amplitude": 6.0, "period": 0.2},
                   "duration": 0.4, "sample_rate": 2000},
    "identification": {"free": ["J", "B"], "observe": ["i", "w"],
                       "bounds": {"J": [5e-6, 1e-4], "B": [5e-6, 1e-4]}},
}
RIGID = {
    "name": "fleet-rigid", "model": "rigid_load",
    "parameters": {"J": 0.02, "B": 0.05, "Kt": 1.0},
    "simulation": {"dt": 1e-4},
    "experiment": {"input": {"type": "square", "amplitude": 0.5, "period": 2.0},
                   "duration": 4.0, "sample_rate": 500},
    "identification": {"free": ["J", "B"], "observe": ["w"],
                       "bounds": {"J": [0.005, 0.08], "B": [0.01, 0.2]}},
}
BLMD = None  # from configs/blmd-d31x-square.json, shortened (below)
NOISE = {"dc": {"i": "1%", "w": "1%"}, "rigid": {"w": "1%"}, "blmd": {"i": "1%", "w": "1%"}}


def blmd_config(root):
    with open(os.path.join(root, "configs", "blmd-d31x-square.json")) as f:
        c = json.load(f)
    c["name"] = "fleet-blmd"
    c.pop("notes", None)
    c.pop("description", None)
    c["simulation"] = {"method": "events"}
    c["experiment"]["duration"] = 0.16
    c["experiment"]["sample_rate"] = 5000
    c["identification"]["observe"] = ["i", "w"]
    return c


CORRUPTIONS = ["truncated", "text_cell", "no_w_column", "time_backwards", "empty", "binary"]


def write_trace(path, columns):
    names = list(columns)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for k in range(len(columns[names[0]])):
            w.writerow([repr(float(columns[n][k])) for n in names])


def corrupt(path, kind, rng):
    with open(path) as f:
        lines = f.read().splitlines()
    if kind == "truncated":  # a logger cut off mid-row
        text = "\n".join(lines[: len(lines) // 2]) + "\n" + lines[len(lines) // 2][:7]
    elif kind == "text_cell":  # in the observed speed column (text elsewhere is left out)
        k = rng.randrange(2, len(lines))
        cells = lines[k].split(",")
        cells[lines[0].split(",").index("w")] = "overflow"
        lines[k] = ",".join(cells)
        text = "\n".join(lines) + "\n"
    elif kind == "no_w_column":
        header = lines[0].split(",")
        keep = [j for j, n in enumerate(header) if n != "w"]
        text = "\n".join(",".join(line.split(",")[j] for j in keep) for line in lines) + "\n"
    elif kind == "time_backwards":
        k = rng.randrange(10, len(lines) - 10)
        lines[k], lines[k + 1] = lines[k + 1], lines[k]
        text = "\n".join(lines) + "\n"
    elif kind == "empty":
        text = ""
    else:  # binary
        text = "".join(chr(rng.randrange(1, 255)) for _ in range(2000))
    with open(path, "w", encoding="latin-1") as f:
        f.write(text)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--drives", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--drift-share", type=float, default=0.05)
    parser.add_argument("--corrupt-share", type=float, default=0.02)
    a = parser.parse_args()
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    types = {"dc": DC, "rigid": RIGID, "blmd": blmd_config(root)}
    os.makedirs(os.path.join(a.out, "configs"), exist_ok=True)
    os.makedirs(os.path.join(a.out, "traces"), exist_ok=True)
    for name, config in types.items():
        with open(os.path.join(a.out, "configs", name + ".json"), "w") as f:
            json.dump(config, f, indent=1)
    rng = random.Random(a.seed)
    drives = [f"d{k:04d}" for k in range(a.drives)]
    drifted = set(rng.sample(drives, round(a.drift_share * a.drives)))
    corrupted = set(rng.sample(drives, round(a.corrupt_share * a.drives)))
    # The model of each drive: the BLMD's records cost ten times the others' (its PWM).
    kinds = ["dc", "rigid", "dc", "rigid", "blmd"]
    truth_rows, base_rows, now_rows = [], [], []
    for k, drive in enumerate(drives):
        kind = kinds[k % len(kinds)]
        config = copy.deepcopy(types[kind])
        J0, B0 = config["parameters"]["J"], config["parameters"]["B"]
        J, B = J0 * rng.uniform(0.75, 1.25), B0 * rng.uniform(0.75, 1.25)
        param, factor = "", 1.0
        if drive in drifted:
            param = rng.choice(["J", "B"])
            factor = 1.0 + rng.choice([-1, 1]) * rng.uniform(0.10, 0.30)
        for night, scale in (("base", 1.0), ("now", factor)):
            c = copy.deepcopy(config)
            c["parameters"]["J"], c["parameters"]["B"] = J, B
            if night == "now" and param:
                c["parameters"][param] *= scale
            trace = blmd.simulate(c, noise=NOISE[kind], seed=rng.randrange(1, 2**31))
            path = os.path.join(a.out, "traces", f"{drive}-{night}.csv")
            write_trace(path, trace)
        kind_written = ""
        if drive in corrupted:
            kind_written = CORRUPTIONS[len(truth_rows) % len(CORRUPTIONS)]
            corrupt(os.path.join(a.out, "traces", f"{drive}-now.csv"), kind_written, rng)
        truth_rows.append([drive, kind, repr(J), repr(B), param, repr(factor), kind_written])
        base_rows.append([f"{drive}-base", f"traces/{drive}-base.csv", f"configs/{kind}.json",
                          "", drive, "2026-11-01"])
        now_rows.append([f"{drive}-now", f"traces/{drive}-now.csv", f"configs/{kind}.json", "",
                         drive, "2026-11-02"])
    header = ["id", "trace", "config", "baseline", "drive", "date"]
    for name, rows in (("baseline.csv", base_rows), ("current.csv", now_rows)):
        with open(os.path.join(a.out, name), "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(header)
            w.writerows(rows)
    with open(os.path.join(a.out, "truth.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["drive", "model", "J", "B", "drifted", "factor", "corrupt"])
        w.writerows(truth_rows)


if __name__ == "__main__":
    main()
