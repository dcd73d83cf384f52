#!/usr/bin/env python3
"""Synthetic EMPS velocity from a published reference model (docs/real-data.md, EMPS).

Drives M dv/dt = F - f(v) with the recorded force F_N of emps_estimation.csv, open loop,
and writes t,F,q,w (no noise) for blmd-ident, to check what the tool does when the model
is known exactly:

  sym   the IDIM-LS model (PDF 3.4):  f = Fv v + Fc sign(v) + offset
        M = 95.1089, Fv = 203.5034, Fc = 20.3935, offset = -3.1648
  asym  the asymmetric model (PDF 4.2): f = Fv+ v + Fc+ (v > 0), Fv- v - Fc- (v < 0), no offset
        M = 95.1540, Fv+ = 166.7061, Fc+ = 20.1440, Fv- = 240.4236, Fc- = 20.6277

Usage: emps-synthetic.py sym|asym OUT.csv [DELAY]
DELAY (default 0): apply the force recorded DELAY samples earlier (a control delay).
Reads ../shared/realdata/emps/emps_estimation.csv (run from the repository root, or set
$BLMD_REALDATA to the folder holding emps/). Each 1 ms sample is integrated in 10 exact steps (force held, friction held per step);
a step that would reverse v stops it at 0, and at rest the axis sticks while
|F - offset| is within the Coulomb level (as rigid_load does). Standard library only.
"""
import csv
import math
import os
import sys

MODELS = {
    "sym": dict(M=95.1089, Fvp=203.5034, Fcp=20.3935, Fvn=203.5034, Fcn=20.3935, offset=-3.1648),
    "asym": dict(M=95.1540, Fvp=166.7061, Fcp=20.1440, Fvn=240.4236, Fcn=20.6277, offset=0.0),
}


def main():
    if len(sys.argv) not in (3, 4) or sys.argv[1] not in MODELS:
        sys.exit(__doc__)
    p = MODELS[sys.argv[1]]
    delay = int(sys.argv[3]) if len(sys.argv) == 4 else 0
    source = os.path.join(os.environ.get("BLMD_REALDATA") or "../shared/realdata", "emps/emps_estimation.csv")
    rows = list(csv.DictReader(open(source)))
    t = [float(r["t_s"]) for r in rows]
    F = [float(r["F_N"]) for r in rows]
    q = [float(r["q_m"]) for r in rows]
    M = p["M"]
    v = (q[1] - q[0]) / (t[1] - t[0])  # the record's first velocity (as --initial-state trace)
    x = q[0]
    with open(sys.argv[2], "w") as out:
        out.write("t,F,q,w\n")
        for k in range(len(t)):
            out.write("%.8f,%.9g,%.12g,%.12g\n" % (t[k], F[k], x, v))
            if k + 1 == len(t):
                break
            h = (t[k + 1] - t[k]) / 10
            for _ in range(10):
                f = F[max(k - delay, 0)] - p["offset"]
                if v > 0 or (v == 0 and f > p["Fcp"]):
                    friction, b = p["Fcp"], p["Fvp"]
                elif v < 0 or (v == 0 and f < -p["Fcn"]):
                    friction, b = -p["Fcn"], p["Fvn"]
                else:
                    continue  # stuck
                v_inf = (f - friction) / b
                decay = math.exp(-b * h / M)
                v_next = v_inf + (v - v_inf) * decay
                x += v_inf * h + (v - v_inf) * (M / b) * (1 - decay)
                v = 0.0 if v != 0 and (v_next > 0) != (v > 0) else v_next


if __name__ == "__main__":
    main()
