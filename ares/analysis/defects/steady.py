"""Is a hot or warm pixel's dark excess a steady dark rate? (issue 48)

A dark rate is charge collected at a constant mean rate: with K known its frames scatter by
the population's temporal variance plus the excess's own shot noise (K x excess DN), white
from frame to frame. A pixel claimed hot or warm is held to that by three tests, together at
``P_STEADY`` (1 %, Bonferroni: each at a third of it): one in a hundred true hot/warm pixels
loses its class -- recall -- while the claims kept are ones their own series do not contradict
-- precision:

* its temporal variance (chi-square, F - 1 dof) is not above the population's plus the shot
  noise of its measured excess -- a noisy pixel whose few frames put its mean high, or a
  telegraph trap mostly in its high level, scatters more;
* nor below the population's plus the shot noise of the smallest excess its measured one is
  consistent with (the excess minus z x the averaged dark's pixel-to-pixel noise -- a pixel's
  own offset adds to it -- z the one-sided normal quantile at the same p) -- an offset without shot noise (a trap held high over most
  frames, a raised offset) is no charge collected;
* where the series can be tested (``rts.telegraph_lr``, >= 12 frames, not on a few codes),
  its telegraph ratio is below the white series' at ``P_TELEGRAPH`` (classify.py).

Where the evidence against a steady rate is strong enough for a class of its own the pixel
takes it (rts at p = 1e-3, noisy at ``noisy_p_fa``); otherwise it is left unclassified:
neither claim clears its false-alarm level.

The converse, with K: a noisy claim needs a variance above what the shot noise of a dark
signal could give whose mean the measured excess does not rule out (excess + z x the averaged
dark's pixel-to-pixel noise: a pixel's negative offset hides part of it). Below that -- on a
quiet sensor, a weak noisy pixel and a dark signal under the averaged dark's noise -- the data
cannot tell the two, and the pixel is left unclassified (``shot_noise_could_explain``).

The variance tests trust K. Where most of the claimed pixels fail them (of >= ``MIN_JUDGED``),
it is K or the shot-noise model that the data contradict, not the pixels (a wrong K given, or
offsets without shot noise as in benchmarks/bench_defects.py): the variance tests are not
applied, and the result says so; likewise where the K the claimed pixels' own variance shows
(the median of (variance - population's) / excess over those whose shot noise dominates, the
median's chi-square bias divided out) is not within ``K_FACTOR`` of the K given. Nor is the
hidden-signal test on noisy claims then (classify.py): it trusts K as much.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

from ares.analysis.defects.dist import chi2_isf, chi2_ppf
from ares.analysis.defects.limits import min_sigma_constant, p_constant_codes

#: the steady-rate tests' false-alarm level together (the z-warm vote's raised-variance test
#: without K, inputs._level_flags, is at the same 1 %)
P_STEADY = 1e-2
#: each variance side's share of it
P_VARIANCE_SIDE = P_STEADY / 3
#: the telegraph ratio's: the tabled p of rts.HMM_NULL nearest a third of P_STEADY
P_TELEGRAPH = 3e-3
#: claimed pixels needed before a majority failing the variance tests is read as K (or the
#: shot-noise model) being wrong rather than the pixels
MIN_JUDGED = 10
#: the K the claimed pixels' own variance shows (the median over those whose shot noise
#: dominates) must be within this factor of the K given -- or within 3 of its SE -- else the
#: variance tests would trust a K the data contradict
K_FACTOR = 1.5


def _claimed(darks, rows: np.ndarray, cols: np.ndarray, line_var: np.ndarray | None):
    """Per dark level: (the level, its frames' degrees of freedom, the claimed pixels' temporal
    variances -- divided by their line's noise factor where given -- and their dark excesses)."""
    for d in darks:
        var = np.asarray(d.st.var[rows, cols], np.float64)
        yield (d, d.st.n_frames - 1, var / line_var if line_var is not None else var,
               np.asarray(d.res[rows, cols], np.float64))


def variance_unsteady(darks, rows: np.ndarray, cols: np.ndarray, gain: float, need: int,
                      line_var: np.ndarray | None = None) -> tuple[np.ndarray, str]:
    """Per pixel (rows[i], cols[i]): its temporal variance departs from a steady dark rate's
    at ``P_VARIANCE_SIDE`` (either side) in >= ``need`` of the dark levels ``darks`` (inputs._Dark).
    ``line_var``: the pixels' bad-line variance factors (1 outside bad lines). With a note
    (else "") where a majority failed and the tests were not applied (module docstring)."""
    p = P_VARIANCE_SIDE
    z = float(-special.ndtri(p))
    n = np.zeros(rows.size, np.int16)
    if rows.size == 0:
        return n.astype(bool), ""
    k_seen = []  # per pixel whose shot noise dominates: (variance - population's) / excess, DN/e-
    for d, dof, var, res in _claimed(darks, rows, cols, line_var):
        hi = d.pop_var + gain * np.maximum(res, 0.0)
        lo = d.pop_var + gain * np.maximum(res - z * d.sigma, 0.0)
        # integer codes: the smallest nonzero sample variance of F codes is step^2 / F (one code
        # a step off the others) -- a variance within that of the limit is no evidence (two equal
        # codes of 2 frames are no missing shot noise)
        q = (d.st.code_step or 0.0) ** 2 / d.st.n_frames
        n += (var > hi * (chi2_isf(p, dof) / dof)) | (var + q < lo * (chi2_ppf(p, dof) / dof))
        big = gain * res > d.pop_var
        k_seen.append((var[big] - d.pop_var) / res[big] / (chi2_ppf(0.5, dof) / dof))
    out = n >= need
    k_seen = np.concatenate(k_seen)
    k_med = float(np.median(k_seen)) if k_seen.size else gain
    # the median's SE from the measured scatter (1.2533 x robust sigma / sqrt(n)): the data must
    # contradict K both significantly (3 SE) and substantially (K_FACTOR)
    k_se = (1.2533 * 1.4826 * float(np.median(np.abs(k_seen - k_med))) / np.sqrt(k_seen.size)
            if k_seen.size else np.inf)
    if (k_seen.size >= MIN_JUDGED and abs(k_med - gain) > 3 * k_se
            and not 1 / K_FACTOR <= k_med / gain <= K_FACTOR):
        return np.zeros(rows.size, bool), (
            f"the hot/warm pixels' temporal variance grows with their dark excess as K = "
            f"{k_med:.3g} +- {k_se:.2g} DN/e- (median of {k_seen.size} whose shot noise dominates), K given "
            f"{gain:g}: their variance was not used to withhold a claim (check K)")
    if rows.size >= MIN_JUDGED and 2 * int(out.sum()) > rows.size:
        return np.zeros(rows.size, bool), (
            f"{int(out.sum())} of the {rows.size} hot/warm pixels have a temporal variance outside the population's "
            f"plus K x their dark excess (K = {gain:g} DN/e-; p = {p:.2g} each side): K, or a steady dark rate, does "
            "not describe them as a population -- their variance was not used to withhold a claim (check K)")
    return out, ""


def shot_noise_could_explain(darks, rows: np.ndarray, cols: np.ndarray, gain: float, need: int,
                             line_var: np.ndarray | None = None) -> np.ndarray:
    """Per pixel (rows[i], cols[i]) claimed noisy with K: the shot noise of a dark signal could
    give its temporal variance -- it is above the population's plus the shot noise of the
    largest dark signal its measured excess is consistent with (the excess + z x the averaged
    dark's pixel-to-pixel noise, z at ``P_VARIANCE_SIDE``: a negative FPN offset hides part of a
    dark signal, whose shot noise then reads as noisy), at ``P_VARIANCE_SIDE``, in fewer than
    ``need`` of the dark levels ``darks``. There a hidden dark signal and excess read noise
    give the same data (issue 48). It binds where K x z x that noise is not small against the
    population's variance: on a quiet sensor (0.66 DN^2 against 0.33 at 0.5 DN of noise and
    FPN), not at 2 DN and 1 DN (1.35 against 4, inside the noisy test's own margin)."""
    p = P_VARIANCE_SIDE
    z = float(-special.ndtri(p))
    n = np.zeros(rows.size, np.int16)
    for d, dof, var, res in _claimed(darks, rows, cols, line_var):
        v = d.pop_var + gain * np.maximum(res, 0.0)  # a steady dark signal at the measured excess
        # the two margins at p each: the variance's chi-square one, and K x the extra signal an
        # offset as low as -z sigma hides (never below no signal) -- added in quadrature (exact for
        # two normal errors; their sum, the union bound, cost 15 of 221 noisy pixels on the quiet
        # sensor at 256 frames, quadrature 7 -- benchmarks/defect_family.md)
        m_var = v * (chi2_isf(p, dof) / dof - 1.0)
        m_off = gain * (np.maximum(res + z * d.sigma, 0.0) - np.maximum(res, 0.0))
        n += var > v + np.hypot(m_var, m_off)
    return n < need


def note_ambiguous_noisy(detection: dict, n: int, sigma: float, gain: float) -> str:
    """The note for ``n`` pixels ``shot_noise_could_explain`` withheld from noisy; adds why to
    noisy's and unclassified's detection sentences (every surface shows those: the window's
    criteria, the report's detection limits -- clipped, so the count and the reason first)."""
    z = float(-special.ndtri(P_VARIANCE_SIDE))
    why = (f"their raised temporal noise could be the shot noise of a dark signal their offset hides (up to {z:.2g} "
           f"x {sigma:.2g} DN, the averaged dark's pixel-to-pixel noise; K = {gain:g} DN/e-)")
    detection["noisy"] = (f"{detection.get('noisy', '')}; {n} more 'unclassified' (a hidden dark signal could give "
                          "their noise)")
    detection["unclassified"] = f"{n} of them: noisy or a hidden dark signal, the data cannot tell -- {why}"
    return f"{n} pixels are not noisy but 'unclassified': {why}, which the data cannot tell from excess read noise"


def one_code(darks, suspect: np.ndarray, gain: float | None, p: float) -> np.ndarray:
    """The ``suspect`` pixels (hot, warm or noisy flags) that repeat one code in every frame of
    every dark level: no dark shot noise, so none of those -- only where a pixel's own sigma
    (the population's plus, with K, its own shot noise) makes one code in every frame
    improbable (``p``; with 2 frames a warm pixel repeats its code often)."""
    const = np.logical_and.reduce([d.st.var <= 0.0 for d in darks]) & suspect
    if gain:
        cand = np.nonzero(const)
        keep = np.ones(cand[0].size, bool)
        for d in darks:
            with np.errstate(invalid="ignore"):
                sig = np.sqrt(d.pop_var + gain * np.maximum(np.asarray(d.res[cand], np.float64), 0.0))
                keep &= sig >= min_sigma_constant(d.st.n_frames, p)
        const[cand] = keep
    else:
        const &= np.array([p_constant_codes(math.sqrt(d.pop_var), d.st.n_frames) <= p for d in darks]).all()
    return const
