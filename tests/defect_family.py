"""A wide family of injected defect stacks with a per-pixel truth *set* (issue 48), and the
per-class precision/recall of the classifier on it.

Independent of ``ares.sim`` and of ``defect_injection.inject`` (whose draws the fast tests
pin): Gaussian dark (offset + column FPN + pixel FPN + white temporal noise, dark shot
noise of each excess), Gaussian flat; units DN, K converts e-. Each case draws:

* frames 4-256, a defect density 0.01-2 % of the pixels (split over the classes, at least
  one of each), a 1 or 10 s exposure, K 0.5 DN/e-;
* hot/warm: dark rates log-uniform 0.3-60 e-/s (across both thresholds, 1 and 5 e-/s);
* RTS: amplitude 1-10 x the temporal noise, mean dwell in each level log-uniform 2-50 frames;
* noisy: temporal SD 1.5-10 x; stuck at 0, at 4095, at 65535, at the dark level, or anywhere;
* dead (response 0-0.4), low (0.55-0.75) and high response (1.3-2);
* clusters of 2x2 / 3x3 hot or dead pixels, 0-2 bad columns (a dark offset);
* the hard ones: an RTS trap on a hot pixel, a stuck pixel at code 0, a noisy pixel in a bad
  column.

Truth per pixel is the set of classes it may rightly be given:

* a pixel's own class; an RTS trap on a hot pixel: rts and hot (and warm, by its rate);
* hot/warm with K and the exposure: by the true rate, either class where the rate is within 3
  SE of the boundary (the rate is measured against the pixel's neighbours: its FPN offset
  and the averaged dark's noise); a rate within 3 SE of the warm threshold may be warm;
  without K or the exposure hot/warm are dark offsets: any pixel with a dark excess;
* noisy means "temporal noise significantly above the population, white or a telegraph not
  resolved in these frames" (benchmarks/defect_family.md): a truly noisy pixel, and an RTS
  trap that switched in the dark frames (its telegraph raises its temporal noise); the
  strict score (truly noisy only) is reported beside it;
* without K or the exposure a pixel with a dark excess may also be noisy: its dark shot
  noise raises its temporal noise, which nothing tells from excess read noise without K;
* an RTS trap that did not show its telegraph in the dark frames -- one state in all but <= 2
  frames (held high it is an offset no classifier can tell from a dark rate), or an
  amplitude below 2 x the temporal noise (levels inside the noise) -- is "indistinguishable",
  counted in no class's precision or recall (``Case.excluded``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

CLASSES = ("stuck", "rts", "hot", "warm", "noisy", "dead", "low_response", "high_response")
ROWS, COLS = 96, 128
OFFSET, TEMPORAL, PIX_FPN, COL_FPN, K = 200.0, 2.0, 1.0, 1.0, 0.5
FLAT = 2000.0
HOT, WARM = 5.0, 1.0  # e-/s, the classifier's default thresholds


@dataclass
class Case:
    dark: np.ndarray  # (F, R, C) uint16
    flat: np.ndarray
    exposure_s: float
    truth: list  # per pixel (flat index) a frozenset of acceptable classes; None: good
    primary: dict  # flat index -> the injected class (for recall)
    excluded: np.ndarray  # bool (R, C): indistinguishable pixels
    rts_amp: dict  # flat index -> amplitude in sigma (RTS that switched)
    info: dict


def make_case(seed: int, frames: int, density: float, with_gain: bool, exposure_s: float | None = None,
              temporal: float = TEMPORAL) -> Case:
    """``temporal``: the white temporal noise (DN; a quiet sensor: 0.3-0.5, its FPN scaled with it)."""
    rng = np.random.default_rng(seed)
    fpn = PIX_FPN * min(1.0, temporal / TEMPORAL * 2)
    n = ROWS * COLS
    t = exposure_s if exposure_s is not None else float(rng.choice([1.0, 10.0]))
    per = max(1, int(round(density * n / len(CLASSES))))
    # hard cases: 2 rts+hot, 1 stuck at 0, 1 noisy in a bad column, clusters
    idx = rng.permutation(n)
    take = iter(idx)
    cls_of: dict[int, str] = {}
    for c in CLASSES:
        for _ in range(per):
            cls_of[int(next(take))] = c
    combo_rts_hot = [int(next(take)) for _ in range(2)]
    stuck0 = int(next(take))
    n_cols = int(rng.integers(0, 3))
    bad_cols = rng.choice(np.arange(4, COLS - 4), size=max(n_cols, 1), replace=False)[:n_cols]
    base = (OFFSET + rng.normal(0, fpn, COLS)[None, :] + rng.normal(0, fpn, (ROWS, COLS)))
    base[:, bad_cols] += 20.0
    # clusters (2x2 or 3x3 of one class) away from the other defects where possible
    clusters = []
    for _ in range(int(rng.integers(0, 3))):
        k = int(rng.choice([2, 3]))
        r0, c0 = int(rng.integers(0, ROWS - k)), int(rng.integers(0, COLS - k))
        cc = str(rng.choice(["hot", "dead"]))
        for r in range(r0, r0 + k):
            for c in range(c0, c0 + k):
                cls_of[r * COLS + c] = cc
        clusters.append((r0, c0, k, cc))
    for i in combo_rts_hot:
        cls_of[i] = "rts+hot"
    cls_of[stuck0] = "stuck0"
    noisy_col = None
    if n_cols:
        noisy_col = int(rng.integers(0, ROWS)) * COLS + int(bad_cols[0])
        cls_of[noisy_col] = "noisy"

    rate = np.zeros(n)
    sig = np.full(n, temporal)
    resp = np.ones(n)
    for i, c in cls_of.items():
        if c in ("hot", "warm", "rts+hot"):
            if c == "hot" and any(i == r * COLS + cc for r0, c0, k, cl in clusters if cl == "hot"
                                  for r in range(r0, r0 + k) for cc in range(c0, c0 + k)):
                rate[i] = math.exp(rng.uniform(math.log(10.0), math.log(60.0)))
            else:
                rate[i] = math.exp(rng.uniform(math.log(0.3), math.log(60.0)))
        elif c == "noisy":
            sig[i] *= rng.uniform(1.5, 10.0)
        elif c == "dead":
            resp[i] = rng.uniform(0.0, 0.4)
        elif c == "low_response":
            resp[i] = rng.uniform(0.55, 0.75)
        elif c == "high_response":
            resp[i] = rng.uniform(1.3, 2.0)
    extra = rate * t * K
    mean = base.ravel() + extra
    sd = np.sqrt(sig**2 + extra * K)
    dark = mean[None, :] + rng.standard_normal((frames, n)) * sd[None, :]
    # RTS
    rts_i = np.array([i for i, c in cls_of.items() if c in ("rts", "rts+hot")], dtype=np.intp)
    amp = rng.uniform(1.0, 10.0, rts_i.size)
    dwell = np.exp(rng.uniform(math.log(2.0), math.log(50.0), (2, rts_i.size)))
    p_up, p_down = 1.0 / dwell[0], 1.0 / dwell[1]
    state = rng.random(rts_i.size) < p_up / (p_up + p_down)
    states = np.empty((frames, rts_i.size), bool)
    for f in range(frames):
        u = rng.random(rts_i.size)
        state = np.where(state, u >= p_down, u < p_up)
        states[f] = state
    dark[:, rts_i] += amp * temporal * states
    # stuck codes
    stuck_i = [i for i, c in cls_of.items() if c == "stuck"]
    codes = {}
    for i in stuck_i:
        kind = int(rng.integers(0, 5))
        codes[i] = [0, 4095, 65535, int(round(mean[i])), int(rng.integers(0, 4096))][kind]
    codes[stuck0] = 0
    illum = 1.0 - 0.2 * ((((np.arange(n) // COLS) - ROWS / 2) / ROWS) ** 2 + (((np.arange(n) % COLS) - COLS / 2) / COLS) ** 2)
    r_flat = FLAT * illum * (1 + rng.normal(0, 0.01, n)) * resp
    flat = (mean + r_flat)[None, :] + rng.standard_normal((frames, n)) * np.sqrt(sd**2 + K * r_flat)[None, :]
    dark = np.clip(np.rint(dark), 0, 65535).astype(np.uint16)
    flat = np.clip(np.rint(flat), 0, 65535).astype(np.uint16)
    for i, code in codes.items():
        dark[:, i] = code
        flat[:, i] = code

    # ---- truth sets
    se_rate = math.sqrt(fpn**2 + temporal**2 / frames) / (K * t)
    truth: list = [None] * n
    primary: dict = {}
    excluded = np.zeros(n, bool)
    rts_amp = {}

    def rate_classes(r):
        s = set()
        if r >= HOT - 3 * se_rate:
            s.add("hot")
        if WARM - 3 * se_rate <= r < HOT + 3 * se_rate:
            s.add("warm")
        return s

    n_high = states.sum(axis=0)
    switched = (np.minimum(n_high, frames - n_high) > 2) & (amp >= 2.0)
    held_high = ~switched
    rts_pos = {int(i): j for j, i in enumerate(rts_i)}
    for i, c in cls_of.items():
        if c in ("stuck", "stuck0"):
            s, p = {"stuck"}, "stuck"
        elif c in ("hot", "warm"):
            s = rate_classes(rate[i]) if with_gain else {"hot", "warm", "noisy"}
            p = ("hot" if rate[i] >= HOT else "warm" if rate[i] >= WARM else None) if with_gain else "hot/warm"
            if not s:
                s, p = set(), None  # a sub-threshold dark rate: good
        elif c in ("rts", "rts+hot"):
            j = rts_pos[i]
            if not switched[j]:
                excluded[i] = True
                continue
            else:
                s, p = {"rts", "noisy"}, "rts"
                rts_amp[i] = float(amp[j])
                if c == "rts+hot":
                    s |= (rate_classes(rate[i]) | {"hot"}) if with_gain else {"hot", "warm"}
        else:
            s, p = {c}, c
        if s:
            truth[i] = frozenset(s)
        if p is not None:
            primary[i] = p
    info = dict(seed=seed, frames=frames, density=density, with_gain=with_gain, exposure_s=t, temporal=temporal,
                bad_columns=[int(c) for c in bad_cols], clusters=clusters, se_rate=se_rate,
                hard=dict(rts_hot=combo_rts_hot, stuck0=stuck0, noisy_col=noisy_col),
                injected=cls_of, rate=rate, sigma=sig, rts_states={int(i): states[:, j] for j, i in enumerate(rts_i)},
                rts_amp_all={int(i): float(amp[j]) for j, i in enumerate(rts_i)})
    return Case(dark.reshape(frames, ROWS, COLS), flat.reshape(frames, ROWS, COLS), t, truth, primary,
                excluded.reshape(ROWS, COLS), rts_amp, info)


def classify(case: Case):
    from ares.analysis.defects import classify_stack

    kw = dict(gain_dn_per_e=K, exposure_s=case.exposure_s) if case.info["with_gain"] else {}
    return classify_stack(case.dark, case.flat, **kw)


def score(case: Case, res) -> dict:
    """Per class: given (pixels given it, not excluded), right (of them, in their truth set),
    strict (of them, injected as that very class), found/total (recall over the injected
    class; RTS: traps that switched), available (count not None), and the verdict text."""
    from ares.analysis.defects.result import PIXEL_CLASSES, primary_class

    prim = primary_class(res.mask).ravel()
    excl = case.excluded.ravel()
    out = {}
    for ci, c in enumerate(PIXEL_CLASSES):
        given = np.flatnonzero((prim == ci) & ~excl)
        right = sum(1 for i in given if case.truth[i] is not None and c in case.truth[i])
        strict = sum(1 for i in given if case.primary.get(int(i)) in (c, "hot/warm" if c in ("hot", "warm") else c))
        members = [i for i, p in case.primary.items()
                   if p == c or (p == "hot/warm" and c in ("hot", "warm"))]
        if c in ("hot", "warm") and not case.info["with_gain"]:
            found = sum(1 for i in members if PIXEL_CLASSES[prim[i]] in ("hot", "warm") if prim[i] >= 0)
        else:
            found = sum(1 for i in members if prim[i] == ci)
        out[c] = dict(given=int(given.size), right=int(right), strict=int(strict), found=int(found),
                      total=len(members), available=res.counts.get(c) is not None,
                      verdict=(res.unavailable.get(c) or res.detection.get(c) or ""),
                      wrong=[(int(i), case.truth[i] and sorted(case.truth[i])) for i in given
                             if case.truth[i] is None or c not in case.truth[i]])
    return out
