#!/usr/bin/env python3
"""Independent J/B/Tc estimate for the ASEN 3801 reaction-wheel spin-up/coast records.

Model (wheel turns one way only, w >= 0):  u = J*dw/dt + B*w + Tc   (u = 0.0335*i [N*m])
w (measured wheel speed) and u are low-passed with the same zero-phase (forward-
backward) 2nd-order Butterworth; dw/dt = np.gradient of the filtered speed.
Samples with w < W_MIN (wheel at rest: speed reads +-4 rad/s of noise) and the
first/last 0.3 s are excluded. Because w never changes sign, sign(w) and a constant
are the same regressor: Tc here is 'constant drag torque' (Coulomb + any offset).
SE: OLS (optimistic) and moving-block bootstrap (block 0.3 s, 200 resamples).
A second, model-light check uses only the two torque levels: with the drive on the
speed is ~w1 at time t1 and with it off ~w1 at t1+: J = (u_on - u_off) / (a_on - a_off)
evaluated in the 0.4 s just before / just after the current is switched off (same speed,
so B*w and Tc cancel).
Run: /usr/bin/python3 estimate.py
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from lsq_tools import block_bootstrap, filtfilt, ols  # noqa: E402


HERE = os.path.dirname(os.path.abspath(__file__))
W_MIN = 10.0                 # rad/s
FCS = [1.0, 2.0, 3.0, 5.0]   # Hz (fs = 100 Hz, speed updated every 30 ms)
FC_MAIN = 2.0

def load(name):
    d = np.genfromtxt(os.path.join(HERE, name), delimiter=',', names=True)
    return d['t'], d['u'], d['w']

def fit(t, u, w, fc, boot=False):
    fs = 1.0 / np.median(np.diff(t))
    wf = filtfilt(w, fc, fs)
    a = np.gradient(wf, t)
    uf = filtfilt(u, fc, fs)
    m = (wf > W_MIN) & (t > t[0] + 0.3) & (t < t[-1] - 0.3)
    X = np.column_stack([a, wf, np.ones_like(wf)])[m]
    y = uf[m]
    p, se, r = ols(X, y)
    bse = block_bootstrap(X, y, block=int(0.3 * fs)) if boot else None
    rel = np.sqrt(np.mean(r ** 2)) / np.sqrt(np.mean((y - y.mean()) ** 2))
    return p, se, bse, rel, m.sum()

def switch_off_check(t, u, w):
    """J from the torque step at switch-off, using straight-line slopes of the raw
    speed 0.5 s before and 0.5 s after the switch-off instant."""
    on = np.where(np.abs(u) > 0.5 * np.max(np.abs(u)))[0]
    toff = t[on[-1]]
    b = (t > toff - 0.6) & (t < toff - 0.05)
    c = (t > toff + 0.05) & (t < toff + 0.6)
    if c.sum() < 10:
        return None
    a_on = np.polyfit(t[b], w[b], 1)[0]
    a_off = np.polyfit(t[c], w[c], 1)[0]
    return (np.mean(u[b]) - np.mean(u[c])) / (a_on - a_off), a_on, a_off, toff

if __name__ == '__main__':
    names = ['J [kg m^2]', 'B [N m s/rad]', 'Tc [N m]']
    for f in ['rw_T10_run1.csv', 'rw_T6767_run1.csv', 'rw_T5_run1.csv']:
        t, u, w = load(f)
        print('==', f)
        p, se, bse, rel, n = fit(t, u, w, FC_MAIN, boot=True)
        print('  main fit (fc = %.0f Hz, %d samples, rel. residual %.3f)' % (FC_MAIN, n, rel))
        for k in range(3):
            print('    %-14s %+.4e   OLS se %.1e   block-bootstrap se %.1e' % (names[k], p[k], se[k], bse[k]))
        print('  J vs derivative-filter cut-off:')
        for fc in FCS:
            p2, *_ = fit(t, u, w, fc)
            print('    fc = %3.0f Hz : J = %.4e  B = %.3e  Tc = %.5f' % (fc, p2[0], p2[1], p2[2]))
        s = switch_off_check(t, u, w)
        if s:
            print('  switch-off check (t_off = %.2f s): a_on = %.1f, a_off = %.1f rad/s^2 -> J = %.3e' % (s[3], s[1], s[2], s[0]))
    print('student (repo) estimates ignore friction: J = Kt*mean(i)/slope(w), see README')
