"""Saturation / full-well criteria. Each returns a level index (or -1), never a guess.

- ``index_max_variance``: EMVA 1288 Release 3.0 -- the level of maximum temporal
  variance, searched from the brightest level down so that noise spikes above the
  peak are skipped (the reference implementation's rule; used by the reference set).
- ``index_max_code``: EMVA 1288 Release 4.0 -- the highest level (before the first
  violation) with no more than ``limit`` (0.2 %) of the samples at the maximum code.
- ``index_ptc_turnoff``: LSST-style -- fit the PTC, reject > ``nsigma`` residuals
  iteratively, then stop at the first gap in the kept levels that is larger than
  ``gap_factor`` times the typical spacing (measured as a ratio on log-spaced levels).
- ``index_linearity_turnoff``: last level before the first that deviates more than
  ``tol`` (1 %) from a straight line of signal vs exposure (or photons).
"""

from __future__ import annotations

import numpy as np


def index_max_variance(var) -> int:
    var = np.asarray(var, float)
    n = var.size
    if n == 0:
        return -1
    best, best_i = 0.0, 0
    for i in range(n - 1, -1, -1):
        prev = var[abs(i - 1)]
        if var[i] >= best or prev >= best:
            best, best_i = var[i], i
        elif var[i] < best and prev < best:
            break
    return best_i


def index_max_code(frac_at_max, limit: float = 0.002) -> int:
    f = np.asarray(frac_at_max, float)
    bad = np.nonzero(f > limit)[0]
    if bad.size == 0:
        return f.size - 1
    return int(bad[0]) - 1


def _spacing_ok(sig: np.ndarray) -> bool:
    """True when level spacing is closer to geometric than arithmetic."""
    if sig.size < 3 or np.any(sig <= 0):
        return False
    d = np.diff(sig)
    r = np.diff(np.log(sig))
    return np.std(r) / max(np.mean(r), 1e-12) < np.std(d) / max(np.mean(d), 1e-12)


def index_ptc_turnoff(signal, var, dof, nsigma: float = 5.0, gap_factor: float = 2.5,
                      max_iter: int = 20) -> tuple[int, np.ndarray]:
    """Return (index of the last kept level before a gap, boolean mask of kept levels).

    Residual scale: the Gaussian variance error ``V*sqrt(2/N)`` times a robust (MAD)
    inflation when the data scatter more than that (real sensors do).
    """
    s = np.asarray(signal, float)
    v = np.asarray(var, float)
    dof = np.broadcast_to(np.asarray(dof, float), s.shape)
    order = np.argsort(s)
    keep = (s > 0) & (v > 0)
    # pre-cut (LSST "variance pivot"): nothing above the level of maximum variance
    if keep.any():
        imax = order[np.argmax(np.where(keep[order], v[order], -np.inf))]
        keep &= s <= s[imax]
    # initial model: origin line through the lower half of the kept levels
    ks = np.sort(s[keep])
    if ks.size < 3:
        return (int(order[np.nonzero(keep[order])[0][-1]]) if keep.any() else -1), keep
    low = keep & (s <= ks[ks.size // 2])
    k0 = float(np.sum(s[low] * v[low]) / np.sum(s[low] ** 2))
    coef = np.array([0.0, k0, 0.0])
    for _ in range(max_iter):
        if keep.sum() < 3:
            break
        model = np.maximum(np.polyval(coef, s), 1e-12)
        sig = np.sqrt(2.0 / dof) * model  # weights from the model, never from the data
        deg = 2 if keep.sum() >= 6 else 1
        coef = np.polyfit(s[keep], v[keep], deg, w=1.0 / sig[keep])
        if deg == 1:
            coef = np.concatenate(([0.0], coef))
        model = np.maximum(np.polyval(coef, s), 1e-12)
        sig = np.sqrt(2.0 / dof) * model
        r = (v - model) / sig
        rk = r[keep]
        scale = max(1.0, 1.4826 * float(np.median(np.abs(rk - np.median(rk)))))
        if np.max(np.abs(rk)) <= nsigma * scale:
            break
        # drop only the worst point per iteration
        worst = np.argmax(np.where(keep, np.abs(r), -1))
        keep[worst] = False
    kept_sorted = [i for i in order if keep[i]]
    if not kept_sorted:
        return -1, keep
    ks = s[kept_sorted]
    log = _spacing_ok(s[order][s[order] > 0])
    steps = np.diff(np.log(ks)) if log else np.diff(ks)
    if steps.size == 0:
        return int(kept_sorted[0]), keep
    typical = float(np.median(steps))
    last = kept_sorted[0]
    for j, st in enumerate(steps):
        if st > gap_factor * typical:
            break
        last = kept_sorted[j + 1]
    # every level above the gap is beyond turnoff
    cut = s[last]
    keep &= s <= cut
    return int(last), keep


def index_linearity_turnoff(x, signal, tol: float = 0.01, fit_lo: float = 0.05,
                            fit_hi: float = 0.5) -> int:
    """Last index (in increasing ``x``) before the first level deviating > ``tol``
    from a line fitted over levels between ``fit_lo`` and ``fit_hi`` of the maximum signal."""
    x = np.asarray(x, float)
    s = np.asarray(signal, float)
    smax = np.nanmax(s)
    sel = (s >= fit_lo * smax) & (s <= fit_hi * smax)
    if sel.sum() < 2:
        return -1
    a, b = np.polyfit(x[sel], s[sel], 1)
    pred = a * x + b
    dev = np.abs(s - pred) / np.maximum(np.abs(pred), 1e-12)
    order = np.argsort(x)
    last = -1
    lo_x = x[sel].min()
    for i in order:
        if x[i] >= lo_x and dev[i] > tol:
            break
        last = int(i)
    return last
