#!/usr/bin/env python3
"""Independent J/B/Tc estimate for the ASB (Quanser SRV02 x2, 5-bar 'CNC') motor-0 voltage steps.

Torque at the load shaft from the commanded voltage (datasheet constants, cnc_params.m of the
source repo): u = eta_g*eta_m*Kg*k/Ra * V  (0.12840 N*m/V), so that
    u = J*dw/dt + (B + B_emf)*w + Tc*sign(w) + d,      B_emf = eta_g*eta_m*Kg^2*k^2/Ra
(B_emf = 0.06900 N*m*s/rad is the back-EMF damping; the fit returns Btot = B + B_emf).
w and dw/dt come from the encoder angle theta (4096 counts/rev at the load shaft): theta is
low-passed with a zero-phase forward-backward 2nd-order Butterworth (-6 dB at fc), then
differentiated twice with np.gradient; u goes through the same filter.
Rows: from the voltage step (t >= 0.5 s) to the end of each file, first 10 ms after the step
kept (the filter spreads the step anyway; the fit is done on filtered u as well).
Spread: OLS standard errors, per-file fits (one direction each, Tc+d lumped), and a
leave-one-file-out jackknife of the pooled fit.  Run: /usr/bin/python3 estimate.py (numpy only).
"""
import os, glob
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from lsq_tools import filtfilt, ols, relative_rms  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
KU = 0.9 * 0.69 * 70 * 7.68e-3 / 2.6          # N*m per V at the load shaft
B_EMF = 0.9 * 0.69 * 70**2 * 7.68e-3**2 / 2.6  # N*m*s/rad
FCS = [5.0, 10.0, 20.0, 40.0]
FC_MAIN = 10.0


def load(name):
    d = np.genfromtxt(name, delimiter=',', names=True)
    return d['t'], d['u'], d['theta']


def rows(name, fc):
    t, u, th = load(name)
    fs = 1.0 / np.median(np.diff(t))
    w = np.gradient(filtfilt(th, fc, fs), t)
    a = np.gradient(w, t)
    uf = filtfilt(u, fc, fs)
    m = (t >= 0.5) & (np.abs(w) > 0.05)
    m[-3:] = False
    return a[m], w[m], uf[m], u[np.argmax(u != 0)]


def pooled(files, fc):
    A = []
    Y = []
    for f in files:
        a, w, uf, _ = rows(f, fc)
        A.append(np.column_stack([a, w, np.sign(w), np.ones_like(w)]))
        Y.append(uf)
    X, y = np.vstack(A), np.concatenate(Y)
    p, se, r = ols(X, y)
    return p, se, relative_rms(r, y)


if __name__ == '__main__':
    files = sorted(glob.glob(os.path.join(HERE, 'm0_*.csv')))
    print('u = %.5f N*m/V * V ; back-EMF damping B_emf = %.5f N*m*s/rad' % (KU, B_EMF))
    print('== per file, fc = %.0f Hz: u = J*dw + Btot*w + c' % FC_MAIN)
    for f in files:
        a, w, uf, u0 = rows(f, FC_MAIN)
        p, se, r = ols(np.column_stack([a, w, np.ones_like(w)]), uf)
        rel = relative_rms(r, uf)
        print('  %-14s V=%+.1f  n=%4d  J=%.4e (se %.1e)  Btot=%.4e  c=%+.3e  wmax=%5.2f rad/s  rel.res %.3f'
              % (os.path.basename(f), u0 / KU, len(w), p[0], se[0], p[1], p[2], np.max(np.abs(w)), rel))
    print('== pooled, both directions: u = J*dw + Btot*w + Tc*sign(w) + d')
    for fc in FCS:
        p, se, rel = pooled(files, fc)
        print('  fc = %4.0f Hz: J = %.4e +- %.1e  Btot = %.4e +- %.1e (B = Btot - B_emf = %+.4e)  Tc = %.3e  d = %+.2e  rel.res %.3f'
              % (fc, p[0], se[0], p[1], se[1], p[1] - B_EMF, p[2], p[3], rel))
    base, _, _ = pooled(files, FC_MAIN)
    jk = np.array([pooled([g for g in files if g != f], FC_MAIN)[0] for f in files])
    n = len(files)
    jse = np.sqrt((n - 1) / n * np.sum((jk - jk.mean(0))**2, axis=0))
    print('  leave-one-file-out jackknife se (fc = %.0f Hz): J %.1e  Btot %.1e  Tc %.1e' % (FC_MAIN, jse[0], jse[1], jse[2]))
    print('  range of J over the 6 jackknife fits: %.4e .. %.4e' % (jk[:, 0].min(), jk[:, 0].max()))
    # datasheet / CAD value from cnc_params.m (home position, no efficiency on the inertia)
    Jm = 3.9e-7 + 7.06e-8
    Jg = 2 * 0.5 * 0.03 * 0.019**2 + 0.5 * 0.083 * 0.032**2 + 25 * 0.5 * 0.005 * 6.35e-3**2
    Jext = 0.0017473775
    print('== datasheet/CAD (cnc_params.m): eta_g*Kg^2*Jm = %.4e, gears %.4e, links(home) %.4e -> J = %.4e kg m^2'
          % (0.9 * 4900 * Jm, Jg, Jext, 0.9 * 4900 * Jm + Jg + Jext))
    print('   students\' first-order fit (Fact_sheet): tau = 0.0401 s, mu = 1.4479 rad/s/V ->'
          ' J = tau*KU/mu = %.4e kg m^2, Btot = KU/mu = %.4e' % (0.0401 * KU / 1.4479, KU / 1.4479))
