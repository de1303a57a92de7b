"""ADC INL/DNL per channel (even/odd columns by default).

Two methods:

- ``code_density``: the histogram test. With an input of known density over the
  range (uniform: a ramp or triangle wave; ``"sine"``: the arcsine density of a
  full-scale sine) the count of each code is proportional to its width:
  ``DNL_k = h_k / h_ideal_k - 1`` over the interior codes (the end codes are open).
- ``ramp_transitions``: transition levels from a slow linear ramp of known start
  and step (``T_k = x_0 + step * #samples below code k``). With an unknown start and
  step the endpoints are fitted (``T_1 = 0.5``, ``T_max = max - 0.5``).

INL per transition level: ``INL_k = T_k - (k - 1/2)`` after the endpoint fit, i.e. the
running sum of the DNL of the codes below k. Units: LSB (= DN).

Standard errors (code density). A ramp's code density is nearly deterministic -- a frame's
count of a code is its width times the samples per LSB to within one sample of the grid --
so the counting (Poisson/multinomial) SE overstates its scatter by tens of times. Given the
histogram as ``K >= 2`` independent sub-histograms (the ramp stage keeps frame i in group
i mod K), every figure -- each code's DNL, each transition's INL and the four extremes --
gets the delete-one-group jackknife SE over the groups (Quenouille/Tukey; Efron & Tibshirani,
An Introduction to the Bootstrap, 1993, ch. 11; the random-groups variance of Wolter,
Introduction to Variance Estimation, 2nd ed. 2007, ch. 2 and 4), which measures the data's
own scatter whatever its model (deterministic ramp, input noise, a sine). It has K - 1
degrees of freedom, so it carries Student's t (``ptc.fit.residual_se_widening``: 3 SE cover
what 3 normal SEs do). A count is an integer: one sample of the total count is kept in
quadrature as its resolution, and where all sub-histograms are the same (a ramp in step with
the sampling: averaging frames resolves nothing) one sample of a sub-histogram's. With one
histogram only (old run directories, a histogram given) the counting SE is used, and
``se_note`` says so. The extreme of many codes is biased away from 0 by their noise: it is
reported less that selection bias (``InlDnl.extremes``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class InlDnl:
    codes: np.ndarray  # interior codes 1..max-1 (DNL) ; INL for transitions 1..max
    dnl: np.ndarray  # per code 0..max (NaN for the open end codes and unvisited range)
    inl: np.ndarray  # per transition k = 1..max (index k-1)
    first: int  # first and last transition covered by the input
    last: int
    samples: int
    missing_codes: np.ndarray
    per_code: float = math.nan  # code density: mean count of an interior code (the counting statistics)
    groups: int = 0  # independent sub-histograms the scatter SEs come from (0: none, counting SE)
    # with groups: "dnl", "inl" the per-code jackknife SEs, "dnl_max"... the extremes', and
    # "floor_dnl" (per code), "floor_inl" the count's resolution (one sample), all unwidened
    scatter: dict | None = None

    def widening(self) -> float:
        """Student's t for the groups' K - 1 dof (``residual_se_widening``), 1 without groups."""
        from ares.analysis.ptc.fit import residual_se_widening

        return residual_se_widening(self.groups - 1) if self.scatter else 1.0

    def se_note(self) -> str:
        """How the SEs were made, one phrase."""
        if self.scatter and not self.scatter["dithered"]:
            return (f"the {self.groups} sub-histograms are all the same (a ramp in step with the sampling, not "
                    f"dithered: averaging resolves nothing): SE one sample of a sub-histogram's count, "
                    f"x Student's t for {self.groups - 1} dof (x {self.widening():.3g})")
        if self.scatter:
            return (f"SE from the scatter of {self.groups} independent sub-histograms (delete-one-group jackknife) "
                    f"with one count's resolution, x Student's t for {self.groups - 1} dof (x {self.widening():.3g})")
        return ("SE from the counting statistics (Poisson counts per code): one histogram only, no sub-histograms "
                "to measure the scatter (a ramp's counts scatter far less: an overstated SE)")

    def _scatter_se(self, name: str) -> np.ndarray:
        """Unwidened SE of each code's DNL / transition's INL from the groups' scatter."""
        return np.sqrt(self.scatter[name] ** 2 + self.scatter[f"floor_{name}"] ** 2)

    def dnl_se(self) -> np.ndarray:
        """SE of each code's DNL: the groups' scatter (module docstring), else the counting SE:
        a code's count is Poisson, SE(DNL_k) = sqrt(w_k / m) with w_k its relative width and m
        the mean count per code."""
        if self.scatter:
            return self._scatter_se("dnl") * self.widening()
        return np.sqrt(np.clip(self.dnl + 1.0, 0.0, None) / self.per_code)

    def inl_se(self) -> np.ndarray:
        """SE of each transition's INL: the groups' scatter, else the counting SE: the count
        below transition j of M interior codes is binomial with the total fixed by the
        endpoint fit, so SE(INL_j) = sqrt(M p (1 - p) / m) with p = j / M (0 at both ends)."""
        if self.scatter:
            return self._scatter_se("inl") * self.widening()
        M = self.last - self.first
        j = np.arange(1, self.inl.size + 1) - self.first
        p = np.clip(j / M, 0.0, 1.0)
        se = np.sqrt(M * p * (1 - p) / self.per_code)
        return np.where(np.isfinite(self.inl), se, np.nan)

    def at_extremes(self) -> dict[str, tuple[float, float]]:
        """(value, SE) of the DNL and INL extremes as the curves give them (LSB): with groups
        the jackknife SE of the extreme itself (it follows the extreme from code to code where
        codes tie) with the count's resolution, else the counting SE of the code it falls on.
        ``extremes`` is what to report (the selection bias corrected)."""
        out = {}
        for name, a, se in (("dnl", self.dnl, self.dnl_se()), ("inl", self.inl, self.inl_se())):
            for which, arg in (("max", np.nanargmax), ("min", np.nanargmin)):
                i = int(arg(a))
                key = f"{name}_{which}"
                if self.scatter:
                    floor = self.scatter[f"floor_{name}"]
                    s_i = math.hypot(self.scatter[key], float(floor[i] if np.ndim(floor) else floor)) * self.widening()
                else:
                    s_i = float(se[i])
                out[key] = (float(a[i]), s_i)
        return out

    def selection_bias(self, key: str) -> float:
        """How far noise alone pushes the extreme ``key`` (``"dnl_max"``...) of the noisy curve
        beyond the curve's own: E[ext(y + e)] - ext(y) with e ~ N(0, SE^2) per code, the
        groups' (unwidened) SEs, over 200 draws of a fixed seed (deterministic). The extreme
        of many codes whose values lie within their noise of each other is biased away from
        0 by about this much (0 when one code stands out)."""
        name, which = key.split("_")
        y = self.dnl if name == "dnl" else self.inl
        ok = np.isfinite(y)
        y, s = y[ok], self._scatter_se(name)[ok]
        f = np.max if which == "max" else np.min
        rng = np.random.default_rng(0)
        draws = [f(y[None] + s[None] * rng.standard_normal((n, y.size)), axis=1) for n in (50,) * 4]
        return float(np.mean(np.concatenate(draws)) - f(y))

    def extremes(self) -> dict:
        """The four extremes to report, each an ``Estimate`` in LSB. With groups: the curve's
        extreme less its selection bias (``selection_bias``), its SE the extreme's scatter SE
        and the bias in quadrature (the correction is known only to about itself); without:
        the curve's extreme with its counting SE. Either way an extreme whose SE exceeds its
        distance from 0 on its own side (max >= 0, min <= 0) is only a limit: max + 3 SE
        (an upper limit for a max), min - 3 SE (a lower limit for a min)."""
        from ares.analysis.stats.estimate import Estimate
        from ares.analysis.stats.physical import NSIGMA

        out = {}
        for key, (v, se) in self.at_extremes().items():
            sign = 1.0 if key.endswith("max") else -1.0
            if self.scatter:
                b = self.selection_bias(key)
                val, se = v - b, math.hypot(se, b)
                note = f"{self.se_note()}; the extreme of the curve {v:.4g} less its selection bias {b:.2g} LSB"
            else:
                val, note = v, f"{self.se_note()}; the extreme of the curve (its selection bias not corrected)"
            if not (math.isfinite(se) and 0 < se <= sign * val):  # (an SE of 0: an endpoint's INL, 0 by the fit)
                lim = sign * max(sign * val, 0.0) + sign * NSIGMA * se
                out[key] = Estimate.limit(lim, "upper" if sign > 0 else "lower", "LSB",
                                          f"{key[:3].upper()} {key[4:]} {val:.3g} ± {se:.2g} LSB: not resolved "
                                          f"from 0 (its SE is not below its distance from 0): only {'an upper' if sign > 0 else 'a lower'}"
                                          f" limit ({'value + ' if sign > 0 else 'value - '}{NSIGMA:g} SE). {note}")
            else:
                out[key] = Estimate(val, se, "LSB", note)
        return out

    @property
    def dnl_max(self) -> float:
        return float(np.nanmax(self.dnl))

    @property
    def dnl_min(self) -> float:
        return float(np.nanmin(self.dnl))

    @property
    def inl_max(self) -> float:
        return float(np.nanmax(self.inl))

    @property
    def inl_min(self) -> float:
        return float(np.nanmin(self.inl))


def _curves(width: np.ndarray, lo: int, hi: int, max_code: int) -> tuple[np.ndarray, np.ndarray]:
    """DNL (codes 0..max) and INL (transitions 1..max) from relative code widths ``width[..., k]``
    (one curve per leading index), endpoint-normalised over the interior codes lo..hi."""
    seg = width[..., lo:hi + 1].astype(float)
    seg = seg * (seg.shape[-1] / seg.sum(axis=-1, keepdims=True))
    lead = seg.shape[:-1]
    dnl = np.full(lead + (max_code + 1,), np.nan)
    dnl[..., lo:hi + 1] = seg - 1.0
    inl = np.full(lead + (max_code,), np.nan)
    # transition k lies between codes k-1 and k: T_lo = lo - 0.5 fixed, T_k = T_lo + sum widths
    t = (lo - 0.5) + np.concatenate((np.zeros(lead + (1,)), np.cumsum(seg, axis=-1)), axis=-1)
    ks = np.arange(lo, hi + 2)
    inl[..., ks - 1] = t - (ks - 0.5)
    return dnl, inl


def _from_widths(width: np.ndarray, lo: int, hi: int, max_code: int, n: int) -> InlDnl:
    """``width[k]`` relative widths for codes lo..hi (interior); endpoint-normalised."""
    dnl, inl = _curves(width, lo, hi, max_code)
    missing = np.nonzero(np.nan_to_num(dnl[lo:hi + 1] + 1.0, nan=1.0) == 0)[0] + lo
    return InlDnl(np.arange(max_code + 1), dnl, inl, lo, hi + 1, n, missing)


def _density_widths(h: np.ndarray, input_density: str) -> np.ndarray:
    """Relative code widths from histograms ``h[..., code]`` of an input of known density."""
    below = np.cumsum(h, axis=-1)
    below = np.concatenate((np.zeros(below.shape[:-1] + (1,)), below), axis=-1) / below[..., -1:]
    if input_density == "uniform":
        t = below  # fraction below code k, k = 0..max+1
    elif input_density == "sine":
        # IEEE 1241: transitions of a sine input T_k = C - A cos(pi * CH_{k-1}); the endpoint
        # fit removes C and A
        t = -np.cos(math.pi * np.clip(below, 0.0, 1.0))
    else:
        raise ValueError(f"unknown input density {input_density!r}")
    return np.diff(t, axis=-1)


def _extremes(dnl: np.ndarray, inl: np.ndarray) -> dict[str, np.ndarray]:
    return {"dnl_max": np.nanmax(dnl, axis=-1), "dnl_min": np.nanmin(dnl, axis=-1),
            "inl_max": np.nanmax(inl, axis=-1), "inl_min": np.nanmin(inl, axis=-1)}


def _jackknife_se(reps: np.ndarray) -> np.ndarray:
    """Delete-one-group jackknife SE from the ``K`` leave-one-out replicates ``reps[g, ...]``:
    sqrt((K - 1) / K * sum_g (theta_(g) - mean)^2) (Efron & Tibshirani 1993, Eq. 11.5)."""
    k = reps.shape[0]
    return np.sqrt((k - 1) / k * np.sum((reps - reps.mean(axis=0)) ** 2, axis=0))


def code_density(codes: np.ndarray, max_code: int, input_density: str = "uniform",
                 trim: int = 1) -> InlDnl:
    """Histogram test on the codes of one channel (counting SEs: one histogram). ``trim``
    end codes of the covered range are dropped (they collect the out-of-range input)."""
    c = np.asarray(codes).ravel()
    return from_histogram(np.bincount(c, minlength=max_code + 1)[: max_code + 1], input_density, trim)


def from_histogram(hist: np.ndarray, input_density: str = "uniform", trim: int = 1,
                   groups: np.ndarray | None = None) -> InlDnl:
    """Histogram test on a code histogram ``hist[code]`` (codes 0..max, ``max = hist.size - 1``).
    ``groups[g, code]``: the same samples as ``K >= 2`` independent sub-histograms (summing to
    ``hist``): every SE then comes from their scatter (module docstring); without them, from
    the counting statistics."""
    h = np.asarray(hist, float)
    max_code = h.size - 1
    nz = np.nonzero(h)[0]
    if nz.size == 0:
        raise ValueError("the input covers fewer than 3 interior codes")
    lo, hi = int(nz[0]) + trim, int(nz[-1]) - trim
    lo, hi = max(lo, 1), min(hi, max_code - 1)
    if hi - lo < 2:
        raise ValueError("the input covers fewer than 3 interior codes")
    r = _from_widths(_density_widths(h, input_density), lo, hi, max_code, int(h.sum()))
    per_code = float(h[lo:hi + 1].sum()) / (hi - lo + 1) if input_density == "uniform" else math.nan
    scatter, k = None, 0
    if groups is not None:
        g = np.asarray(groups, float).reshape(-1, h.size)
        g = g[g.sum(axis=1) > 0]  # (a group no frame reached)
        if g.shape[0] >= 2:
            if not np.array_equal(g.sum(axis=0), h):
                raise ValueError("the sub-histograms do not add up to the histogram")
            k = g.shape[0]
            dnl, inl = _curves(_density_widths(h - g, input_density), lo, hi, max_code)
            # a count is an integer: where every group agrees the scatter says 0, so one sample of
            # the code's count (DNL) and of the mean count per code (INL) is kept as the
            # resolution (JCGM 100:2008 F.2.2.1). Sub-histograms all the same are a ramp in step
            # with the sampling (not dithered): averaging them resolves nothing, one sample of
            # each group's count is the resolution
            mean = float(h[lo:hi + 1].mean())
            res = float(k) if np.all(g == g[:1]) else 1.0
            scatter = {"dnl": _jackknife_se(dnl), "inl": _jackknife_se(inl),
                       "floor_dnl": res * np.where(h > 0, (r.dnl + 1.0) / np.maximum(h, 1.0), 1.0 / mean),
                       "floor_inl": res / mean, "dithered": res == 1.0,
                       **{n: float(_jackknife_se(v)) for n, v in _extremes(dnl, inl).items()}}
    return replace(r, per_code=per_code, groups=k, scatter=scatter)


def ramp_transitions(codes_per_frame: np.ndarray, max_code: int, x0: float | None = None,
                     step: float | None = None) -> InlDnl:
    """Transition levels from frames each holding one slow ramp (samples in ramp order).

    With ``x0``/``step`` (input of the first sample, LSB per sample) the levels are
    absolute; otherwise the endpoints are fitted (the same INL definition as the
    histogram)."""
    c = np.asarray(codes_per_frame)
    c = c.reshape(c.shape[0], -1) if c.ndim > 1 else c[None, :]
    f = c.shape[0]
    below = np.zeros(max_code + 2)
    h = np.bincount(c.ravel(), minlength=max_code + 1)[: max_code + 1].astype(float)
    below[1:] = np.cumsum(h) / f  # mean #samples with code < k, k = 0..max+1
    nz = np.nonzero(h)[0]
    lo, hi = max(int(nz[0]) + 1, 1), min(int(nz[-1]) - 1, max_code - 1)
    if x0 is None or step is None:
        return _from_widths(np.diff(below)[: max_code + 1], lo, hi, max_code, int(c.size))
    T = x0 + step * below[1: max_code + 1] - 0.5 * step  # transition k = 1..max
    inl = np.full(max_code, np.nan)
    ks = np.arange(lo, hi + 2)
    inl[ks - 1] = T[ks - 1] - (ks - 0.5)
    dnl = np.full(max_code + 1, np.nan)
    dnl[lo:hi + 1] = np.diff(T[lo - 1:hi + 1]) - 1.0
    missing = np.nonzero(dnl[lo:hi + 1] <= -1 + 1e-12)[0] + lo
    return InlDnl(np.arange(max_code + 1), dnl, inl, lo, hi + 1, int(c.size), missing)


def per_channel(frames: np.ndarray, max_code: int, method: str = "code_density", channels: int = 2,
                **kw) -> list[InlDnl]:
    """Split (frames, rows, cols) codes by column % channels and analyse each channel."""
    a = np.asarray(frames)
    out = []
    for ch in range(channels):
        sub = a[..., ch::channels]
        if method == "code_density":
            out.append(code_density(sub, max_code, **kw))
        elif method == "ramp":
            out.append(ramp_transitions(sub.reshape(sub.shape[0], -1), max_code, **kw))
        else:
            raise ValueError(f"unknown method {method!r}")
    return out
