"""Shared helpers of the folders' estimate.py scripts (numpy only, so that the independent
estimates run without SciPy): a zero-phase low-pass for the derivatives, ordinary least
squares with its standard errors, and a moving-block bootstrap.

Each script puts this folder on its path: sys.path.insert(0, os.path.dirname(HERE)).
"""
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
    x1 = x2 = y1 = y2 = x[0]  # start in steady state
    for k in range(len(x)):
        yk = b[0] * x[k] + b[1] * x1 + b[2] * x2 - a[1] * y1 - a[2] * y2
        y[k] = yk
        x2, x1 = x1, x[k]
        y2, y1 = y1, yk
    return y


def filtfilt(x, fc, fs):
    """Zero-phase forward-backward 2nd-order Butterworth (effective 4th order, -6 dB at fc),
    odd-reflection padding of 3/fc seconds at both ends."""
    b, a = butter2(fc, fs)
    npad = min(len(x) - 1, int(3.0 * fs / fc))
    xp = np.concatenate([2 * x[0] - x[npad:0:-1], x, 2 * x[-1] - x[-2:-npad - 2:-1]])
    y = _lfilter(b, a, xp)
    y = _lfilter(b, a, y[::-1])[::-1]
    return y[npad:npad + len(x)]


def ols(X, y):
    """Least squares: the parameters, their standard errors and the residual."""
    th, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ th
    s2 = r @ r / max(1, len(y) - X.shape[1])
    return th, np.sqrt(np.diag(s2 * np.linalg.inv(X.T @ X))), r


def relative_rms(r, y):
    """The residual's RMS over the fitted signal's standard deviation."""
    return np.sqrt(np.mean(r**2)) / np.std(y)


def block_bootstrap(X, y, block, nboot=200, seed=1):
    """Moving-block bootstrap of rows (keeps the serial correlation of the residuals inside
    blocks): the standard deviation of the parameter estimates."""
    rng = np.random.default_rng(seed)
    n = len(y)
    nb = int(np.ceil(n / block))
    est = []
    for _ in range(nboot):
        s = rng.integers(0, n - block + 1, nb)
        idx = (s[:, None] + np.arange(block)[None, :]).ravel()[:n]
        th, *_ = np.linalg.lstsq(X[idx], y[idx], rcond=None)
        est.append(th)
    return np.std(np.array(est), axis=0, ddof=1)
