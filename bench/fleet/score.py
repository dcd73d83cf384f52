#!/usr/bin/env python3
"""Scores a fleet study's table against its truth (bench/fleet/make_fleet.py; docs/fleet.md):
the share of drifted drives flagged, of the others flagged, and whether every corrupt file is
an error row with a message. Prints one JSON object.

Usage: score.py STUDY_DIR RESULTS_CSV
"""
import csv
import json
import sys


def main():
    study, results = sys.argv[1], sys.argv[2]
    with open(f"{study}/truth.csv") as f:
        truth = {r["drive"]: r for r in csv.DictReader(f)}
    with open(results) as f:
        rows = list(csv.DictReader(f))
    by_drive = {r["drive"]: r for r in rows}
    truth = {d: t for d, t in truth.items() if d in by_drive}  # a table of a part of the fleet
    drifted = [d for d, t in truth.items() if t["drifted"] and not t["corrupt"]]
    steady = [d for d, t in truth.items() if not t["drifted"] and not t["corrupt"]]
    corrupt = [d for d, t in truth.items() if t["corrupt"]]
    flagged = lambda d: by_drive[d]["status"] == "drift"
    missed = [d for d in drifted if not flagged(d)]
    false = [d for d in steady if flagged(d)]
    other_errors = [d for d in drifted + steady if by_drive[d]["status"] == "error"]
    corrupt_ok = [d for d in corrupt
                  if by_drive[d]["status"] == "error" and by_drive[d]["message"].strip()]
    out = {
        "rows": len(rows),
        "ids_unique": len({r["id"] for r in rows}) == len(rows),
        "drifted": len(drifted), "drifted_flagged": len(drifted) - len(missed),
        "drift_detection": (len(drifted) - len(missed)) / max(1, len(drifted)),
        "missed": [(d, truth[d]["model"], truth[d]["drifted"], truth[d]["factor"],
                    by_drive[d]["drift_z"]) for d in missed],
        "steady": len(steady), "steady_flagged": len(false),
        "false_flag_rate": len(false) / max(1, len(steady)),
        "false": [(d, truth[d]["model"], by_drive[d]["drift_z"], by_drive[d]["moved"])
                  for d in false],
        "unexpected_errors": [(d, by_drive[d]["message"]) for d in other_errors],
        "corrupt": len(corrupt), "corrupt_error_rows": len(corrupt_ok),
        "corrupt_messages": {truth[d]["corrupt"]: by_drive[d]["message"] for d in corrupt},
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
