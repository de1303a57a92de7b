"""Weighted nonlinear least squares for ARES's small fits (the PTC's Astier model, the
panels' Gaussian): Levenberg-Marquardt in numpy, so that no run, ``ares emva`` or panel
imports scipy.optimize for them (~0.4 s; ``scipy.interpolate`` brings it too).

Pure numpy: no I/O.
"""

from __future__ import annotations

import math

import numpy as np


def levenberg_marquardt(model, y, sig, p0, scale=None, max_iter: int = 200, rtol: float = 1e-13):
    """Weighted least squares ``sum(((y - model(p)) / sig)^2)`` from ``p0`` by
    Levenberg-Marquardt (Marquardt's diagonal scaling, forward-difference Jacobian with
    MINPACK's relative steps, at least ``sqrt(eps) * scale`` -- a parameter's typical size,
    for one that starts at 0): (p, covariance inv(J^T J) at p), or None when it does not
    converge.
    What ``scipy.optimize.curve_fit(..., absolute_sigma=True)`` returns, converged to
    ``rtol`` instead of MINPACK's 1.5e-8 (equal to it within that; tested)."""
    p = np.asarray(p0, float).copy()
    h0 = math.sqrt(np.finfo(float).eps)
    floor = h0 * (np.abs(p) if scale is None else np.maximum(np.abs(np.asarray(scale, float)), np.abs(p)))

    def resid(q):
        return (y - model(q)) / sig

    def jac(q, r):  # d(model / sig)/dq: minus the residuals' derivative
        J = np.empty((r.size, q.size))
        for j in range(q.size):
            h = max(h0 * abs(q[j]), floor[j]) or h0
            qh = q.copy()
            qh[j] += h
            J[:, j] = (r - resid(qh)) / h
        return J

    r = resid(p)
    cost = float(r @ r)
    if not math.isfinite(cost):
        return None
    lam = 1e-3
    for _ in range(max_iter):
        J = jac(p, r)
        A, g = J.T @ J, J.T @ r
        d = np.diag(A).copy()
        d[d <= 0] = 1.0
        while True:
            try:
                step = np.linalg.solve(A + lam * np.diag(d), g)
            except np.linalg.LinAlgError:
                step = None
            if step is not None:
                pn = p + step
                with np.errstate(over="ignore", invalid="ignore"):  # a wild trial step: rejected below
                    rn = resid(pn)
                    cn = float(rn @ rn)
                if math.isfinite(cn) and cn <= cost:
                    break
            lam *= 10.0
            if lam > 1e16:  # no step lowers the cost: p is the minimum
                step = np.zeros_like(p)
                pn, rn, cn = p, r, cost
                break
        # converged when the step is negligible in Marquardt's scaled norm (MINPACK's xtol
        # test: a parameter at 0 does not demand an absolute step of 0) or the cost no
        # longer falls (ftol)
        w = np.sqrt(d)
        done = (float(np.linalg.norm(step * w)) <= rtol * float(np.linalg.norm(p * w))
                or cost - cn <= rtol * cost or cn == 0.0)
        p, r, cost = pn, rn, cn
        lam = max(lam / 10.0, 1e-12)
        if done:
            try:
                J = jac(p, r)
                return p, np.linalg.inv(J.T @ J)
            except np.linalg.LinAlgError:
                return None
    return None
