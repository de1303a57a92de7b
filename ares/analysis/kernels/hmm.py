"""Baum-Welch for Gaussian hidden Markov models with one shared sigma, one series at a time
(numba, ``ares.analysis.kernels.jit``): the numpy path (``baum_welch_numpy``, used without numba)
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


def baum_welch_numpy(x, mu, var, iters, tol):
    """The numpy path of ``baum_welch`` (without numba): all columns at once, stepping through
    time; the same start and updates, stopping when every series has converged."""
    F, n = x.shape
    k = mu.shape[1]
    A = np.full((n, k, k), 0.1 / (k - 1))
    A[:, np.arange(k), np.arange(k)] = 0.9
    pi = np.full((n, k), 1.0 / k)
    alpha = np.empty((F, n, k))
    c = np.empty((F, n))
    prev_ll = np.full(n, -np.inf)
    for _ in range(iters):
        # emission densities (F, n, k), scaled per frame (the common factor cancels in gamma/xi)
        z = (x[:, :, None] - mu[None]) ** 2 / var[None, :, None]
        b = np.exp(-0.5 * (z - z.min(axis=2, keepdims=True)))
        logscale = -0.5 * z.min(axis=2) - 0.5 * np.log(2 * np.pi * var)[None, :]
        a = pi * b[0]
        c[0] = a.sum(1)
        alpha[0] = a / c[0][:, None]
        for t in range(1, F):
            a = np.einsum("nk,nkj->nj", alpha[t - 1], A) * b[t]
            c[t] = a.sum(1)
            alpha[t] = a / c[t][:, None]
        ll = np.log(c).sum(0) + logscale.sum(0)
        beta = np.ones((n, k))
        gamma_sum = np.zeros((n, k))
        xi_sum = np.zeros((n, k, k))
        mu_num = np.zeros((n, k))
        sq = np.zeros((n, k))
        g = alpha[F - 1] * beta
        gamma_sum += g
        mu_num += g * x[F - 1][:, None]
        sq += g * (x[F - 1] ** 2)[:, None]
        gamma0 = g
        for t in range(F - 2, -1, -1):
            bb = b[t + 1] * beta
            xi = alpha[t][:, :, None] * A * bb[:, None, :] / c[t + 1][:, None, None]
            xi_sum += xi
            beta = np.einsum("nkj,nj->nk", A, bb) / c[t + 1][:, None]
            g = alpha[t] * beta
            gamma_sum += g
            mu_num += g * x[t][:, None]
            sq += g * (x[t] ** 2)[:, None]
            gamma0 = g
        mu_new = mu_num / np.maximum(gamma_sum, 1e-12)
        # the shared variance around the new levels: sum g (x - mu)^2 = sum g x^2 - 2 mu sum g x + mu^2 sum g
        var = np.maximum((sq - 2 * mu_new * mu_num + mu_new**2 * gamma_sum).sum(1) / F, 1e-12)
        mu = mu_new
        A = xi_sum / np.maximum(xi_sum.sum(2, keepdims=True), 1e-300)
        pi = gamma0 / gamma0.sum(1, keepdims=True)
        if np.all(np.abs(ll - prev_ll) < tol * F):
            break
        prev_ll = ll
    dep = xi_sum.sum(2) - xi_sum[:, np.arange(k), np.arange(k)]
    return mu, var, A, gamma_sum, dep, ll


def warm() -> None:
    """Compile (or load from numba's cache) the kernel on a tiny series."""
    x = np.array([0.0, 1.0, 0.1, 0.9, 0.0, 1.1, 0.05, 0.95])[:, None]  # (frames, series)
    baum_welch(x, np.array([[0.0, 1.0]]), np.array([0.1]), 2, 1e-6)
