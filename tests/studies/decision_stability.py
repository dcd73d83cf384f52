#!/usr/bin/env python3
"""Decision stability of the committed real-rig commands (docs/real-data.md, "Stable decisions").

Every blmd-ident command of docs/real-data.md that writes a report under docs/real-data/ is run
once on the data as recorded and RUNS times on copies whose measured columns (those the command
maps to u, w, theta, i or open) are scaled by 1 + REL*z, z standard normal (seeded per run):
a change far below any sensor's noise. Per command it prints the effects added, how many of the
perturbed runs added the same, whether every differing run's report marks the decision
(discovery.unstable or discovery.ambiguous), and the largest relative change of the headline
J and B. Exit 1 when a perturbed run adds other effects without marking the decision.

The decision that differs is the first round at which the two runs add different effects
(what is added after it is a consequence: a Stribeck friction chosen in round 1 leaves no
room for the Coulomb friction the other run adds in round 2). A differing run counts as
marked when either report marks one of the two effects chosen in that round, or when every
effect in which the two sets differ is marked.

With --variant K=V (repeatable) it instead runs each command on the data as recorded under
each environment variant (e.g. BLMD_BATCH_ISA=baseline) and prints whether the effects added
are the same, the largest relative difference of every fitted parameter's value and of its
95 % interval's end points (relative to the larger of the end point and the value), and any
parameter whose interval comes from another method; a
variant bin=DIR runs DIR/blmd-ident instead (another build, e.g. with other compiler flags).
With --show-differing each perturbed run that adds other effects is listed on stderr; with
--show-values every perturbed run's J and B.

Usage: decision_stability.py [--runs N] [--rel R] [--filter REGEX] [--bin DIR] [--env K=V]
                             [--variant K=V ...] [--show-differing] [--show-values]
(run from the repository root; the data from ../shared/realdata or $BLMD_REALDATA)
"""
import argparse
import csv
import json
import os
import random
import re
import shlex
import subprocess
import sys
import tempfile

MAPPED = {"u", "w", "theta", "i", "open"}


def commands(page, data):
    """(report name, argv list) of every blmd-ident call with --report docs/real-data/."""
    out = []
    for block in re.findall(r"```sh\n(.*?)```", page, flags=re.S):
        if "--report docs/real-data/" not in block:
            continue
        script = block.replace("../shared/realdata", data)
        script = script.replace("build/bin/blmd-ident", "echo BLMD_IDENT")
        lines = subprocess.run(["bash", "-c", script], capture_output=True, text=True,
                               check=True).stdout.splitlines()
        for line in lines:
            if not line.startswith("BLMD_IDENT "):
                continue
            argv = shlex.split(line)[1:]
            report = argv[argv.index("--report") + 1]
            out.append((os.path.basename(report)[:-5], argv))
    return out


def mapped_headers(argv):
    """The CSV headers the command reads as measured columns."""
    headers = set(MAPPED)
    for k, a in enumerate(argv):
        if a == "--column" and k + 1 < len(argv):
            name, _, header = argv[k + 1].partition("=")
            if name in MAPPED:
                headers.add(header)
    return headers


def perturb(path, headers, rel, rng, out_dir):
    target = os.path.join(out_dir, os.path.basename(path))
    with open(path, newline="", encoding="utf-8") as src, \
            open(target, "w", newline="", encoding="utf-8") as dst:
        header = None
        for line in src:
            if header is None and (line.startswith("#") or not line.strip()):
                dst.write(line)
                continue
            if header is None:
                header = next(csv.reader([line]))
                dst.write(line)
                columns = [k for k, h in enumerate(header) if h.strip() in headers]
                continue
            fields = line.rstrip("\n").split(",")
            for k in columns:
                try:
                    value = float(fields[k])
                except (ValueError, IndexError):
                    continue
                fields[k] = repr(value * (1.0 + rel * rng.gauss(0.0, 1.0)))
            dst.write(",".join(fields) + "\n")
    return target


def run(binary, argv, env):
    argv = list(argv)
    k = argv.index("--report")
    del argv[k:k + 2]
    done = subprocess.run([binary, *argv, "--json", "--quiet"], capture_output=True, text=True,
                          env=env)
    if done.returncode not in (0, 1, 3):
        return None, done.stderr.strip()
    return json.loads(done.stdout), ""


def summary(report):
    d = report.get("discovery") or {}
    marked = {c["effect"] for c in d.get("unstable", [])}
    for group in d.get("ambiguous", []):
        marked.update(group["effects"])
    p = report["parameters"]
    return (tuple(d.get("added", [])), marked, p.get("J", {}).get("value"),
            p.get("B", {}).get("value"))


def selected(page, data, binary, env, args, errors):
    """(name, argv, report) of each command matching --filter, run on the data as recorded;
    a command that fails is printed as an error row and appended to `errors`."""
    for name, argv in commands(page, data):
        if not re.search(args.filter, name):
            continue
        report, error = run(binary, argv, env)
        if report is None:
            print(f"| {name} | error: {error} |")
            errors.append(name)
            continue
        yield name, argv, report


def variants(page, data, binary, env, args):
    print("| command | added | " + " | ".join(f"{v}: same effects, max rel. diff." for v in args.variant) + " |")
    print("|---|---|" + "---|" * len(args.variant))
    bad, errors = 0, []
    for name, argv, report in selected(page, data, binary, env, args, errors):
        added = tuple((report.get("discovery") or {}).get("added", []))
        cells = []
        for variant in args.variant:
            key, _, value = variant.partition("=")
            if key == "bin":
                other, error = run(os.path.join(value, "blmd-ident"), argv, env)
            else:
                other, error = run(binary, argv, {**env, key: value})
            if other is None:
                cells.append("error")
                bad += 1
                continue
            o_added = tuple((other.get("discovery") or {}).get("added", []))
            diff, over, j_diff = 0.0, [], 0.0
            ci_diff, ci_over, method_differs = 0.0, [], []
            for pname, p in report["parameters"].items():
                q = other["parameters"].get(pname)
                if q and p["value"]:
                    d = abs(q["value"] - p["value"]) / abs(p["value"])
                    diff = max(diff, d)
                    if d > 1e-6:
                        over.append(f"{pname} {d:.2g}")
                    if pname == "J":
                        j_diff = d
                # The printed 95 % interval is a headline number too: its end points, and
                # which method gave it.
                if q and p.get("ci95") and q.get("ci95"):
                    c = max(abs(b - a) / max(abs(a), abs(p["value"]), 1e-300)
                            for a, b in zip(p["ci95"], q["ci95"]))
                    ci_diff = max(ci_diff, c)
                    if c > 1e-6:
                        ci_over.append(f"{pname} {c:.2g}")
                    if p.get("interval_method") != q.get("interval_method"):
                        method_differs.append(pname)
            same = o_added == added
            bad += 0 if same and diff <= 1e-6 and ci_diff <= 1e-6 and not method_differs else 1
            # Every value beyond 1e-6 is named, not only the largest: one value over the bar
            # can hide another.
            listed = f" ({', '.join(over)}; J {j_diff:.2g})" if over else ""
            intervals = f"; intervals {ci_diff:.2g}"
            if ci_over:
                intervals += f" ({', '.join(ci_over)})"
            if method_differs:
                intervals += f", method differs: {', '.join(method_differs)}"
            cells.append(f"{'yes' if same else 'NO'}, {diff:.2g}{listed}{intervals}")
        print(f"| {name} | {', '.join(added) or '—'} | " + " | ".join(cells) + " |")
        sys.stdout.flush()
    return 1 if bad or errors else 0


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--rel", type=float, default=1e-9)
    parser.add_argument("--filter", default=".")
    parser.add_argument("--bin", default=os.environ.get("BUILD_DIR", "build") + "/bin")
    parser.add_argument("--env", action="append", default=[])
    parser.add_argument("--variant", action="append", default=[])
    parser.add_argument("--show-differing", action="store_true")
    parser.add_argument("--show-values", action="store_true")
    args = parser.parse_args()
    data = os.environ.get("BLMD_REALDATA", "../shared/realdata")
    env = dict(os.environ)
    for item in args.env:
        key, _, value = item.partition("=")
        env[key] = value
    page = open("docs/real-data.md", encoding="utf-8").read()
    binary = os.path.join(args.bin, "blmd-ident")
    bad = 0
    if args.variant:
        return variants(page, data, binary, env, args)
    print("| command | added | same in perturbed runs | differing runs marked | max rel. change J, B |")
    print("|---|---|---|---|---|")
    errors = []
    for name, argv, report in selected(page, data, binary, env, args, errors):
        added, marked, J, B = summary(report)
        same, differing, differing_marked, change = 0, 0, 0, 0.0
        headers = mapped_headers(argv)
        for r in range(args.runs):
            rng = random.Random(1000 + r)
            with tempfile.TemporaryDirectory() as tmp:
                perturbed = list(argv)
                for k, a in enumerate(argv):
                    if a in ("--trace", "--validate"):
                        k2 = k + 1
                        while k2 < len(argv) and not argv[k2].startswith("--"):
                            perturbed[k2] = perturb(argv[k2], headers, args.rel, rng, tmp)
                            k2 += 1
                other, error = run(binary, perturbed, env)
            if other is None:
                differing += 1
                continue
            o_added, o_marked, oJ, oB = summary(other)
            if o_added == added:
                same += 1
            else:
                differing += 1
                k = next((k for k, (a, b) in enumerate(zip(added, o_added)) if a != b),
                         min(len(added), len(o_added)))
                chosen = set(added[k:k + 1]) | set(o_added[k:k + 1])
                if (set(o_added) ^ set(added)) <= (marked | o_marked) or \
                        chosen & (marked | o_marked):
                    differing_marked += 1
                if args.show_differing:
                    print(f"{name} run {r}: added {', '.join(o_added) or '-'}"
                          f"{' (undecided: ' + ', '.join(sorted(o_marked)) + ')' if o_marked else ''}"
                          f", J {oJ:.6g}", file=sys.stderr)
            if args.show_values:
                print(f"{name} run {r}: J {oJ!r} (as recorded {J!r}), B {oB!r} ({B!r})",
                      file=sys.stderr)
            for a, b in ((J, oJ), (B, oB)):
                if a and b:
                    change = max(change, abs(b - a) / abs(a))
        if differing > differing_marked:
            bad += 1
        print(f"| {name} | {', '.join(added) or '—'}{' (undecided: ' + ', '.join(sorted(marked)) + ')' if marked else ''}"
              f" | {same}/{args.runs} | {differing_marked}/{differing} | {change:.2g} |")
        sys.stdout.flush()
    return 1 if bad or errors else 0


if __name__ == "__main__":
    sys.exit(main())
