#!/usr/bin/env python3
"""Start-up time of the commands (docs/performance.md, "Start-up"): each command's --version,
the median of N runs, beside /bin/true (the cost of a process at all), and beside a second
binary when one is given (e.g. an older build): the runs alternate between the binaries so that
the machine's load falls on both alike, and the ratio is printed pair by pair.

    bench/startup.py [--runs N] [--vs OTHER_BLMD_IDENT] [BIN_DIR]   # default build/bin
"""
import argparse
import os
import statistics
import subprocess
import time

COMMANDS = ["blmd-ident", "blmd-sim", "blmd-surface", "blmd-tune", "blmd-design"]


def once(argv):
    started = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - started


def shared_libraries(path):
    out = subprocess.run(["ldd", path], capture_output=True, text=True).stdout
    return len([line for line in out.splitlines() if line.strip()])


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--vs", help="another blmd-ident binary, timed in turn with ours")
    parser.add_argument("bin", nargs="?", default=os.path.join(root, "build", "bin"))
    args = parser.parse_args()
    rows = [("/bin/true", ["/bin/true"])]
    rows += [(name, [os.path.join(args.bin, name), "--version"]) for name in COMMANDS]
    if args.vs:
        rows.append(("--vs " + args.vs, [args.vs, "--version"]))
    times = {label: [] for label, _ in rows}
    for _ in range(args.runs):
        for label, argv in rows:  # in turn: a slow moment of the machine falls on every row
            times[label].append(once(argv))
    true_ms = 1000 * statistics.median(times["/bin/true"])
    print("| binary | shared libraries | median of %d (ms) | over /bin/true |" % args.runs)
    print("|---|---|---|---|")
    for label, argv in rows:
        median = 1000 * statistics.median(times[label])
        libraries = shared_libraries(argv[0]) if label != "/bin/true" else "-"
        print("| %s | %s | %.1f | %.1fx |" % (label, libraries, median, median / true_ms))
    if args.vs:
        ours = times["blmd-ident"]
        other = times["--vs " + args.vs]
        ratios = [o / b for o, b in zip(other, ours)]
        print("\n--vs over blmd-ident, run by run: median ratio %.2f (min %.2f, max %.2f)"
              % (statistics.median(ratios), min(ratios), max(ratios)))


if __name__ == "__main__":
    main()
