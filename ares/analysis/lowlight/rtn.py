"""Random telegraph noise (RTN/RTS) measured per pixel over a long dark time series.

Three steps, the first two streaming (frames once each, memory O(pixels)):

1. ``LineFree``: each frame minus the pixels' temporal means, then minus its row medians and
   column medians (the row- and column-temporal and frame-global terms are common to a line;
   they would otherwise correlate every pixel of it).
2. ``Screen``: each pixel's lag-1 autocorrelation of that residual. White noise gives
   N(0, 1/F); a telegraph term of variance v_t = A^2 p (1 - p) gives
   rho_1 = v_t (1 - 1/tau_lo - 1/tau_hi) / (v_t + sigma^2). Candidates: z = rho_1 sqrt(F) >= ``z_screen``.
3. ``fit_levels``: per candidate, Gaussian hidden Markov models with 1, 2 and 3 levels (shared
   within-level sigma; Baum-Welch, vectorized over the candidates), the number of levels chosen
   by the Bayesian information criterion (BIC); RTN when 2 or 3 levels beat 1 by ``bic_margin``.

Why an HMM and not a change-point method: RTN is a two-state Markov process with geometric
(exponential) dwell times, which is exactly the HMM's model; its transition probabilities give the
mean dwell times directly (1 / leaving probability) and their SEs from the expected transition
counts, and it weighs every frame by its level probability instead of deciding each switch --
a change-point segmentation (PELT, binary segmentation) misses dwells of a few frames when the
amplitude is a few sigma, which biases the mean dwell long, and it runs per pixel in Python.
The BIC (k ln F penalty: 2, 5, 10 parameters) chooses the number of levels by evidence.
Libraries weighed: ``hmmlearn`` fits the same model (``covariance_type="tied"``) but one series per
model object, a Python round trip per pixel and EM iteration, for thousands of candidates; ``ruptures``
is change-point (above). The Baum-Welch here is ~60 lines of scalar loops, compiled by numba
(``ares.analysis.kernels.hmm``, already a dependency), over every candidate in one call.

Per RTN pixel: levels, amplitude (highest - lowest level) with its SE sigma sqrt(1/n_lo + 1/n_hi),
mean dwell time in the lowest and highest level (frames) with SE (dwell / sqrt(departures)), the
within-level sigma.

Summary: fraction of RTN pixels, read noise with and without them, the
amplitude map and histograms, and frames needed (``frames_needed``). What a frame series can
measure of the dwell times, and how well: ``ares.analysis.lowlight.rtn_dwell``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ares.analysis.lowlight.rtn_dwell import (continuous_dwell_s, dwell_frames_needed,  # noqa: F401
                                              dwell_precision, dwell_rel_se)
from ares.analysis.stats.estimate import Estimate

Z_SCREEN = 5.0
LINE_VAR_ALL, LINE_VAR_EVERY = 64, 8  # frames whose line medians' noise ``Screen`` measures
BIC_MARGIN = 10.0
EM_ITER = 60


def loo_median(d: np.ndarray) -> np.ndarray:
    """For every element of each row of ``d`` the median of the *other* elements of its row:
    a pixel's own level then never moves the line term taken from it (with the plain median, a
    pixel switching across its row's median moves it by ~1/(n f(median)), 5 % of sigma on a
    48-pixel row: 3 % of a 3-sigma amplitude)."""
    n = d.shape[1]
    if n < 3:  # one other element (or none: the pixel itself, a zero residual)
        return d[:, ::-1].copy()
    if n % 2 == 0:  # n - 1 odd: one middle element of the rest
        h = n // 2
        part = np.partition(d, (h - 1, h), axis=1)
        lo, hi = part[:, h - 1:h], part[:, h:h + 1]
        return np.where(d <= lo, hi, lo)
    h = (n - 1) // 2  # n - 1 even: the mean of the two middle elements of the rest
    part = np.partition(d, (h - 1, h, h + 1), axis=1)
    a, m, b = part[:, h - 1:h], part[:, h:h + 1], part[:, h + 1:h + 2]
    return np.where(d < m, 0.5 * (m + b), np.where(d > m, 0.5 * (a + m), 0.5 * (a + b)))


class LineFree:
    """The frames' residual after each pixel's mean and each frame's row and column medians
    (each pixel's without itself, ``loo_median``). With ``spread``, ``line_var`` holds the
    variance the two medians added to each pixel of the last frame (rows x cols): each is the
    median of its line's n - 1 other values, independent of the pixel itself, of variance
    measured in that frame (``median_noise_var``). Without it the rms
    temporal noise of the rtn scan's 128x128 array was 1.2 % high (pi / 128 in variance): 5 SE,
    and 21 SE without the RTN pixels (benchmarks/truth_z.md)."""

    def __init__(self, mean: np.ndarray, spread: bool = False):
        self.mean = np.asarray(mean, np.float64)
        self.spread = spread
        self.line_var = 0.0

    def __call__(self, frame) -> np.ndarray:
        d = np.asarray(frame, np.float64) - self.mean
        if self.spread:
            vr = median_noise_var(d)
        d = d - loo_median(d)
        if self.spread:
            self.line_var = vr + median_noise_var(d.T)
        return d - loo_median(d.T).T


def median_noise_var(d: np.ndarray) -> float:
    """The variance of the noise of one row's median of the other n - 1 values (``loo_median``)
    in the frame residual ``d`` (rows x n), measured: the medians of the row's even and of its odd
    values hold the same line term and independent noises, of variance c / (m + 1) for m values;
    their difference's variance across the rows (its mean over the rows, a pattern of the
    columns' terms shared by every row, removed) gives c, and c / n is the noise of a median of
    n - 1. No model of the values: a row whose values come from pixels of different noise and
    from column terms of their own (a column-temporal pattern in the frame) has a median less
    noisy than the same values drawn at random (1 / (4 n f^2) took them so: 0.2 % high at a
    2 DN column-temporal term)."""
    R, n = d.shape
    if R < 2 or n < 2:
        return 0.0
    x = np.median(d[:, 0::2], axis=1) - np.median(d[:, 1::2], axis=1)
    x -= x.mean()
    c = float(np.dot(x, x)) / (R - 1) / (1.0 / ((n + 1) // 2 + 1) + 1.0 / (n // 2 + 1))
    return c / n


class MeanPass:
    """Pass 1: the per-pixel temporal mean."""

    def __init__(self):
        self.sum, self.n = None, 0

    def add(self, frame) -> None:
        f = np.asarray(frame, np.float64)
        self.sum = f.copy() if self.sum is None else self.sum + f
        self.n += 1

    @property
    def mean(self) -> np.ndarray:
        return self.sum / self.n


class Screen:
    """Pass 2: per-pixel variance and lag-1 autocorrelation of the line-free residual."""

    def __init__(self, mean: np.ndarray):
        self.free = LineFree(mean)
        self.s2 = np.zeros(self.free.mean.shape)
        self.s_line, self.n_line = 0.0, 0
        self.s11 = np.zeros(self.free.mean.shape)
        self.prev = None
        self.n = 0

    def add(self, frame) -> None:
        # the medians' noise is a property of the noise level, not of the frame: measured on
        # every frame of the first LINE_VAR_ALL, then every LINE_VAR_EVERY-th (it doubled the pass)
        self.free.spread = self.n < LINE_VAR_ALL or self.n % LINE_VAR_EVERY == 0
        d = self.free(frame)
        self.s2 += d * d
        if self.free.spread:
            self.s_line += self.free.line_var
            self.n_line += 1
        if self.prev is not None:
            self.s11 += d * self.prev
        self.prev = d
        self.n += 1

    @property
    def variance(self) -> np.ndarray:
        """Per pixel the temporal variance about its mean, line terms apart: the residual's,
        less what the row and column medians added (``LineFree.line_var``)."""
        return np.maximum(self.s2 / max(self.n - 1, 1) - self.s_line / max(self.n_line, 1), 0.0)

    @property
    def rho1(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.s2 > 0, self.s11 / self.s2, 0.0)

    def candidates(self, z: float = Z_SCREEN) -> np.ndarray:
        """Flat indices of the pixels whose lag-1 autocorrelation is ``z`` SEs above 0."""
        return np.flatnonzero((self.rho1 * math.sqrt(max(self.n, 1))).ravel() >= z)


class Series:
    """Pass 3: the line-free residual series of the candidates (F, n)."""

    def __init__(self, mean: np.ndarray, flat_index: np.ndarray):
        self.free = LineFree(mean)
        self.index = np.asarray(flat_index, np.int64)
        self.rows: list[np.ndarray] = []

    def add(self, frame) -> None:
        self.rows.append(self.free(frame).ravel()[self.index].astype(np.float32))

    @property
    def series(self) -> np.ndarray:
        return np.asarray(self.rows, np.float32).reshape(len(self.rows), self.index.size)


# ------------------------------------------------------------------ hidden Markov models


@dataclass
class HmmFit:
    levels: np.ndarray  # (n, K) sorted
    sigma: np.ndarray  # (n,)
    trans: np.ndarray  # (n, K, K) rows: from, columns: to (levels sorted)
    occupancy: np.ndarray  # (n, K) expected frames in each level
    departures: np.ndarray  # (n, K) expected transitions out of each level
    loglik: np.ndarray  # (n,)
    k: int

    @property
    def n_params(self) -> int:
        return self.k + 1 + self.k * (self.k - 1)

    def bic(self, frames: int) -> np.ndarray:
        return -2 * self.loglik + self.n_params * math.log(frames)


def _init_levels(x: np.ndarray, k: int) -> np.ndarray:
    """k levels from a few rounds of 1-D k-means started at quantiles (x: (F, n))."""
    q = np.quantile(x, (np.arange(k) + 0.5) / k, axis=0).T  # (n, k)
    for _ in range(8):
        lab = np.argmin(np.abs(x[:, :, None] - q[None, :, :]), axis=2)
        for j in range(k):
            m = lab == j
            cnt = m.sum(0)
            q[:, j] = np.where(cnt > 0, (x * m).sum(0) / np.maximum(cnt, 1), q[:, j])
    return np.sort(q, axis=1)


def fit_hmm(x: np.ndarray, k: int, iters: int = EM_ITER, tol: float = 1e-6, use_kernel: bool = True) -> HmmFit:
    """Gaussian HMM with ``k`` levels and one sigma fitted to each column of ``x`` (F, n) by
    Baum-Welch (scaled forward-backward): the numba kernel ``ares.analysis.kernels.hmm`` one
    column at a time, or (no numba, ``use_kernel=False``) the numpy path, all columns at once."""
    x = np.asarray(x, np.float64)
    F, n = x.shape
    if k == 1:
        mu = x.mean(0)
        var = x.var(0)
        ll = -0.5 * F * (np.log(2 * np.pi * np.maximum(var, 1e-12)) + 1)
        return HmmFit(mu[:, None], np.sqrt(var), np.ones((n, 1, 1)), np.full((n, 1), float(F)), np.zeros((n, 1)), ll, 1)
    mu = _init_levels(x, k)
    var = np.maximum(np.mean((x - mu[np.arange(n), np.argmin(np.abs(x[:, :, None] - mu[None]), axis=2)]) ** 2, 0),
                     1e-6 * max(float(np.var(x)), 1e-12))
    from ares.analysis.kernels.hmm import baum_welch, baum_welch_numpy

    res = baum_welch(x, mu, var, iters, tol) if use_kernel else None
    mu, var, A, occ, dep, ll = res if res is not None else baum_welch_numpy(x, mu, var, iters, tol)
    order = np.argsort(mu, axis=1)
    rows = np.arange(n)[:, None]
    mu = mu[rows, order]
    A = A[rows[:, :, None], order[:, :, None], order[:, None, :]]
    return HmmFit(mu, np.sqrt(var), A, occ[rows, order], dep[rows, order], ll, k)


# ------------------------------------------------------------------ per-pixel results


@dataclass
class RtnPixels:
    index: np.ndarray  # flat pixel index of each RTN pixel
    n_levels: np.ndarray
    levels: list  # per pixel, the levels (DN)
    amplitude_dn: np.ndarray
    amplitude_se_dn: np.ndarray
    sigma_dn: np.ndarray
    dwell_low_frames: np.ndarray
    dwell_low_se: np.ndarray
    dwell_high_frames: np.ndarray
    dwell_high_se: np.ndarray
    occupancy_high: np.ndarray
    delta_bic: np.ndarray
    candidates: int = 0
    frames: int = 0
    extra: dict = field(default_factory=dict)


def fit_levels(series: np.ndarray, index: np.ndarray, bic_margin: float = BIC_MARGIN, three: bool = True,
               chunk: int = 2048) -> RtnPixels:
    """Choose 1, 2 or 3 levels per candidate series (F, n) by BIC; the RTN pixels' figures."""
    x = np.asarray(series, np.float64)
    F, n = x.shape
    keep = []
    for s in range(0, n, chunk):
        xs = x[:, s:s + chunk]
        fits = [fit_hmm(xs, 1), fit_hmm(xs, 2)] + ([fit_hmm(xs, 3)] if three else [])
        bics = np.stack([f.bic(F) for f in fits])
        best = np.argmin(bics[1:], axis=0) + 1
        gain = bics[0] - bics[1:].min(0)
        for j in np.flatnonzero(gain > bic_margin):
            f = fits[best[j]]
            keep.append((s + j, f, j, gain[j]))
    out = {k: [] for k in ("index", "n_levels", "levels", "amp", "amp_se", "sigma", "dl", "dl_se", "dh", "dh_se",
                           "occ", "dbic")}
    for i, f, j, gain in keep:
        lv = f.levels[j]
        occ = f.occupancy[j]
        dep = f.departures[j]
        sig = f.sigma[j]
        out["index"].append(index[i])
        out["n_levels"].append(f.k)
        out["levels"].append([float(v) for v in lv])
        out["amp"].append(float(lv[-1] - lv[0]))
        out["amp_se"].append(float(sig * math.sqrt(1 / max(occ[0], 1) + 1 / max(occ[-1], 1))))
        out["sigma"].append(float(sig))
        for key, lev in (("dl", 0), ("dh", f.k - 1)):
            p_leave = 1.0 - f.trans[j, lev, lev]
            d = 1.0 / p_leave if p_leave > 0 else math.inf
            out[key].append(d)
            out[key + "_se"].append(d / math.sqrt(dep[lev]) if dep[lev] > 0 else math.inf)
        out["occ"].append(float(occ[-1] / F))
        out["dbic"].append(float(gain))
    a = lambda k, dt=np.float64: np.asarray(out[k], dt)
    return RtnPixels(a("index", np.int64), a("n_levels", np.int64), out["levels"], a("amp"), a("amp_se"), a("sigma"),
                     a("dl"), a("dl_se"), a("dh"), a("dh_se"), a("occ"), a("dbic"), candidates=n, frames=F)


def join(parts: list) -> RtnPixels:
    """One ``RtnPixels`` of several (candidates fitted in groups)."""
    if len(parts) == 1:
        return parts[0]
    cat = lambda k: np.concatenate([getattr(p, k) for p in parts])
    keys = ("index", "n_levels", "levels", "amplitude_dn", "amplitude_se_dn", "sigma_dn", "dwell_low_frames",
            "dwell_low_se", "dwell_high_frames", "dwell_high_se", "occupancy_high", "delta_bic")
    vals = {k: (sum((p.levels for p in parts), []) if k == "levels" else cat(k)) for k in keys}
    return RtnPixels(**vals, candidates=sum(p.candidates for p in parts), frames=parts[0].frames)


def frames_needed(amplitude_sigma: float, dwell_low: float, dwell_high: float, amp_rel: float = 0.05,
                  dwell_rel: float = 0.10, z: float = Z_SCREEN) -> int:
    """Frames for an RTN pixel of this amplitude (in read-noise sigmas) and these mean dwells
    to be found by the screen (z SEs of the lag-1 autocorrelation) with its amplitude to
    ``amp_rel`` and its dwell times to ``dwell_rel`` (one SE): the largest of the three."""
    a = float(amplitude_sigma)
    if not (a > 0 and dwell_low >= 1 and dwell_high >= 1):
        return -1
    p = dwell_high / (dwell_low + dwell_high)
    vt = a * a * p * (1 - p)
    rho = vt * max(1 - 1 / dwell_low - 1 / dwell_high, 1e-6) / (vt + 1)
    n_detect = (z / rho) ** 2
    n_amp = (1 / (a * amp_rel)) ** 2 * (1 / p + 1 / (1 - p))
    n_dwell = (dwell_low + dwell_high) / dwell_rel**2  # ~ 1/dwell_rel^2 departures from each level
    return int(math.ceil(max(n_detect, n_amp, n_dwell)))


def _increase(var: np.ndarray, is_rtn: np.ndarray) -> Estimate:
    """100 (r - 1), r^2 = mean variance of all pixels / of the others = (1 - f) + f b / a (a, b: the
    mean variance without and of the RTN pixels, f their share), SE by the delta method over the
    pixels' spread (the set of RTN pixels given)."""
    a_v, b_v = var[~is_rtn], var[is_rtn]
    a, f = float(np.mean(a_v)), b_v.size / var.size
    b = float(np.mean(b_v)) if b_v.size else 0.0
    r = math.sqrt((1 - f) + f * b / a)
    v_b = float(np.var(b_v, ddof=1)) / b_v.size if b_v.size > 1 else 0.0
    v_a = float(np.var(a_v, ddof=1)) / a_v.size if a_v.size > 1 else 0.0
    se_r2 = math.sqrt((f / a) ** 2 * v_b + (f * b / a**2) ** 2 * v_a)
    return Estimate(100 * (r - 1), 100 * se_r2 / (2 * r) if b_v.size > 1 else math.nan, "%",
                    "the RTN pixels' share of the pixel temporal noise")


def _median_se(x: np.ndarray) -> float:
    """SE of a median: sqrt(pi/2) x the spread (half the 16-84 % range) / sqrt(n)."""
    if x.size < 2:
        return math.nan
    q16, q84 = np.percentile(x, (16, 84))
    return float(1.2533 * 0.5 * (q84 - q16) / math.sqrt(x.size))


def summarize(px: RtnPixels, variance_map: np.ndarray, shape, frame_period_s: float | None = None,
              amplitude_sigmas=(1.0, 2.0, 3.0, 5.0)) -> dict:
    """Fraction of RTN pixels, read noise with and without them, histograms, frames needed."""
    var = np.asarray(variance_map, np.float64).ravel()
    npx = var.size
    is_rtn = np.zeros(npx, bool)
    is_rtn[px.index] = True
    rn_all = math.sqrt(float(np.mean(var)))
    rn_without = math.sqrt(float(np.mean(var[~is_rtn]))) if (~is_rtn).any() else math.nan
    # SE of an rms over pixels: half the relative SE of the mean variance
    se_all = rn_all * 0.5 * float(np.std(var, ddof=1)) / float(np.mean(var)) / math.sqrt(npx) if npx > 1 else math.nan
    v2 = var[~is_rtn]
    se_wo = rn_without * 0.5 * float(np.std(v2, ddof=1)) / float(np.mean(v2)) / math.sqrt(v2.size) if v2.size > 1 \
        else math.nan
    n = int(is_rtn.sum())
    frac = n / npx
    sig = float(np.median(px.sigma_dn)) if n else rn_without
    amap = np.zeros(npx)
    amap[px.index] = px.amplitude_dn
    out = {
        "frames": px.frames, "pixels": npx, "candidates": px.candidates, "rtn_pixels": n,
        "rtn_fraction": Estimate(frac, math.sqrt(frac * (1 - frac) / npx) if npx else math.nan, "",
                                 "pixels with 2 or 3 levels by BIC / pixels"),
        "three_level": int(np.sum(px.n_levels == 3)),
        "temporal_noise_dn": Estimate(rn_all, se_all, "DN", "rms temporal noise of every pixel (line terms removed)"),
        "temporal_noise_without_rtn_dn": Estimate(rn_without, se_wo, "DN", "the same without the RTN pixels"),
        "temporal_noise_increase_pct": _increase(var, is_rtn)
        if math.isfinite(rn_without) and rn_without > 0 else Estimate.na("no pixel without RTN", "%"),
        "median_amplitude_dn": Estimate(float(np.median(px.amplitude_dn)), _median_se(px.amplitude_dn), "DN",
                                        "median over the RTN pixels") if n else Estimate.na("no RTN pixel", "DN"),
        "amplitude_map": amap.reshape(shape),
    }
    if n:
        rel = px.amplitude_dn / np.where(px.sigma_dn > 0, px.sigma_dn, np.nan)
        edges = np.array([0, 1, 2, 3, 4, 5, 7, 10, 15, 20, np.inf])
        out["amplitude_hist"] = {"edges_sigma": [float(e) for e in edges[:-1]] + ["inf"],
                                 "counts": np.histogram(rel, edges)[0].tolist()}
        dedges = np.array([1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, np.inf])
        out["dwell_hist"] = {"edges_frames": [float(e) for e in dedges[:-1]] + ["inf"],
                             "low": np.histogram(px.dwell_low_frames, dedges)[0].tolist(),
                             "high": np.histogram(px.dwell_high_frames, dedges)[0].tolist()}
        dl, dh = float(np.median(px.dwell_low_frames)), float(np.median(px.dwell_high_frames))
    else:
        dl = dh = 10.0
    out.update(dwell_precision(px))
    out["frames_needed"] = {f"{a:g}x": frames_needed(a, dl, dh) for a in amplitude_sigmas}
    out["frames_needed_dwell_frames"] = (dl, dh)
    out["within_level_sigma_dn"] = sig
    if frame_period_s:
        out["frame_period_s"] = frame_period_s
    return out


def analyse_stack(stack, z: float = Z_SCREEN, bic_margin: float = BIC_MARGIN, three: bool = True):
    """All three passes on an in-memory stack (F, R, C): (RtnPixels, summary dict)."""
    st = np.asarray(stack)
    mp = MeanPass()
    for f in st:
        mp.add(f)
    sc = Screen(mp.mean)
    for f in st:
        sc.add(f)
    cand = sc.candidates(z)
    se = Series(mp.mean, cand)
    for f in st:
        se.add(f)
    px = fit_levels(se.series, cand, bic_margin, three)
    return px, summarize(px, sc.variance, st.shape[1:])
