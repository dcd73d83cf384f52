#!/usr/bin/env python3
"""The cost of --discover per record (docs/fleet.md §9): blmd-ident --discover on one thread
on the bundled discovery cases (testdata/, docs/discovery.md) and on three real rigs, for two
builds run in turn case by case (so that both see the same load), with each run's decision
(the effects added) beside its time. Prints one JSON object: per case the wall times, the
effects each build added and whether they agree; the medians and their ratio.

Usage: discover_cost.py BIN_BEFORE BIN_AFTER [--repeat N] [--realdata DIR] [--only REGEX]
BIN_*: folders holding blmd-ident. The real rigs are skipped without their data.
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import tempfile
import time

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def cases(realdata):
    c = lambda *p: os.path.join(ROOT, *p)
    square = c("configs", "ganesh-square.json")
    out = [(name, ["--config", square, "--trace", c("testdata", f"{name}.csv")])
           for name in ["ganesh-square", "dc-hidden-coulomb", "dc-hidden-load",
                        "dc-hidden-dead-time", "dc-hidden-current-offset", "dc-hidden-stribeck",
                        "dc-hidden-cogging"]]
    out.append(("dc-hidden-drag", ["--config", c("configs", "ganesh-staircase.json"),
                                   "--trace", c("testdata", "dc-hidden-drag.csv")]))
    out.append(("dc-ambiguous-coulomb", ["--config", c("configs", "ganesh-running.json"),
                                         "--trace", c("testdata", "dc-ambiguous-coulomb.csv")]))
    blmd_square = c("configs", "blmd-d31x-square.json")
    for name in ["blmd-square", "blmd-hidden-load", "blmd-hidden-cogging"]:
        out.append((name, ["--config", blmd_square, "--trace", c("testdata", f"{name}.csv")]))
    if realdata and os.path.isdir(realdata):
        o = os.path.join(realdata, "odrive_cogging", "spinup_3_comp.csv")
        out.append(("odrive-spinup3", [
            "--config", c("configs", "real", "odrive.json"), "--trace", o, "--split", "run",
            "--select", "run=12:19", "--column", "t=t_s", "--column", "u=iq_A", "--scale",
            "u=0.0551329", "--column", "theta=theta_rad", "--derive", "w=theta",
            "--initial-state", "trace"]))
        d = os.path.join(realdata, "dev_dyno_spindown")
        out.append(("dyno-coastdown", [
            "--config", c("configs", "real", "dyno-coastdown.json"),
            "--trace", os.path.join(d, "motorUnplugged_spindown.csv"),
            "--column", "t=t_s", "--column", "u=current_A", "--scale", "u=0",
            "--column", "w=w_flywheel_radps", "--select", "t=60:", "--initial-state", "trace"]))
        h = os.path.join(realdata, "hslu_dcmotor_speed")
        out.append(("hslu-brake05", [
            "--config", c("configs", "real", "hslu.json"),
            "--trace", os.path.join(h, "openloop_step_5to15V_brake05.csv"),
            "--column", "t=t_s", "--column", "u=u_V", "--column", "w=w_radps",
            "--initial-state", "trace"]))
    return out


def run(binary, args, folder):
    report = os.path.join(folder, "r.json")
    start = time.perf_counter()
    done = subprocess.run([os.path.join(binary, "blmd-ident"), *args, "--discover",
                           "--threads", "1", "--quiet", "--no-progress", "--report", report],
                          capture_output=True, text=True)
    seconds = time.perf_counter() - start
    added = None
    if os.path.exists(report):
        with open(report) as f:
            r = json.load(f)
        added = (r.get("discovery") or {}).get("added", [])
        os.remove(report)
    return seconds, done.returncode, added


def main():
    p = argparse.ArgumentParser()
    p.add_argument("before")
    p.add_argument("after")
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--realdata", default=os.path.join(ROOT, "..", "shared", "realdata"))
    p.add_argument("--only", default=".")
    a = p.parse_args()
    result = {"cases": {}}
    with tempfile.TemporaryDirectory() as folder:
        for name, args in cases(a.realdata):
            if not re.search(a.only, name):
                continue
            entry = {"before_s": [], "after_s": []}
            for _ in range(a.repeat):
                for which, binary in (("before", a.before), ("after", a.after)):
                    seconds, code, added = run(binary, args, folder)
                    entry[which + "_s"].append(round(seconds, 3))
                    entry[which + "_exit"] = code
                    entry[which + "_added"] = added
            entry["same_decision"] = entry["before_added"] == entry["after_added"]
            entry["ratio"] = round(statistics.median(entry["before_s"]) /
                                   statistics.median(entry["after_s"]), 2)
            result["cases"][name] = entry
            print(name, entry, flush=True, file=__import__("sys").stderr)
    before = [statistics.median(e["before_s"]) for e in result["cases"].values()]
    after = [statistics.median(e["after_s"]) for e in result["cases"].values()]
    result["median_before_s"] = statistics.median(before)
    result["median_after_s"] = statistics.median(after)
    result["median_ratio"] = round(result["median_before_s"] / result["median_after_s"], 2)
    result["same_decisions"] = sum(e["same_decision"] for e in result["cases"].values())
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
