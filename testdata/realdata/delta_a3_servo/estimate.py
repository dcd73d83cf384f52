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
import numpy as np

def butter2(fc, fs):
    """2nd-order Butterworth low-pass, bilinear transform with pre-warping."""
    K = np.tan(np.pi * fc / fs)
    n = 1.0 / (1.0 + np.sqrt(2.0) * K + K * K)
    b = np.array([K * K * n, 2 * K * K * n, K * K * n])
    a = np.array([1.0, 2.0 * (K * K - 1.0) * n, (1.0 - np.sqrt(2.0) * K + K * K) * n])
    return b, a

def _lfilter(b, a, x):
    y = np.empty_like(x)
    # start in steady state for the first sample (step response initial condition)
    x1 = x2 = x[0]
    y1 = y2 = x[0]
    b0, b1, b2 = b
    a1, a2 = a[1], a[2]
    for i in range(len(x)):
        xi = x[i]
        yi = b0 * xi + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2
        y[i] = yi
        x2, x1 = x1, xi
        y2, y1 = y1, yi
    return y

def filtfilt(x, fc, fs):
    """Zero-phase forward-backward 2nd-order Butterworth (effective 4th order,
    -6 dB at fc). Odd-reflection padding of 3/fc seconds at both ends."""
    b, a = butter2(fc, fs)
    npad = min(len(x) - 1, int(3.0 * fs / fc))
    xp = np.concatenate([2 * x[0] - x[npad:0:-1], x, 2 * x[-1] - x[-2:-npad - 2:-1]])
    y = _lfilter(b, a, xp)
    y = _lfilter(b, a, y[::-1])[::-1]
    return y[npad:npad + len(x)]

def ols(X, y):
    th, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ th
    dof = max(1, len(y) - X.shape[1])
    s2 = r @ r / dof
    cov = s2 * np.linalg.inv(X.T @ X)
    return th, np.sqrt(np.diag(cov)), r

def block_bootstrap(X, y, block, nboot=200, seed=1):
    """Moving-block bootstrap of rows (keeps the serial correlation of the
    residuals inside blocks). Returns the std of the parameter estimates."""
    rng = np.random.default_rng(seed)
    n = len(y)
    nb = int(np.ceil(n / block))
    starts_max = n - block
    est = []
    for _ in range(nboot):
        s = rng.integers(0, starts_max + 1, nb)
        idx = (s[:, None] + np.arange(block)[None, :]).ravel()[:n]
        th, *_ = np.linalg.lstsq(X[idx], y[idx], rcond=None)
        est.append(th)
    return np.std(np.array(est), axis=0, ddof=1)
# ---- end shared helpers ----

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
