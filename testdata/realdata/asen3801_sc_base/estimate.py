#!/usr/bin/env python3
"""Independent J/B estimate for the ASEN 3801 spacecraft-simulator body driven by its base motor.

Two models are fitted by plain least squares (w > 0 only, so sign(w) == constant):
  M1 (plain):      u = J*dw/dt + B*w + c
  M2 (+ 1/rev):    u = J*dw/dt + B*w + c + s1*sin(th) + c1*cos(th) + s2*sin(2th) + c2*cos(2th)
th is the body angle obtained by integrating the measured speed (trapezoid rule,
th(0) = 0; the absolute angle is unknown, only its phase matters here).
M1 fails (negative B, 50-70 % residual) because the body sees a large
once-per-revolution torque (unbalance / tilted axis / cable); M2 captures it.
w and u are low-passed with the same zero-phase (forward-backward) 2nd-order
Butterworth, dw/dt = np.gradient of the filtered speed. Samples with w < 0.3 rad/s
and the first/last 0.3 s are excluded. SE: OLS and moving-block bootstrap (0.3 s).
Run: /usr/bin/python3 estimate.py
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from lsq_tools import block_bootstrap, filtfilt, ols  # noqa: E402


HERE = os.path.dirname(os.path.abspath(__file__))
W_MIN = 0.3
FCS = [1.0, 2.0, 3.0, 5.0]
FC_MAIN = 2.0

def load(name):
    d = np.genfromtxt(os.path.join(HERE, name), delimiter=',', names=True)
    return d['t'], d['u'], d['w']

def fit(t, u, w, fc, harmonics=True, boot=False):
    fs = 1.0 / np.median(np.diff(t))
    th = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))])
    wf = filtfilt(w, fc, fs)
    a = np.gradient(wf, t)
    uf = filtfilt(u, fc, fs)
    m = (wf > W_MIN) & (t > t[0] + 0.3) & (t < t[-1] - 0.3)
    cols = [a, wf, np.ones_like(wf)]
    if harmonics:
        for k in (1, 2):
            # filter the harmonic regressors too, so every column sees the same filter
            cols += [filtfilt(np.sin(k * th), fc, fs), filtfilt(np.cos(k * th), fc, fs)]
    X = np.column_stack(cols)[m]
    y = uf[m]
    p, se, r = ols(X, y)
    bse = block_bootstrap(X, y, block=int(0.3 * fs)) if boot else None
    rel = np.sqrt(np.mean(r ** 2)) / np.sqrt(np.mean((y - y.mean()) ** 2))
    return p, se, bse, rel, m.sum()

if __name__ == '__main__':
    names = ['J [kg m^2]', 'B [N m s/rad]', 'c [N m]']
    for f in ['base_T10_run1.csv', 'base_T8_run1.csv']:
        t, u, w = load(f)
        print('==', f)
        p, se, bse, rel, n = fit(t, u, w, FC_MAIN, harmonics=False, boot=True)
        print('  M1 plain (fc = %.0f Hz, %d samples, rel. residual %.3f):' % (FC_MAIN, n, rel))
        for k in range(3):
            print('    %-14s %+.4e   OLS se %.1e   block-bootstrap se %.1e' % (names[k], p[k], se[k], bse[k]))
        p, se, bse, rel, n = fit(t, u, w, FC_MAIN, harmonics=True, boot=True)
        print('  M2 with 1/rev + 2/rev terms (fc = %.0f Hz, rel. residual %.3f):' % (FC_MAIN, rel))
        for k in range(3):
            print('    %-14s %+.4e   OLS se %.1e   block-bootstrap se %.1e' % (names[k], p[k], se[k], bse[k]))
        print('    1/rev amplitude %.4f N m, 2/rev amplitude %.4f N m' % (np.hypot(p[3], p[4]), np.hypot(p[5], p[6])))
        print('  J vs derivative-filter cut-off (M2 | M1):')
        for fc in FCS:
            p2, _, _, r2, _ = fit(t, u, w, fc, harmonics=True)
            p1, _, _, r1, _ = fit(t, u, w, fc, harmonics=False)
            print('    fc = %3.0f Hz : M2 J = %.3e B = %+.2e (res %.2f) | M1 J = %.3e B = %+.2e (res %.2f)'
                  % (fc, p2[0], p2[1], r2, p1[0], p1[1], r1))
