"""Gain and read noise of deep sub-electron sensors from the photon-counting histogram
(Starkey and Fossum, IEEE J. Electron Devices Soc. 4(3), 2016).

At low light the values of a stack of a uniformly lit, non-uniformity-free region are a
Poisson mixture of Gaussians, one per electron number ``k``::

    p(x) = sum_k Pois(k; H) * N(x; o + K k, (K sigma_e)^2)

with the conversion gain ``K`` (DN/e-), read noise ``sigma_e`` (e-), mean electrons ``H``
and offset ``o`` (DN). Integer codes are fitted as the integral of each Gaussian over its
code's width (the quantizer), by weighted least squares on the code histogram (first with
the counts as weights, then iteratively reweighted with the model's own Poisson variance:
the maximum-likelihood fit); the SEs are its inverse Fisher information. With the dark
stack of the same exposure its histogram is fitted jointly (same offset and read noise,
its own small charge when one is measurable).

Starting points (the comb likelihood has a minimum at every wrong spacing): the dark's
zero-electron peak (place, width, and the light values' share below it: P(0) = exp(-H)),
the light histogram's mode as the zero peak, and each strong periodic component of the
histogram over periods of 2 codes to its whole span (at low light the spacing is wider
than the values' spread: an earlier search that stopped at twice the spread gave "not
available" at 0.15 e- read noise), anchored at the mode; each also refined by regressing
the peaks' centroids on the electron number. The lowest Poisson deviance wins.

Verdicts on the measured scatter (``_judge``): the histogram's scatter about the fit against
its Poisson expectation (above it the SEs are scaled by its square root, far above it the
model fails); the stack's own variance against the fitted mixture's (inconsistent photon
counts); the fitted read noise with its SE against the merging of the peaks (above
``MERGED_E`` by 2 SE "not available", between ``READ_NOISE_LIMIT_E`` and it said so); K
to better than 5 %. Peaks narrower than half a code (K sigma_e < ``SUB_LSB_DN``) hide their
width in the quantizer: K from the fit with the width held, the read noise an upper limit.
Measured over the corpus (benchmarks/photon_counting_corpus.md).

``photon_transfer`` gives the photon-transfer estimate of the same stack (light and dark
means and temporal variances) to show beside it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.optimize import OptimizeWarning, curve_fit
from scipy.special import gammaln, ndtr

from ares.analysis.stats.estimate import Estimate

READ_NOISE_LIMIT_E = 0.5  # above it the electron peaks merge (Starkey & Fossum 2016)
# the precision a photon-counting K and read noise are meant to have (issue 48: K to 0.5 %,
# read noise to 3 %); a fit whose 3 SE exceed it keeps its number, but its verdict says the
# precision is not enough and how many values (SE ~ 1/sqrt(values)) would reach it
K_TARGET = 0.005
RN_TARGET = 0.03
PRECISION_VERDICT = "precision not enough"
MERGED_E = 0.6  # a fitted read noise above this (by 2 SE) is "not available": no valley between the peaks


def _pmf(H: float, kmax: int) -> np.ndarray:
    h = max(float(H), 1e-12)
    k = np.arange(kmax + 1)
    return np.exp(k * math.log(h) - h - gammaln(k + 1.0))


def _kmax(H: float) -> int:
    H = max(float(H), 0.0)
    return int(H + 8 * math.sqrt(H) + 8)


def _model(x, K, s_e, H, o, n_total):
    """Expected counts at the integer codes ``x`` (consecutive): each Gaussian integrated over
    its code's width, the code boundaries' CDF computed once."""
    top = (x[-1] + 0.5 - o) / max(abs(K), 1e-3) + 4  # peaks above the codes add nothing
    w = _pmf(H, int(min(_kmax(H), max(top, 1.0), 5000)))[:, None]
    k = np.arange(w.shape[0])[:, None]
    s = min(max(abs(K * s_e), 1e-6), 1e12)
    edges = np.append(x - 0.5, x[-1] + 0.5)
    cdf = ndtr((edges[None, :] - (o + K * k)) / s)
    return n_total * np.sum(w * np.diff(cdf, axis=1), axis=0)


class _Joint:
    """The light histogram, and the dark one when given (same offset and read noise, its own
    small mean charge: dark current and clock-induced charge), as one vector of expected
    counts over both histograms' bins; parameters ``K, s_e, H, o[, H_dark]``."""

    def __init__(self, codes, h, dcodes=None, dh=None, dark_charge=True):
        self.codes, self.h = codes, h
        self.dcodes, self.dh = dcodes, dh
        self.n, self.nd = float(h.sum()), float(dh.sum()) if dh is not None else 0.0
        self.dark_charge = dh is not None and dark_charge
        self.y = h if dh is None else np.concatenate([h, dh])
        self.x = np.arange(self.y.size, dtype=np.float64)

    def __call__(self, _x, K, s_e, H, o, *hd):
        m = _model(self.codes, K, s_e, H, o, self.n)
        if self.dh is None:
            return m
        Hd = abs(hd[0]) if self.dark_charge else 0.0
        return np.concatenate([m, _model(self.dcodes, K, s_e, Hd, o, self.nd)])


def _deviance(h, m) -> float:
    m = np.maximum(m, 1e-12)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(h > 0, h * np.log(h / m), 0.0)
    return float(2 * np.sum(m - h + t))


def _comb_start(codes: np.ndarray, h: np.ndarray, K: float) -> float:
    """Where the comb of spacing K starts: a tooth at the histogram's mode (always on an
    electron peak), stepped down by K to the lowest one inside the values (their 0.2 %
    quantile less half a spacing)."""
    mode = float(codes[int(np.argmax(h))])
    lo = float(codes[int(np.searchsorted(np.cumsum(h) / h.sum(), 0.002))])
    return mode - K * math.floor((mode - lo) / K + 0.5)


def _gain_guesses(codes: np.ndarray, h: np.ndarray) -> list[float]:
    """Candidate comb spacings: the strong periodic components of the histogram less its
    single-Gaussian envelope, over periods of 2 codes to the histogram's whole span (at low
    light the spacing is far wider than the values' spread)."""
    n = h.sum()
    mu = float((codes * h).sum() / n)
    sd = math.sqrt(float((h * (codes - mu) ** 2).sum() / n))
    res = h - n * (ndtr((codes + 0.5 - mu) / max(sd, 0.3)) - ndtr((codes - 0.5 - mu) / max(sd, 0.3)))
    span = max(float(codes[-1] - codes[0]), 4.0)
    f = np.linspace(1.0 / span, 0.5, 4000)
    amp = np.abs(np.exp(-2j * np.pi * np.outer(f, codes - mu)) @ res)
    top = float(amp.max())
    a = np.concatenate([[0.0], amp, [0.0]])  # the ends count (period 2: f = 0.5)
    pk = np.nonzero((a[1:-1] >= a[:-2]) & (a[1:-1] >= a[2:]) & (amp >= 0.3 * top))[0]
    pk = pk[np.argsort(-amp[pk])][:4]
    return [float(1.0 / f[i]) for i in pk] or [float(1.0 / f[int(np.argmax(amp))])]


def _below(codes, h, x: float) -> float:
    """The fraction of values below ``x`` (DN), each code's count spread evenly over its width."""
    inside = np.clip(x - (codes - 0.5), 0.0, 1.0)
    return float(np.sum(h * inside) / h.sum())


def _zero_peak_start(codes, h, o0: float, sd_dn: float, p_below: float):
    """A start from the zero-electron peak at ``o0`` (DN) of width ``sd_dn``: the light values
    below ``o0`` over the zero peak's own share there (``p_below``: from the dark stack, or
    1/2 at the light histogram's own mode) give P(0 e-) = exp(-H)."""
    p0 = min(max(_below(codes, h, o0) / max(p_below, 1e-3), 1e-3), 0.999)
    H0 = -math.log(p0)
    mean = float((codes * h).sum() / h.sum())
    K0 = (mean - o0) / H0
    if not (math.isfinite(K0) and K0 > 0.5):
        return None
    return K0, min(max(sd_dn / K0, 0.03), 1.0), H0, o0


def _refine(codes, h, K0: float, o0: float, rounds: int = 3):
    """A comb start made from the histogram: the centroids of the values within 0.3 K of each
    tooth, regressed on the electron number (weighted by their counts), give K and the offset;
    the values' spread about their centroids the width; the mean the charge."""
    K, o = K0, o0
    n = h.sum()
    mean = float((codes * h).sum() / n)
    for _ in range(rounds):
        if not (math.isfinite(K) and K >= 1.0):
            return None
        k = np.rint((codes - o) / K)
        near = (np.abs(codes - o - k * K) <= 0.3 * K) & (k >= 0)
        ks = np.unique(k[near])
        w = np.array([h[near & (k == j)].sum() for j in ks])
        if ks.size < 2 or np.count_nonzero(w >= 5) < 2:
            return None
        c = np.array([np.sum(codes[near & (k == j)] * h[near & (k == j)]) / max(wj, 1) for j, wj in zip(ks, w)])
        ok = w >= 5
        K, o = np.polyfit(ks[ok], c[ok], 1, w=np.sqrt(w[ok]))
        K, o = float(K), float(o)
        sd = math.sqrt(max(float(sum(np.sum(h[near & (k == j)] * (codes[near & (k == j)] - (o + j * K)) ** 2)
                                     for j in ks[ok]) / w[ok].sum()) - 1 / 12, 0.01))
    H = (mean - o) / K
    if not (math.isfinite(K) and K >= 1.0 and H > 0.001):
        return None
    return K, min(max(sd / K, 0.02), 1.0), H, o


def _starts(codes, h, dcodes, dh) -> list[tuple]:
    """Starting points: from the dark stack's zero peak, from the light histogram's mode as
    the zero peak (low light), and from each strong comb spacing anchored at the mode."""
    out = []
    if dh is not None:
        nd = dh.sum()
        md = float((dcodes * dh).sum() / nd)
        vd = float((dh * (dcodes - md) ** 2).sum() / nd)
        out.append(_zero_peak_start(codes, h, md, math.sqrt(max(vd - 1 / 12, 0.01)), _below(dcodes, dh, md)))
    i = int(np.argmax(h))
    near = slice(max(i - 1, 0), i + 2)
    c = float(np.sum(codes[near] * h[near]) / h[near].sum())  # the mode peak's centre
    left = codes < c
    sdl = math.sqrt(max(float(np.sum(h[left] * (codes[left] - c) ** 2) / max(h[left].sum(), 1)), 0.01))
    out.append(_zero_peak_start(codes, h, c, sdl, 0.5))
    mean = float((codes * h).sum() / h.sum())
    for K0 in _gain_guesses(codes, h):
        if not K0 >= 1.0:
            continue
        for j in (0, -1, 1):
            o0 = _comb_start(codes, h, K0) + j * K0
            H0 = (mean - o0) / K0
            if H0 > 0.01:
                out.append((K0, 0.3, H0, o0))
    out = [s for s in out if s is not None]
    return out + [r for r in (_refine(codes, h, K0, o0) for K0, _, _, o0 in out) if r is not None]


def fit_histogram(values, *, dark=None, read_noise_limit_e: float = READ_NOISE_LIMIT_E) -> dict:
    """``{"K", "read_noise_e", "mean_e", "offset_dn"}`` Estimates (and the histogram and model
    for the report) from the integer values of a low-light stack (any shape), and of the dark
    stack of the same exposure when given (``dark``: fitted jointly, same offset and read noise)."""
    lh = _histogram(values, "light")
    if isinstance(lh, str):
        return _na(lh)
    dk = {}
    if dark is not None:
        dh = _histogram(dark, "dark")
        if isinstance(dh, str):
            return _na(dh)
        dk = {"dark_codes": dh[0], "dark_counts": dh[1]}
    return fit_code_histogram(*lh, read_noise_limit_e=read_noise_limit_e, **dk)


def _histogram(values, what):
    v = np.asarray(values).ravel()
    if v.size < 1000:
        return f"only {v.size} {what} values; the histogram needs at least 1000"
    if not np.all(np.isfinite(v)):
        return f"the {what} stack holds non-finite values"
    lo, hi = int(np.floor(v.min())), int(np.ceil(v.max()))
    if hi - lo > 100000:
        return f"the {what} values span {hi - lo} codes; a photon-counting histogram needs a low-light stack"
    return np.arange(lo, hi + 1), np.bincount(np.rint(v).astype(np.int64) - lo, minlength=hi - lo + 1)


_UNIT = {"K": "DN/e-", "read_noise_e": "e-", "mean_e": "e-", "offset_dn": "DN"}


def _na(why, extra=None):
    out = {k: Estimate.na(why, u) for k, u in _UNIT.items()}
    out.update(extra or {})
    return out


def _trim(codes, counts):
    codes = np.asarray(codes, np.float64)
    h = np.asarray(counts, np.float64)
    nz = np.nonzero(h)[0]
    if nz.size == 0 or h.sum() < 1000:
        return f"only {int(h.sum())} values; the histogram needs at least 1000"
    codes, h = codes[nz[0]:nz[-1] + 1], h[nz[0]:nz[-1] + 1]
    if codes.size > 1 and np.any(np.diff(codes) != 1):
        return "the histogram's codes are not consecutive integers (one count per code is needed)"
    return codes, h


def _fit_one(J, p0):
    try:
        with warnings.catch_warnings():  # a singular covariance here: the ML rounds follow
            warnings.simplefilter("ignore", OptimizeWarning)
            p, _ = curve_fit(J, J.x, J.y, p0=p0, sigma=np.sqrt(np.maximum(J.y, 1.0)))
        p, cov = _poisson_ml(J, J.x, J.y, p)
    except (RuntimeError, ValueError):
        return None
    m = J(J.x, *p)
    return _deviance(J.y, m), p, cov


def fit_code_histogram(codes, counts, *, dark_codes=None, dark_counts=None,
                       read_noise_limit_e: float = READ_NOISE_LIMIT_E) -> dict:
    """As ``fit_histogram``, from a histogram of consecutive integer codes (``counts[i]``
    values at ``codes[i]``; the zero-count ends are trimmed), and the dark stack's histogram
    when given."""
    t = _trim(codes, counts)
    if isinstance(t, str):
        return _na(t)
    codes, h = t
    dcodes = dh = None
    if dark_counts is not None:
        t = _trim(dark_codes, dark_counts)
        if isinstance(t, str):
            return _na("dark stack: " + t)
        dcodes, dh = t
    n = float(h.sum())
    mean = float((codes * h).sum() / n)
    var = float((h * (codes - mean) ** 2).sum() / n)
    J = _Joint(codes, h, dcodes, dh)
    best = None
    for K0, s0, H0, o0 in _starts(codes, h, dcodes, dh):
        r = _fit_one(J, [K0, s0, H0, o0] + ([0.01] if J.dark_charge else []))
        if r is not None and np.isfinite(r[0]) and (best is None or r[0] < best[0]):
            best = r
    if best is None:
        return _na(f"no electron peaks in the histogram (read noise {_rn_from_ptc(mean, var, _gain_guesses(codes, h)[0])} "
                   f"too high for separated peaks; limit ~{read_noise_limit_e:g} e-)")
    _, p, cov = best
    if J.dark_charge and not (np.isfinite(cov[4, 4]) and abs(p[4]) > 2 * math.sqrt(max(cov[4, 4], 0))):
        J0 = _Joint(codes, h, dcodes, dh, dark_charge=False)  # no dark charge measurable: not a parameter
        r = _fit_one(J0, list(p[:4]))
        if r is not None:
            J, (_, p, cov) = J0, r
    sub_lsb = None
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    if abs(p[0] * p[1]) < SUB_LSB_DN and not (np.all(np.isfinite(se)) and se[0] < 0.05 * abs(p[0])):
        # peaks inside one code: the offset's place within it and the width trade off (only the
        # leak over one code edge is seen); K from the fit with the width held
        s_fix = float(abs(p[1]))
        Jf = _Fixed(J, s_fix)
        r = _fit_one(Jf, [p[0], p[2], p[3]] + list(p[4:]))
        if r is not None:
            _, q, cq = r
            p = np.concatenate([[q[0], s_fix], q[1:]])
            cov = np.zeros((p.size, p.size))
            idx = [0] + list(range(2, p.size))
            cov[np.ix_(idx, idx)] = cq
            sub_lsb = s_fix
    return _judge(J, p, cov, mean, var, read_noise_limit_e, sub_lsb)


SUB_LSB_DN = 0.5  # peaks narrower than this (sigma, DN) sit inside one code


class _Fixed:
    """``_Joint`` with the read noise held (a peak inside one code: its width not measurable)."""

    def __init__(self, J, s_e):
        self.J, self.s_e, self.x, self.y = J, s_e, J.x, J.y

    def __call__(self, x, K, H, o, *hd):
        return self.J(x, K, self.s_e, H, o, *hd)
MAX_SCATTER = 25.0  # histogram scatter about the fit over its Poisson expectation: beyond, the model fails


def _judge(J, p, cov, mean, var, limit, sub_lsb=None) -> dict:
    """The fit's verdicts, each on the data's measured scatter: the histogram's Pearson
    scatter about the fit (over bins expecting >= 5 counts) against its Poisson expectation
    (above it the SEs are scaled by its square root, and said so; far above it the model does
    not describe the data); the stack's own variance against the fitted mixture's; the peaks'
    separation as the fitted read noise with its SE against the limit; K's relative SE."""
    K, s_e, H, o = float(p[0]), abs(float(p[1])), float(p[2]), float(p[3])
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    m_all = J(J.x, *p)
    use = m_all >= 5
    ndf = max(int(use.sum()) - len(p), 1)
    ratio = float(np.sum((J.y[use] - m_all[use]) ** 2 / m_all[use]) / ndf)
    m = m_all[:J.h.size]
    extra = {"hist_codes": J.codes, "hist_counts": J.h, "hist_model": m, "chi2_ndf": ratio}
    how = "photon-counting histogram fit (Starkey & Fossum 2016)" + (" with the dark stack" if J.dh is not None else "")
    if sub_lsb is not None:
        se[1] = 0.0  # held: judged below as an upper limit
    if ratio > MAX_SCATTER or not np.all(np.isfinite(se)):
        return _na(f"the electron-peak model does not describe the histogram (scatter {ratio:.3g}x its Poisson "
                   "expectation about the best fit): no separated electron peaks", extra)
    if ratio > 1 + 4 * math.sqrt(2.0 / ndf):  # the measured scatter wins over the Poisson SEs
        se = se * math.sqrt(ratio)
        how += f"; SE scaled by sqrt of the histogram's scatter about the fit ({ratio:.3g}x its Poisson expectation)"
    else:
        how += "; SE from the Poisson Fisher information"
    n = J.n
    var_m = float(np.sum(m * (J.codes - np.sum(m * J.codes) / m.sum()) ** 2) / m.sum())
    m4 = float(np.sum(J.h * (J.codes - mean) ** 4) / n)
    z = abs(var_m - var) / math.sqrt(max((m4 - var * var) / n, 1e-12))
    if z > 5 * max(1.0, math.sqrt(ratio)):
        return _na(f"the fitted peaks' variance {var_m:.4g} DN^2 disagrees with the stack's own {var:.4g} DN^2 "
                   f"by {z:.3g} SE: inconsistent photon counts", extra)
    if s_e - 2 * se[1] > max(limit, MERGED_E * limit / READ_NOISE_LIMIT_E):
        return _na(f"read noise {s_e:.2f} ± {se[1]:.2f} e- too high for separated peaks (limit ~{limit:g} e-)", extra)
    if se[0] > 0.05 * K:
        return _na(f"the electron peaks are not resolved: K {K:.3g} DN/e- only to {100 * se[0] / K:.2g} % "
                   f"(read noise ~{s_e:.2f} e-, {H:.3g} e-/pixel)", extra)
    if s_e > limit:
        how += f"; read noise at the peaks' separation limit (~{limit:g} e-)"
    rn = Estimate(s_e, float(se[1]), "e-", how)
    if sub_lsb is not None:
        rn = Estimate.limit(SUB_LSB_DN / K, "upper", "e-", f"the electron peaks are narrower than one code "
                            f"(K x read noise < {SUB_LSB_DN:g} DN): the quantizer hides their width; only an upper limit")
    n_values = float(J.n + J.nd)
    short = _precision(K, float(se[0]), K_TARGET, n_values)
    if rn.bound == "" and s_e > 0:
        rn_short = _precision(s_e, float(se[1]), RN_TARGET, n_values)
        if rn_short:
            extra["precision_read_noise_e"] = ("read noise to ±" + rn_short[0] + ": " + RN_NEEDS.format(
                pct=100 * RN_TARGET) + rn_short[1], rn_short[2])
    if short:
        extra["precision_K"] = ("K to ±" + short[0] + ": " + K_NEEDS.format(pct=100 * K_TARGET) + short[1], short[2])
    out = {"K": Estimate(K, float(se[0]), "DN/e-", how), "read_noise_e": rn,
           "mean_e": Estimate(H, float(se[2]), "e-", how), "offset_dn": Estimate(o, float(se[3]), "DN", how)}
    out.update(extra)
    return out


NEED_MARGIN = 1.25  # a quarter more values than put 3 SE exactly at the target
K_NEEDS = "{pct:g} % at 3 SE needs "
RN_NEEDS = "{pct:g} % at 3 SE needs "


def _precision(value: float, se: float, target: float, n_values: float):
    """None where 3 SE are within ``target`` (relative); else (the relative SE as text, the
    values needed as text, the values needed): the SE falls as 1/sqrt(values), so
    ``n (3 SE / (target value))^2`` values bring 3 SE to the target (the light and dark
    histograms alike) -- and NEED_MARGIN times that bring it inside: 54 corpus cells re-taken
    with exactly that many landed at the boundary (SE 0.162-0.170 % for 0.167 %), half of
    them just outside (benchmarks/photon_counting_corpus.md)."""
    if not (value > 0 and math.isfinite(se)) or 3 * se <= target * value:
        return None
    need = int(math.ceil(NEED_MARGIN * n_values * (3 * se / (target * value)) ** 2))
    return f"{100 * se / value:.2g} % (1 SE)", f">= {need} values ({need / n_values:.3g}x these {n_values:.0f})", need


def _poisson_ml(f, codes, h, p, rounds: int = 8):
    """The Poisson maximum-likelihood fit by iteratively reweighted least squares (weights the
    model's own variance, re-evaluated until the parameters stop moving), and its covariance:
    the inverse Fisher information ``(J^T V^-1 J)^-1``, the counts' Poisson variance taken as
    known (``absolute_sigma``; rescaling by the reduced chi-square would shrink it by the
    near-empty tail bins' small Pearson terms)."""
    for _ in range(rounds):
        m = np.maximum(f(codes, *p), 1e-3)
        with warnings.catch_warnings():  # a singular covariance comes back as inf: judged by the caller
            warnings.simplefilter("ignore", OptimizeWarning)
            q, cov = curve_fit(f, codes, h, p0=p, sigma=np.sqrt(m), absolute_sigma=True)
        se = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
        done = bool(np.all(np.abs(q - p) < 1e-3 * se))
        p = q
        if done:
            break
    return p, cov


def _rn_from_ptc(mean, var, K) -> str:
    return "unknown" if not (math.isfinite(K) and K > 0) else f"~{math.sqrt(max(var, 0)) / K:.2f} e-"


def photon_transfer(light, dark) -> dict:
    """The photon-transfer estimate from a light and a dark stack (frames, ...)."""
    L = np.asarray(light, np.float64).reshape(len(light), -1)
    D = np.asarray(dark, np.float64).reshape(len(dark), -1)
    return photon_transfer_levels(float(L.mean()), float(np.mean(np.var(L, axis=0, ddof=1))), L.shape[0],
                                  float(D.mean()), float(np.mean(np.var(D, axis=0, ddof=1))), D.shape[0], L.shape[1])


def photon_transfer_levels(mean_l, var_l, frames_l, mean_d, var_d, frames_d, pixels) -> dict:
    """K from the light and dark temporal variances over the mean difference (EMVA 1288 4.0
    Linear Eq. 43's two-point form), read noise = dark temporal sigma / K; SEs by first-order
    propagation of the pooled sample variances (var of one ~ 2 v^2 / (pixels (frames - 1)))."""
    dm = mean_l - mean_d
    if not dm > 0:
        why = "the light stack is not brighter than the dark stack"
        return {"K": Estimate.na(why, "DN/e-"), "read_noise_e": Estimate.na(why, "e-")}
    K = (var_l - var_d) / dm
    se_vl = var_l * math.sqrt(2.0 / max(pixels * (frames_l - 1), 1))
    se_vd = var_d * math.sqrt(2.0 / max(pixels * (frames_d - 1), 1))
    se_K = math.hypot(se_vl, se_vd) / dm
    rn = math.sqrt(max(var_d, 0)) / K
    se_rn = rn * math.hypot(se_vd / (2 * var_d) if var_d > 0 else 0.0, se_K / K)
    how = "photon transfer (light and dark temporal variances)"
    return {"K": Estimate(K, se_K, "DN/e-", how), "read_noise_e": Estimate(rn, se_rn, "e-", how)}


def result_dict(fit: dict, pt: dict | None = None) -> dict:
    """The JSON form of a fit (and its photon-transfer estimate), as the report page reads it."""
    res = {k: fit[k].to_dict() for k in ("K", "read_noise_e", "mean_e", "offset_dn")}
    for k in ("K", "read_noise_e"):  # a number whose 3 SE exceed the method's target: not "ok"
        if f"precision_{k}" in fit and res[k]["verdict"] == "ok":
            why, need = fit[f"precision_{k}"]
            res[k].update(verdict=PRECISION_VERDICT, precision=why, needs_values=need)
    if "hist_codes" in fit:
        res["histogram"] = {"codes": [int(c) for c in fit["hist_codes"]], "counts": [int(c) for c in fit["hist_counts"]],
                            "model": [round(float(m), 3) for m in fit["hist_model"]],
                            "chi2_ndf": round(fit["chi2_ndf"], 3)}
    if pt:
        res["photon_transfer"] = {k: e.to_dict() for k, e in pt.items()}
    return res
