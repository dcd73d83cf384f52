#!/usr/bin/env python3
"""Independent J/B/c estimate for the ASEN 3200 (CU Boulder, 2018) reaction-wheel spin-ups.

u = Kt*i (Kt = 33.5 mN*m/A, stated in the source's main.m), w = wheel speed (rpm -> rad/s).
Model M1: u = J*dw/dt + B*w + c  (w >= 0 throughout: Coulomb friction and offset are one c).
w and u are low-passed with the same zero-phase forward-backward 2nd-order Butterworth
(-6 dB at fc); dw/dt = np.gradient of the filtered w. Rows: w > 3 rad/s, below 3500 rpm, first
and last 0.3 s of the file dropped; drive-on AND coast rows are both used (the coast is what
separates J from B and c).  Also printed: the students' method (J = mean(Kt*i)/slope(w) on the
spin-up, friction ignored, as in main.m).  Spread: OLS s.e., moving-block bootstrap (0.3 s
blocks, 200 resamples), fc = 1/2/4 Hz, and across the four runs.
Run: /usr/bin/python3 estimate.py  (numpy only)
"""
import os, glob
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from lsq_tools import block_bootstrap, filtfilt, ols, relative_rms  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
FCS = [1.0, 2.0, 4.0]
FC_MAIN = 2.0


def design(name, fc):
    d = np.genfromtxt(name, delimiter=',', names=True)
    t, u, w = d['t'], d['u'], d['w']
    fs = 1.0 / np.median(np.diff(t))
    wf = filtfilt(w, fc, fs)
    a = np.gradient(wf, t)
    uf = filtfilt(u, fc, fs)
    m = (wf > 3.0) & (wf < 3500 * np.pi / 30) & (t > t[0] + 0.3) & (t < t[-1] - 0.3)
    return np.column_stack([a, wf, np.ones_like(wf)])[m], uf[m], t, u, w, fs


def slope_difference(t, u, w):
    """J = u_on / (alpha_on - alpha_off): last 1.0 s of the drive-on phase vs the coast (drive off,
    all rows 50 ms after the switch-off; J = (u_on - u_off)/(alpha_on - alpha_off)), both near the same speed, so the same friction acts in both (its speed
    dependence over the ~30 rad/s gap is neglected)."""
    on = np.where(u > 0.2 * 0.0335)[0]
    k_off = on[-1]
    mon = (t > t[k_off] - 1.0) & (t <= t[k_off])
    moff = (t > t[k_off] + 0.05)
    a_on = np.polyfit(t[mon], w[mon], 1)[0]
    a_off = np.polyfit(t[moff], w[moff], 1)[0]
    u_on = np.mean(u[mon]) - np.mean(u[moff])     # the logged current after switch-off is not always 0
    J = u_on / (a_on - a_off)
    return J, a_on, a_off, u_on, np.mean(u[moff]) - J * a_off, np.mean(w[moff])


def students(t, u, w):
    m = (u > 0.2 * 0.0335) & (w < 3500 * np.pi / 30)
    slope = np.polyfit(t[m], w[m], 1)[0]
    return np.mean(u[m]) / slope, np.mean(u[m]), slope


if __name__ == '__main__':
    files = sorted(glob.glob(os.path.join(HERE, '*.csv')))
    allJ = []
    sdJ = []
    for f in files:
        X, y, t, u, w, fs = design(f, FC_MAIN)
        p, se, r = ols(X, y)
        rel = relative_rms(r, y)
        bse = block_bootstrap(X, y, int(0.3 * fs))
        allJ.append(p[0])
        Js, um, sl = students(t, u, w)
        upd = np.mean(np.diff(w) != 0)
        print('== %s: %d rows used, speed changes in %.0f %% of the rows' % (os.path.basename(f), len(y), 100 * upd))
        print('   M1 fc = %.0f Hz: J = %.4e (OLS se %.1e, bootstrap se %.1e)  B = %+.3e (bs %.1e)  c = %+.3e (bs %.1e)  rel.res %.3f'
              % (FC_MAIN, p[0], se[0], bse[0], p[1], bse[1], p[2], bse[2], rel))
        line = '   J vs fc:'
        for fc in FCS:
            q, _, _ = ols(*design(f, fc)[:2])
            line += '  %.0f Hz: %.4e (B %+.2e, c %+.2e)' % (fc, q[0], q[1], q[2])
        print(line)
        Jd, aon, aoff, uon, fric, wc = slope_difference(t, u, w)
        sdJ.append(Jd)
        print('   slope difference: alpha_on = %.2f, alpha_off (coast) = %.2f rad/s^2, u_on-u_off = %.4e N m -> J = %.4e kg m^2, drag at %.0f rad/s = %.2e N m'
              % (aon, aoff, uon, Jd, wc, fric))
        print('   students\' method: mean torque %.4e N m / slope %.2f rad/s^2 = J %.4e kg m^2 (friction ignored)'
              % (um, sl, Js))
    Xs, ys = [], []
    for j, f in enumerate(files):
        X, y = design(f, FC_MAIN)[:2]
        Z = np.zeros((len(y), len(files)))
        Z[:, j] = 1.0
        Xs.append(np.column_stack([X[:, :2], Z]))
        ys.append(y)
    X, y = np.vstack(Xs), np.concatenate(ys)
    p, se, r = ols(X, y)
    rel = relative_rms(r, y)
    print('== all runs, one J and B, a c per run (fc = %.0f Hz): J = %.4e +- %.1e, B = %+.3e, c = %s, rel.res %.3f'
          % (FC_MAIN, p[0], se[0], p[1], ' '.join('%+.2e' % v for v in p[2:]), rel))
    print('   spread of per-run J (M1): mean %.4e, std %.1e' % (np.mean(allJ), np.std(allJ, ddof=1)))
    print('   slope-difference J over the runs: mean %.4e, std %.1e, min %.4e, max %.4e'
          % (np.mean(sdJ), np.std(sdJ, ddof=1), min(sdJ), max(sdJ)))
