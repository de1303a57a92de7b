"""What each defect class can detect with the frames (and signal) at hand.

A class whose false-alarm rate per pixel at this frame count exceeds
``DefectThresholds.max_false_alarm`` (1e-5), or that cannot find the defect it is meant
for with 99 % probability, is *not available* with one sentence why -- never a count of
thousands of normal pixels (SCIENCE.md, "Detection limits").

- stuck: a normal pixel with temporal sigma s (DN) shows *zero* variance when its F
  integer codes are all equal. With s = 1 DN that happens to 2.8 % of the pixels at
  F = 4 (8600 "stuck" pixels on a VGA sensor), 4e-4 at F = 8 and 1.4e-7 at F = 16
  (``p_constant_codes``). Stuck is detected in the darks only where this is below the
  limit, or in a flat whose shot noise makes equal codes impossible.
- noisy: the chi-square test at ``noisy_p_fa`` finds, with 99 % probability, pixels whose
  variance is ``noisy_ratio_99`` times the population's: 180000x with a pair, 310x at
  F = 4, 11x at F = 16, 5x at F = 32. The class is available where that ratio is at most
  ``noisy_detect_ratio`` (10).
- hot/warm: the robust z threshold fixes the false-alarm rate (< 1e-6 at 4.8 sigma);
  the smallest dark rate found with 99 % probability is stated (it depends on the
  exposure, the gain and the averaged dark's noise).
- RTS needs ``rts_min_frames`` frames of time series; dead/low/high response need a flat.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ares.analysis.defects.dist import chi2_isf, chi2_ppf, norm_cdf

Z99 = 2.326  # one-sided 99 % quantile of the normal


def p_constant_codes(sigma_dn: float, frames: int, n_phase: int = 32) -> float:
    """Probability that ``frames`` integer codes of a Gaussian pixel (sigma in DN, mean
    uniformly placed between codes) are all equal -- zero sample variance."""
    if frames < 2:
        return 1.0
    if not sigma_dn > 0:
        return 1.0
    mu = (np.arange(n_phase) + 0.5) / n_phase
    k = np.arange(-int(8 * sigma_dn) - 2, int(8 * sigma_dn) + 3)
    p = (norm_cdf((k[None, :] + 0.5 - mu[:, None]) / sigma_dn)
         - norm_cdf((k[None, :] - 0.5 - mu[:, None]) / sigma_dn))
    return float(np.mean(np.sum(p**frames, axis=1)))


@lru_cache(maxsize=64)
def min_sigma_constant(frames: int, p_max: float) -> float:
    """The smallest sigma (DN) at which ``frames`` codes are all equal with probability <=
    ``p_max`` (``p_constant_codes`` falls monotonically with sigma: checked for 2-256 frames
    in tests/test_defects_limits.py), by bisection in log sigma; inf where even 4096 DN does
    not get there (2 frames, a small p_max). Lets a classification compare each pixel's
    sigma with one number instead of summing the code probabilities per pixel."""
    hi = 4096.0
    if frames < 2 or p_constant_codes(hi, frames) > p_max:
        return math.inf
    lo = 1e-3
    if p_constant_codes(lo, frames) <= p_max:
        return lo
    while hi / lo > 1 + 1e-9:
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if p_constant_codes(mid, frames) <= p_max else (mid, hi)
    return hi


def min_frames_stuck(sigma_dn: float, p_max: float, f_max: int = 4096) -> int | None:
    """Fewest frames at which a normal pixel's codes are all equal with probability <= p_max."""
    f = 2
    while f <= f_max:
        if p_constant_codes(sigma_dn, f) <= p_max:
            return f
        f = f + 1 if f < 64 else int(f * 1.25)
    return None


def noisy_ratio_99(frames: int, p_fa: float) -> float:
    """Variance ratio a noisy pixel needs to fail the chi-square test with 99 % probability."""
    dof = frames - 1
    if dof < 1:
        return math.inf
    return float(chi2_isf(p_fa, dof) / chi2_ppf(0.01, dof))


def min_frames_noisy(ratio: float, p_fa: float, f_max: int = 4096) -> int | None:
    f = 2
    while f <= f_max:
        if noisy_ratio_99(f, p_fa) <= ratio:
            return f
        f = f + 1 if f < 64 else int(f * 1.25)
    return None


def stuck_in_darks(pop_sigma_dn: float, frames: int, p_max: float) -> tuple[bool, str]:
    """(usable, why not) for the zero-variance test in a dark level."""
    p = p_constant_codes(pop_sigma_dn, frames)
    if p <= p_max:
        return True, ""
    need = min_frames_stuck(pop_sigma_dn, p_max)
    return False, ((f"needs >= {need} frames: " if need else "")
                   + f"with {frames} frames a normal pixel (temporal sigma {pop_sigma_dn:.2g} DN) repeats one code "
                   f"in every frame with probability {p:.2g} (limit {p_max:g})")


def noisy_available(frames: int, p_fa: float, ratio: float) -> tuple[bool, str]:
    r99 = noisy_ratio_99(frames, p_fa)
    if r99 <= ratio:
        return True, f"finds pixels with >= {r99:.3g}x the population variance (99 %)"
    need = min_frames_noisy(ratio, p_fa)
    return False, (f"needs >= {need} frames: with {frames} the chi-square test finds only pixels with >= {r99:.3g}x "
                   f"the population variance (99 %), a {ratio:g}x noisy pixel not")


def hot_limit_text(sigma_dn: float, z: float, gain: float | None, exposure_s: float | None,
                   rate_threshold: float) -> str:
    """The smallest excess dark signal found with 99 % probability, as a sentence."""
    dn = (z + Z99) * sigma_dn
    if gain and exposure_s:
        lim = dn / (gain * exposure_s)
        return (f"finds excess dark rates >= {max(lim, rate_threshold):.3g} e-/s (99 %; the averaged dark's noise "
                f"{sigma_dn:.2g} DN at {exposure_s:g} s" + (f" hides hot pixels between {rate_threshold:g} and "
                                                             f"{lim:.3g} e-/s)" if lim > rate_threshold else ")"))
    return f"finds excess dark signals >= {dn:.3g} DN (99 %)"


def rate_available(cls: str, threshold: float, lim: float, exposure_s: float, sigma_dn: float,
                   slope: bool, factor: float = 2.0) -> tuple[bool, str]:
    """(available, sentence) for a dark-rate class (hot, warm) whose 99 % detection limit
    is ``lim`` e-/s: available where a pixel at ``factor`` times the class's threshold is
    found (as noisy: a 10x pixel), the pixels between threshold and limit named as hidden;
    else the exposure that would bring the limit down there at this dark noise (the limit
    scales as 1/exposure while the averaged dark's pixel-to-pixel noise stays ``sigma_dn``)."""
    how = "the slope of the dark signal over the exposures" if slope else f"the averaged dark at {exposure_s:g} s"
    if lim <= factor * threshold:
        return True, (f"finds dark rates >= {max(lim, threshold):.3g} e-/s (99 %, from {how})"
                      + (f"; {cls} pixels between {threshold:g} and {lim:.3g} e-/s may be missed"
                         if lim > threshold else ""))
    need = exposure_s * lim / (factor * threshold)
    return False, (("needs a longest exposure" if slope else "needs an exposure") + f" >= {need:.3g} s: with {how} "
                   f"(pixel-to-pixel noise {sigma_dn:.2g} DN) only dark rates >= {lim:.3g} e-/s are found (99 %), "
                   f"above {factor:g}x the {cls} threshold {threshold:g} e-/s (a lower bound: longer where the dark's "
                   "non-uniformity grows with exposure)")


def partial_rate_text(cls: str, threshold: float, lim: float, why_not: str) -> str:
    """The detection sentence of a rate class reported incomplete: the pixels found (rate >=
    ``lim`` e-/s, 99 %) are of the class, those between its threshold and ``lim`` are missed;
    ``why_not`` (rate_available's sentence) says the exposure that would find them all."""
    return (f"incomplete: finds only dark rates >= {lim:.3g} e-/s (99 %), {cls} pixels between {threshold:g} and "
            f"{lim:.3g} e-/s are missed -- the count is a lower bound; for all of them it " + why_not)
