"""Baum-Welch for Gaussian hidden Markov models with one shared sigma, one series at a time
(numba, ``ares.analysis.kernels.jit``): the numpy path (``ares.analysis.lowlight.rtn.fit_hmm``)
steps through time for all series at once, ~10 small array operations a frame, which is the
cost of a long series; here each frame of each series is a few scalar loops. Same start, same
updates, each series stops on its own once its log-likelihood changes by less than
``tol x frames`` (the numpy path when all have): equal to it within the tolerance (tested).
Among ``jit.KERNEL_MODULES``: compiled once at install (``python -m ares.jit``, ``warm``), so
the first ``ares rtn`` does not pay for it."""

from __future__ import annotations

import math

import numpy as np

_kernel_c = None
_loaded = False


def _kernel(x, mu_init, var_init, iters, tol, mu_o, var_o, a_o, occ_o, dep_o, ll_o):
    F, n = x.shape
    k = mu_init.shape[1]
    alpha = np.empty((F, k))
    b = np.empty((F, k))
    c = np.empty(F)
    beta = np.empty(k)
    nb = np.empty(k)
    bb = np.empty(k)
    A = np.empty((k, k))
    pi = np.empty(k)
    mu = np.empty(k)
    gs = np.empty(k)
    gx = np.empty(k)
    gx2 = np.empty(k)
    g0 = np.empty(k)
    xis = np.empty((k, k))
    for j in range(n):
        for a in range(k):
            mu[a] = mu_init[j, a]
            pi[a] = 1.0 / k
            for q in range(k):
                A[a, q] = 0.9 if a == q else 0.1 / (k - 1)
        var = var_init[j]
        prev = -np.inf
        ll = 0.0
        for _it in range(iters):
            off = -0.5 * F * math.log(2 * math.pi * var)
            for t in range(F):
                zmin = np.inf
                for a in range(k):
                    z = (x[t, j] - mu[a]) ** 2 / var
                    b[t, a] = z
                    if z < zmin:
                        zmin = z
                for a in range(k):
                    b[t, a] = math.exp(-0.5 * (b[t, a] - zmin))
                off -= 0.5 * zmin
            s = 0.0
            for a in range(k):
                alpha[0, a] = pi[a] * b[0, a]
                s += alpha[0, a]
            c[0] = s
            for a in range(k):
                alpha[0, a] /= s
            for t in range(1, F):
                s = 0.0
                for q in range(k):
                    acc = 0.0
                    for a in range(k):
                        acc += alpha[t - 1, a] * A[a, q]
                    v = acc * b[t, q]
                    alpha[t, q] = v
                    s += v
                c[t] = s
                for q in range(k):
                    alpha[t, q] /= s
            ll = off
            for t in range(F):
                ll += math.log(c[t])
            xl = x[F - 1, j]
            for a in range(k):
                beta[a] = 1.0
                g = alpha[F - 1, a]
                gs[a] = g
                gx[a] = g * xl
                gx2[a] = g * xl * xl
                g0[a] = g
                for q in range(k):
                    xis[a, q] = 0.0
            for t in range(F - 2, -1, -1):
                ct = c[t + 1]
                for q in range(k):
                    bb[q] = b[t + 1, q] * beta[q]
                for a in range(k):
                    acc = 0.0
                    for q in range(k):
                        v = A[a, q] * bb[q]
                        xis[a, q] += alpha[t, a] * v / ct
                        acc += v
                    nb[a] = acc / ct
                xt = x[t, j]
                for a in range(k):
                    beta[a] = nb[a]
                    g = alpha[t, a] * nb[a]
                    gs[a] += g
                    gx[a] += g * xt
                    gx2[a] += g * xt * xt
                    g0[a] = g
            sq = 0.0
            for a in range(k):
                m = gx[a] / max(gs[a], 1e-12)
                sq += gx2[a] - 2 * m * gx[a] + m * m * gs[a]
                mu[a] = m
            var = max(sq / F, 1e-12)
            for a in range(k):
                row = 0.0
                for q in range(k):
                    row += xis[a, q]
                for q in range(k):
                    A[a, q] = xis[a, q] / max(row, 1e-300)
            s = 0.0
            for a in range(k):
                s += g0[a]
            for a in range(k):
                pi[a] = g0[a] / s
            if abs(ll - prev) < tol * F:
                break
            prev = ll
        for a in range(k):
            mu_o[j, a] = mu[a]
            occ_o[j, a] = gs[a]
            d = 0.0
            for q in range(k):
                a_o[j, a, q] = A[a, q]
                if q != a:
                    d += xis[a, q]
            dep_o[j, a] = d
        var_o[j] = var
        ll_o[j] = ll


def baum_welch(x: np.ndarray, mu_init: np.ndarray, var_init: np.ndarray, iters: int, tol: float):
    """(levels (n, k), variance (n,), transitions (n, k, k), occupancy (n, k), departures
    (n, k), log-likelihood (n,)), levels unsorted; None when numba is not there."""
    global _kernel_c, _loaded
    from ares.analysis.kernels import jit

    if not _loaded:
        _kernel_c, _loaded = jit.compiled(_kernel), True
    if _kernel_c is None:
        return None
    x = np.ascontiguousarray(x, np.float64)
    n, k = mu_init.shape
    mu, var, A = np.empty((n, k)), np.empty(n), np.empty((n, k, k))
    occ, dep, ll = np.empty((n, k)), np.empty((n, k)), np.empty(n)
    _kernel_c(x, np.ascontiguousarray(mu_init, np.float64), np.ascontiguousarray(var_init, np.float64), int(iters),
              float(tol), mu, var, A, occ, dep, ll)
    return mu, var, A, occ, dep, ll


def warm() -> None:
    """Compile (or load from numba's cache) the kernel on a tiny series."""
    x = np.array([0.0, 1.0, 0.1, 0.9, 0.0, 1.1, 0.05, 0.95])[:, None]  # (frames, series)
    baum_welch(x, np.array([[0.0, 1.0]]), np.array([0.1]), 2, 1e-6)
