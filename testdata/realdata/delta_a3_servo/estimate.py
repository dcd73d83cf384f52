#!/usr/bin/env python3
"""Independent J/B/Tc estimate for the Delta ECM-A3 servo 'Lorenz' Jm records.

Model: u = J*dw/dt + B*w + Tc*sign(w) + c0     (u = commanded torque [N*m])
w and dw/dt are taken from the measured angle theta: theta is low-passed with a
zero-phase (forward-backward) 2nd-order Butterworth, then differentiated twice
with central differences (np.gradient). u is passed through the same filter so
that both sides of the regression see the same (zero) phase and the same
attenuation. Samples with |w| < W_MIN (standstill, velocity reversal) and the
first/last 0.2 s are excluded. Standard errors: OLS (white-noise assumption,
optimistic) and a moving-block bootstrap (block 0.25 s, 200 resamples).
Run: /usr/bin/python3 estimate.py   (numpy only, < 2 s)
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from lsq_tools import block_bootstrap, filtfilt, ols  # noqa: E402


HERE = os.path.dirname(os.path.abspath(__file__))
W_MIN = 2.0          # rad/s, exclusion band around zero speed
FCS = [5.0, 10.0, 20.0, 40.0]   # derivative filter cut-offs to test [Hz]
FC_MAIN = 10.0

def load(name):
    d = np.genfromtxt(os.path.join(HERE, name), delimiter=',', names=True)
    return d['t'], d['u'], d['w'], d['theta']

def fit(t, u, th, fc, boot=False):
    fs = 1.0 / np.median(np.diff(t))
    thf = filtfilt(th, fc, fs)
    w = np.gradient(thf, t)
    a = np.gradient(w, t)
    uf = filtfilt(u, fc, fs)
    m = (np.abs(w) > W_MIN) & (t > t[0] + 0.2) & (t < t[-1] - 0.2)
    X = np.column_stack([a, w, np.sign(w), np.ones_like(w)])[m]
    y = uf[m]
    p, se, r = ols(X, y)
    bse = block_bootstrap(X, y, block=int(0.25 * fs)) if boot else None
    rel = np.sqrt(np.mean(r ** 2)) / np.sqrt(np.mean((y - y.mean()) ** 2))
    return p, se, bse, rel, m.sum()

if __name__ == '__main__':
    names = ['J [kg m^2]', 'B [N m s/rad]', 'Tc [N m]', 'c0 [N m]']
    for f in ['lorenz_jm_1.csv', 'lorenz_jm_2.csv']:
        t, u, w_log, th = load(f)
        print('==', f)
        p, se, bse, rel, n = fit(t, u, th, FC_MAIN, boot=True)
        print('  main fit (fc = %.0f Hz, %d samples used, rel. residual %.3f)' % (FC_MAIN, n, rel))
        for k in range(4):
            print('    %-14s %+.4e   OLS se %.1e   block-bootstrap se %.1e' % (names[k], p[k], se[k], bse[k]))
        print('  J vs derivative-filter cut-off:')
        for fc in FCS:
            p2, *_ = fit(t, u, th, fc)
            print('    fc = %4.0f Hz : J = %.4e  B = %.3e  Tc = %.4f  c0 = %+.4f' % (fc, p2[0], p2[1], p2[2], p2[3]))
    print('reference (repo Main.cpp feed-forward): Jm = 1.6588e-4, Bm = 4.8858e-4, fc = 0.0244, fs = 0.0290')
    print('reference (course document example):    Jm = 1.6846e-4, Bm = 8.2285e-5, Fc = 0.0165, Fs = 0.0193')
