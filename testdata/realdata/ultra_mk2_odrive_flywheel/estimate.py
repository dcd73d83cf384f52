#!/usr/bin/env python3
"""Independent J/B/Tc estimate for the 'Repeat Ultra Mk2' ODrive dyno records.

Model (motor shaft): u = J*dw/dt + B*w + Tc*sign(w) + c0
u = -Kt*Iq_logged [N*m], Kt = 8.27/1367.74 N*m/A (ODrive convention 8.27/KV with the KV
the source repo measured; the logged current has the opposite sign to the speed);
u = 0 where the axis was idle (the logger then repeats the last current value, column idle).
The host logger samples irregularly (median 11 ms), so theta and u are first interpolated
linearly onto a uniform 100 Hz grid; theta is low-passed with a zero-phase forward-backward
2nd-order Butterworth (effective 4th order, -6 dB at fc) and differentiated twice with
np.gradient; u passes through the same filter. Excluded: |w| < 20 rad/s (standstill,
reversals), |w| > 1200 rad/s (velocity-limit / voltage-saturation region, where the logged
Iq is not the shaft torque) and the first/last 0.2 s. One-direction records cannot separate
Tc from c0 (sign(w) = 1): there c = Tc + c0 is reported.
Uncertainty: OLS standard errors (optimistic) and a moving-block bootstrap (0.25 s, 200).
Run: /usr/bin/python3 estimate.py   (numpy only, a few seconds)
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from lsq_tools import block_bootstrap, filtfilt, ols  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
FS = 100.0
W_MIN, W_MAX = 20.0, 1200.0
FCS = [2.0, 3.0, 5.0, 8.0]
FC_MAIN = 3.0
J_FLYWHEEL_CAD = (2551.676 + 0.235) / 1000.0 / 1000.0   # kg m^2, repo config.py
GEAR = 14.0


def load(name):
    d = np.genfromtxt(os.path.join(HERE, name), delimiter=',', names=True)
    return d['t'], d['u'], d['theta']


def regressors(t, u, th, fc):
    tg = np.arange(t[0], t[-1], 1.0 / FS)
    thg = np.interp(tg, t, th)
    ug = np.interp(tg, t, u)
    thf = filtfilt(thg, fc, FS)
    w = np.gradient(thf, 1.0 / FS)
    a = np.gradient(w, 1.0 / FS)
    uf = filtfilt(ug, fc, FS)
    m = (np.abs(w) > W_MIN) & (np.abs(w) < W_MAX) & (tg > tg[0] + 0.2) & (tg < tg[-1] - 0.2)
    both = (w[m] > 0).sum() >= 20 and (w[m] < 0).sum() >= 20
    cols = [a, w, np.sign(w), np.ones_like(w)] if both else [a, w, np.ones_like(w)]
    return np.column_stack(cols)[m], uf[m], both


def fit(name, fc, boot=False):
    t, u, th = load(name)
    X, y, both = regressors(t, u, th, fc)
    p, se, r = ols(X, y)
    bse = block_bootstrap(X, y, block=int(0.25 * FS)) if boot else None
    rel = np.sqrt(np.mean(r ** 2)) / np.std(y)
    return p, se, bse, rel, len(y), both


if __name__ == '__main__':
    files = ['flywheel_ramp_0p1Nm_per_s.csv', 'flywheel_ramp_1Nm_per_s.csv', 'noflywheel_steps.csv']
    J_main = {}
    for f in files:
        p, se, bse, rel, n, both = fit(f, FC_MAIN, boot=True)
        names = ['J [kg m^2]', 'B [N m s/rad]'] + (['Tc [N m]', 'c0 [N m]'] if both else ['c=Tc+c0 [N m]'])
        print('==', f)
        print('  main fit (fc = %.0f Hz, %d grid samples used, rel. residual %.3f)' % (FC_MAIN, n, rel))
        for k in range(len(p)):
            print('    %-15s %+.4e   OLS se %.1e   block-bootstrap se %.1e' % (names[k], p[k], se[k], bse[k]))
        print('  J vs derivative-filter cut-off:')
        for fc in FCS:
            p2, *_ = fit(f, fc)
            print('    fc = %4.0f Hz : J = %.4e  B = %+.3e  ' % (fc, p2[0], p2[1])
                  + '  '.join('%s = %+.2e' % (nm.split(' ')[0], v) for nm, v in zip(names[2:], p2[2:])))
        J_main[f] = p[0]
    dJ = J_main['flywheel_ramp_0p1Nm_per_s.csv'] - J_main['noflywheel_steps.csv']
    print('flywheel increment J(ramp 0.1) - J(no flywheel) = %.3e kg m^2;  CAD flywheel / %g^2 = %.3e kg m^2'
          % (dJ, GEAR, J_FLYWHEEL_CAD / GEAR ** 2))
    print('repo reference (config.py): MOTOR_INERTIA = 3.71e-6 (its own estimate, Kt = 60/(2 pi 1450)),'
          ' total with flywheel = %.3e kg m^2' % (3.71e-6 + J_FLYWHEEL_CAD / GEAR ** 2))
