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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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

    def dnl_se(self) -> np.ndarray:
        """Counting SE of each code's DNL (code density): a code's count is Poisson, so
        SE(DNL_k) = sqrt(w_k / m) with w_k its relative width and m the mean count per code."""
        return np.sqrt(np.clip(self.dnl + 1.0, 0.0, None) / self.per_code)

    def inl_se(self) -> np.ndarray:
        """Counting SE of each transition's INL (code density): the count below transition
        j of M interior codes is binomial with the total fixed by the endpoint fit, so
        SE(INL_j) = sqrt(M p (1 - p) / m) with p = j / M (0 at both ends)."""
        M = self.last - self.first
        j = np.arange(1, self.inl.size + 1) - self.first
        p = np.clip(j / M, 0.0, 1.0)
        se = np.sqrt(M * p * (1 - p) / self.per_code)
        return np.where(np.isfinite(self.inl), se, np.nan)

    def at_extremes(self) -> dict[str, tuple[float, float]]:
        """(value, counting SE) of the DNL and INL extremes (LSB)."""
        out = {}
        for name, a, se in (("dnl", self.dnl, self.dnl_se()), ("inl", self.inl, self.inl_se())):
            for which, arg in (("max", np.nanargmax), ("min", np.nanargmin)):
                i = int(arg(a))
                out[f"{name}_{which}"] = (float(a[i]), float(se[i]))
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


def _from_widths(width: np.ndarray, lo: int, hi: int, max_code: int, n: int) -> InlDnl:
    """``width[k]`` relative widths for codes lo..hi (interior); endpoint-normalised."""
    w = np.full(max_code + 1, np.nan)
    seg = width[lo:hi + 1].astype(float)
    seg = seg * seg.size / seg.sum()
    w[lo:hi + 1] = seg
    dnl = w - 1.0
    inl = np.full(max_code, np.nan)
    # transition k lies between codes k-1 and k: T_lo = lo - 0.5 fixed, T_k = T_lo + sum widths
    t = (lo - 0.5) + np.concatenate(([0.0], np.cumsum(seg)))
    ks = np.arange(lo, hi + 2)
    inl[ks - 1] = t - (ks - 0.5)
    missing = np.nonzero(np.nan_to_num(w[lo:hi + 1], nan=1.0) == 0)[0] + lo
    return InlDnl(np.arange(max_code + 1), dnl, inl, lo, hi + 1, n, missing)


def code_density(codes: np.ndarray, max_code: int, input_density: str = "uniform",
                 trim: int = 1) -> InlDnl:
    """Histogram test on the codes of one channel. ``trim`` end codes of the covered
    range are dropped (they collect the out-of-range input)."""
    c = np.asarray(codes).ravel()
    h = np.bincount(c, minlength=max_code + 1)[: max_code + 1].astype(float)
    nz = np.nonzero(h)[0]
    lo, hi = int(nz[0]) + trim, int(nz[-1]) - trim
    lo, hi = max(lo, 1), min(hi, max_code - 1)
    if hi - lo < 2:
        raise ValueError("the input covers fewer than 3 interior codes")
    below = np.concatenate(([0.0], np.cumsum(h))) / h.sum()  # fraction below code k, k = 0..max+1
    if input_density == "uniform":
        t = below
    elif input_density == "sine":
        # IEEE 1241: transitions of a sine input T_k = C - A cos(pi * CH_{k-1}); the endpoint
        # fit removes C and A
        t = -np.cos(math.pi * np.clip(below, 0.0, 1.0))
    else:
        raise ValueError(f"unknown input density {input_density!r}")
    width = np.diff(t)
    r = _from_widths(width, lo, hi, max_code, int(c.size))
    if input_density == "uniform":
        from dataclasses import replace

        r = replace(r, per_code=float(h[lo:hi + 1].sum()) / (hi - lo + 1))
    return r


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
