"""Gain and read noise of deep sub-electron sensors from the photon-counting histogram
(Starkey and Fossum, IEEE J. Electron Devices Soc. 4(3), 2016).

At low light the values of a stack of a uniformly lit, non-uniformity-free region are a
Poisson mixture of Gaussians, one per electron number ``k``::

    p(x) = sum_k Pois(k; H) * N(x; o + K k, (K sigma_e)^2)

with the conversion gain ``K`` (DN/e-), read noise ``sigma_e`` (e-), mean electrons ``H``
and offset ``o`` (DN). Integer codes are fitted as the integral of each Gaussian over its
code's width (the quantizer), by weighted least squares on the code histogram (first with
the counts as weights, then iteratively reweighted with the model's own Poisson variance:
the maximum-likelihood fit); the SEs are its inverse Fisher information (the sandwich
form with the residuals' own variance agrees with it within a few per cent on the simulator,
so the bins are not overdispersed). Measured against the simulator's truth
(benchmarks/beyond_linear.md): spread/SE 1.02 (K) and 0.99 (read noise) over 600 seeds at
0.45 e- where the peaks overlap most, as on stacks drawn by numpy alone from the model
(1.02, 1.01). An earlier 1.20 for the read noise came from one set of 120 seeds (200-319):
its bootstrap SE is 0.09 and one of its seeds sits 3.9 SEs out, so it was that set's
fluctuation, not a missing term (the offset and the mean are fitted with K and sigma_e, and
the full covariance's inverse is what is reported). Below about 0.5 e- read noise the peaks separate and the fit determines K and
sigma_e far better than photon transfer; above it the verdict is "not available".

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


def _model(x, K, s_e, H, o, n_total, kmax):
    """Expected counts at the integer codes ``x`` (consecutive): each Gaussian integrated over
    its code's width, the code boundaries' CDF computed once."""
    k = np.arange(kmax + 1)[:, None]
    h = max(float(H), 1e-12)
    w = np.exp(k * math.log(h) - h - gammaln(k + 1.0))  # Poisson pmf
    s = max(abs(K * s_e), 1e-6)
    edges = np.append(x - 0.5, x[-1] + 0.5)
    cdf = ndtr((edges[None, :] - (o + K * k)) / s)
    return n_total * np.sum(w * np.diff(cdf, axis=1), axis=0)


def _comb_start(codes: np.ndarray, h: np.ndarray, K: float) -> float:
    """Where the comb of spacing K sits: the phase of the histogram's K-periodic component."""
    ph = np.angle(np.sum(h * np.exp(-2j * np.pi * codes / K)))
    cdf = np.cumsum(h) / h.sum()
    lo = float(codes[int(np.searchsorted(cdf, 0.002))])
    base = ph / (2 * np.pi) * K
    return base + K * math.ceil((lo - base) / K - 0.5)


def _gain_guess(codes: np.ndarray, h: np.ndarray) -> float:
    """The comb spacing: the strongest periodic component of the histogram less its
    single-Gaussian envelope, over periods of 2 codes to twice the values' spread."""
    n = h.sum()
    mu = float((codes * h).sum() / n)
    sd = math.sqrt(float((h * (codes - mu) ** 2).sum() / n))
    res = h - n * (ndtr((codes + 0.5 - mu) / sd) - ndtr((codes - 0.5 - mu) / sd))
    f = np.linspace(1.0 / (2.0 * max(sd, 1.0)), 0.5, 4000)
    amp = np.abs(np.exp(-2j * np.pi * np.outer(f, codes - mu)) @ res)
    # sharp peaks put as much power in the harmonics: the lowest-frequency strong maximum
    top = float(amp.max())
    peaks = np.nonzero((amp[1:-1] >= amp[:-2]) & (amp[1:-1] >= amp[2:]) & (amp[1:-1] >= 0.5 * top))[0] + 1
    return float(1.0 / f[int(peaks[0]) if peaks.size else int(np.argmax(amp))])


def fit_histogram(values, *, read_noise_limit_e: float = READ_NOISE_LIMIT_E) -> dict:
    """``{"K", "read_noise_e", "mean_e", "offset_dn"}`` Estimates (and the histogram and model
    for the report) from the integer values of a low-light stack (any shape)."""
    v = np.asarray(values).ravel()
    if v.size < 1000:
        return _na(f"only {v.size} values; the histogram needs at least 1000")
    lo, hi = int(np.floor(v.min())), int(np.ceil(v.max()))
    if hi - lo > 100000:
        return _na(f"the values span {hi - lo} codes; a photon-counting histogram needs a low-light stack")
    h = np.bincount(np.rint(v).astype(np.int64) - lo, minlength=hi - lo + 1)
    return fit_code_histogram(np.arange(lo, hi + 1), h, read_noise_limit_e=read_noise_limit_e)


_UNIT = {"K": "DN/e-", "read_noise_e": "e-", "mean_e": "e-", "offset_dn": "DN"}


def _na(why, extra=None):
    out = {k: Estimate.na(why, u) for k, u in _UNIT.items()}
    out.update(extra or {})
    return out


def fit_code_histogram(codes, counts, *, read_noise_limit_e: float = READ_NOISE_LIMIT_E) -> dict:
    """As ``fit_histogram``, from a histogram of consecutive integer codes (``counts[i]``
    values at ``codes[i]``; the zero-count ends are trimmed)."""
    codes = np.asarray(codes, np.float64)
    h = np.asarray(counts, np.float64)
    nz = np.nonzero(h)[0]
    if nz.size == 0 or h.sum() < 1000:
        return _na(f"only {int(h.sum())} values; the histogram needs at least 1000")
    codes, h = codes[nz[0]:nz[-1] + 1], h[nz[0]:nz[-1] + 1]
    if codes.size > 1 and np.any(np.diff(codes) != 1):
        return _na("the histogram's codes are not consecutive integers (one count per code is needed)")
    na = _na
    n = float(h.sum())
    mean = float((codes * h).sum() / n)
    var = float((h * (codes - mean) ** 2).sum() / n)
    K0 = _gain_guess(codes, h)
    if not math.isfinite(K0) or K0 < 2:
        rn = _rn_from_ptc(mean, var, K0)
        return na(f"no electron peaks in the histogram (read noise {rn} too high for separated peaks; "
                  f"limit ~{read_noise_limit_e:g} e-)")
    best = None
    for j in (0, -1, 1):  # the comb's first peak: the lowest-looking one, or its neighbours
        o0 = _comb_start(codes, h, K0) + j * K0
        H0 = (mean - o0) / K0
        if H0 <= 0.02:
            continue
        kmax = int(H0 + 8 * math.sqrt(H0) + 8)
        f = lambda x, K, s, H, o, kmax=kmax: _model(x, K, s, H, o, n, kmax)  # noqa: E731
        try:
            with warnings.catch_warnings():  # a singular covariance here: the ML rounds follow
                warnings.simplefilter("ignore", OptimizeWarning)
                p, _ = curve_fit(f, codes, h, p0=[K0, 0.3, H0, o0], sigma=np.sqrt(np.maximum(h, 1.0)))
            p, cov = _poisson_ml(f, codes, h, p)
        except (RuntimeError, ValueError):
            continue
        chi2 = float(np.sum((h - f(codes, *p)) ** 2 / np.maximum(f(codes, *p), 1.0)))
        if best is None or chi2 < best[0]:
            best = (chi2, p, cov, f)
    if best is None:
        return na("the histogram fit did not converge")
    _, p, cov, f = best
    K, s_e, H, o = float(p[0]), abs(float(p[1])), float(p[2]), float(p[3])
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    model = f(codes, *p)
    extra = {"hist_codes": codes, "hist_counts": h, "hist_model": model,
             "chi2_ndf": float(np.sum((h - model) ** 2 / np.maximum(model, 1.0)) / max(codes.size - 4, 1))}
    consistent = abs(K * K * (H + s_e * s_e) + 1 / 12 - var) < 0.2 * var  # the mixture's variance
    if not consistent:
        return na(f"no consistent electron-peak fit (read noise too high for separated peaks; "
                  f"limit ~{read_noise_limit_e:g} e-)", extra)
    if s_e > read_noise_limit_e or not np.all(np.isfinite(se)) or se[0] > 0.05 * K:
        return na(f"read noise {s_e:.2f} e- too high for separated peaks (limit ~{read_noise_limit_e:g} e-)", extra)
    how = "photon-counting histogram fit (Starkey & Fossum 2016); SE from the Poisson Fisher information"
    out = {"K": Estimate(K, float(se[0]), "DN/e-", how), "read_noise_e": Estimate(s_e, float(se[1]), "e-", how),
           "mean_e": Estimate(H, float(se[2]), "e-", how), "offset_dn": Estimate(o, float(se[3]), "DN", how)}
    out.update(extra)
    return out


def _poisson_ml(f, codes, h, p, rounds: int = 6):
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
