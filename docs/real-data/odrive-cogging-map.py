#!/usr/bin/env python3
"""Dominant cogging orders (periods per revolution) and amplitudes of the ODrive cogging maps.

Reads ../shared/realdata/odrive_cogging/coggingmap_*.csv (or $BLMD_REALDATA/odrive_cogging),
removes each map's mean (the sweep's friction/hysteresis bias, README), takes the discrete
Fourier transform over the one revolution the map covers and prints, per map, the five
largest harmonics k (periods/rev) with their amplitude 2|X_k|/N in A and, times
Kt = 8.27/150 N m/A, in N m -- the Tcog of `cogging` (T = Tcog sin(k theta + phase)) that a
single harmonic of that size corresponds to. Also the map's RMS ripple and half peak-to-peak.
Standard library only. Output committed as odrive-cogging-map.txt.
"""
import cmath
import csv
import math
import os
import sys

KT = 8.269933431 / 150.0  # N m / A (spinup_analysis.m)
here = os.path.dirname(os.path.abspath(__file__))
root = os.environ.get("BLMD_REALDATA") or os.path.join(here, "..", "..", "..", "shared", "realdata")
folder = os.path.join(root, "odrive_cogging")


def spectrum(values):
    n = len(values)
    mean = sum(values) / n
    x = [v - mean for v in values]
    out = []
    for k in range(1, n // 2):
        s = sum(x[m] * cmath.exp(-2j * math.pi * k * m / n) for m in range(n))
        out.append((k, 2.0 * abs(s) / n))
    return mean, x, out


def main():
    print("Kt = %.6f N m/A" % KT)
    for name in ("coggingmap_forward_16.csv", "coggingmap_reverse_16.csv", "coggingmap_forward_4.csv"):
        path = os.path.join(folder, name)
        if not os.path.exists(path):
            sys.exit("not found: " + path)
        with open(path) as f:
            rows = list(csv.DictReader(f))
        columns = [c for c in rows[0] if c.startswith("iq_hold_A_")]
        for column in columns:
            values = [float(r[column]) for r in rows]
            mean, x, harmonics = spectrum(values)
            rms = math.sqrt(sum(v * v for v in x) / len(x))
            half_pp = 0.5 * (max(values) - min(values))
            top = sorted(harmonics, key=lambda h: -h[1])[:5]
            print("\n%s %s: %d samples over one revolution, mean %+.3f A" % (name, column, len(values), mean))
            print("  ripple RMS %.3f A = %.4f N m; half peak-to-peak %.3f A = %.4f N m"
                  % (rms, rms * KT, half_pp, half_pp * KT))
            print("  largest harmonics (periods/rev: amplitude A, N m):")
            for k, a in top:
                print("    %3d: %.3f A  %.4f N m" % (k, a, a * KT))


if __name__ == "__main__":
    main()
