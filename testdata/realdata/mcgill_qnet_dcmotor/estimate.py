#!/usr/bin/env python3
"""Independent J/B/Tc estimate for the McGill ECSE 307 QNET DC motor step records.

Model (mechanical): Kt*(i - i0) = J*dw/dt + B*w + c        (c: Coulomb + torque offset)
Torque from the MEASURED armature current, Kt = 0.035 N*m/A (value the course
LiveScript in the same repository gives: "Kt = 0.035; Ke = 0.035; R = 8.4;").
i0 = current-sensor offset, mean current while the amplifier is on and the shaft stands
still (before the first voltage step). The speed is one-signed in both records, so
sign(w) = 1 and a Coulomb term cannot be told from a constant offset: c holds both.

w and dw/dt are taken from the ENCODER angle theta (2048 counts/rev): theta is low-passed
with a zero-phase forward-backward 2nd-order Butterworth (effective 4th order, -6 dB at
fc), then differentiated twice with np.gradient; i (and u) pass through the same filter.
Rows with open = 1 (amplifier switched off at the end: no torque, tachometer frozen) are
dropped, as are |w| < 3 rad/s, the first 0.1 s and the last 3 rows before the switch-off.
Uncertainty: OLS standard errors (white residuals, optimistic) and a moving-block
bootstrap (block 0.25 s, 200 resamples).

Cross-checks printed: (a) torque from the COMMANDED voltage, Kt*(u - Ke*w)/R;
(b) the electrical equation u = R*(i - i0) + Ke*w + v0 fitted on the same rows (L = 1.16 mH
is negligible at 100 Hz), to see whether the course constants fit this unit.
Run: /usr/bin/python3 estimate.py   (numpy only, < 2 s)
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from lsq_tools import block_bootstrap, filtfilt, ols  # noqa: E402

KT, KE, R = 0.035, 0.035, 8.4
FCS = [3.0, 5.0, 10.0, 20.0]
FC_MAIN = 5.0
W_MIN = 3.0
HERE = os.path.dirname(os.path.abspath(__file__))


def load(name):
    d = np.genfromtxt(os.path.join(HERE, name), delimiter=',', names=True)
    return {k: d[k] for k in d.dtype.names}


def prepare(d, fc):
    on = d['open'] == 0
    t, u, i, w_tach, th = (d[k][on] for k in ('t', 'u', 'i', 'w', 'theta'))
    fs = 1.0 / np.median(np.diff(t))
    first_step = np.where(u != 0)[0][0]
    i0 = i[t < t[first_step] - 0.02].mean()
    thf = filtfilt(th, fc, fs)
    w = np.gradient(thf, t)
    a = np.gradient(w, t)
    i_f = filtfilt(i, fc, fs)
    u_f = filtfilt(u, fc, fs)
    m = (np.abs(w) > W_MIN) & (t > t[0] + 0.1)
    m[-3:] = False
    return t, u_f, i_f, i0, w, a, m, fs


def fit(d, fc, boot=False, torque='current'):
    t, u_f, i_f, i0, w, a, m, fs = prepare(d, fc)
    tau = KT * (i_f - i0) if torque == 'current' else KT * (u_f - KE * w) / R
    X = np.column_stack([a, w, np.ones_like(w)])[m]
    y = tau[m]
    p, se, r = ols(X, y)
    bse = block_bootstrap(X, y, block=int(0.25 * fs)) if boot else None
    rel = np.sqrt(np.mean(r ** 2)) / np.std(y)
    return p, se, bse, rel, int(m.sum()), i0


def electrical(d, fc):
    t, u_f, i_f, i0, w, a, m, fs = prepare(d, fc)
    X = np.column_stack([i_f - i0, w, np.ones_like(w)])[m]
    p, se, r = ols(X, u_f[m])
    return p, se


if __name__ == '__main__':
    names = ['J [kg m^2]', 'B [N m s/rad]', 'c=Tc+off [N m]']
    files = ['qnet_step2V.csv', 'qnet_step4V6V.csv']
    for f in files:
        d = load(f)
        print('==', f, '(%d rows, %d with the amplifier off)' % (len(d['t']), int(d['open'].sum())))
        p, se, bse, rel, n, i0 = fit(d, FC_MAIN, boot=True)
        print('  current offset i0 = %.5f A (removed)' % i0)
        print('  main fit, torque = Kt*(i - i0), fc = %.0f Hz, %d samples, rel. residual %.3f' % (FC_MAIN, n, rel))
        for k in range(3):
            print('    %-15s %+.4e   OLS se %.1e   block-bootstrap se %.1e' % (names[k], p[k], se[k], bse[k]))
        print('  J vs derivative-filter cut-off (torque from current | from commanded voltage):')
        for fc in FCS:
            p1, *_ = fit(d, fc)
            p2, _, _, rel2, _, _ = fit(d, fc, torque='voltage')
            print('    fc = %4.0f Hz : J = %.4e  B = %+.2e  c = %+.2e   |  J = %.4e  B = %+.2e  (rel. res. %.2f)'
                  % (fc, p1[0], p1[1], p1[2], p2[0], p2[1], rel2))
        pe, see = electrical(d, FC_MAIN)
        print('  electrical check u = R*(i-i0) + Ke*w + v0: R = %.2f +- %.2f ohm, Ke = %.4f +- %.4f V s/rad, v0 = %+.3f V'
              % (pe[0], see[0], pe[1], see[1], pe[2]))
    # both records together (separate offsets c per record)
    rows = []
    for j, f in enumerate(files):
        d = load(f)
        t, u_f, i_f, i0, w, a, m, fs = prepare(d, FC_MAIN)
        tau = KT * (i_f - i0)
        X = np.column_stack([a, w, np.ones_like(w) * (j == 0), np.ones_like(w) * (j == 1)])[m]
        rows.append((X, tau[m]))
    X = np.vstack([r[0] for r in rows])
    y = np.concatenate([r[1] for r in rows])
    p, se, _ = ols(X, y)
    print('== both records, fc = %.0f Hz: J = %.4e +- %.1e kg m^2, B = %+.2e +- %.1e N m s/rad, c = %+.2e / %+.2e N m'
          % (FC_MAIN, p[0], se[0], p[1], se[1], p[2], p[3]))
    print('course constants used: Kt = Ke = 0.035, R = 8.4 ohm (Lab04 LiveScript in the source repo);')
    print('J scales with Kt: with the 0.042 N m/A often quoted for this motor, multiply J, B, c by 1.2.')
