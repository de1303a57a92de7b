"""Defect classification of one region/channel from per-pixel statistics (pure numpy).

Pass 1 uses only per-pixel mean and temporal-variance maps of one or more dark levels
(and optional flat levels); pass 2 (RTS) looks at the time series of the noisy
candidates only, obtained through ``rts_series`` -- a callable ``(rows, cols) -> (F, n)``
(e.g. slicing a recorded stack) or a :class:`~.stats.SeriesCollector` filled during a
second streaming pass. See :mod:`.params` for every class definition and default.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from ares.analysis.defects.clusters import find_clusters
from ares.analysis.defects.dist import chi2_isf, chi2_ppf
from ares.analysis.defects.histograms import deviation_histograms
from ares.analysis.defects.lines import LineFlags, line_z
from ares.analysis.defects.params import DefectThresholds
from ares.analysis.defects.result import BITS, DEFECT_DTYPE, PIXEL_CLASSES, DefectResult, primary_class
from ares.analysis.defects.limits import Z99, hot_limit_text, noisy_available, partial_rate_text, rate_available
from ares.analysis.defects.robust import robust_sigma
from ares.analysis.defects.rts import (detect_rts, hmm_null_threshold, low_outlier, low_outlier_critical, rts_threshold,
                                       telegraph_test)
from ares.analysis.defects.steady import (P_STEADY, P_TELEGRAPH, note_ambiguous_noisy, one_code,
                                          shot_noise_could_explain, variance_unsteady)
from ares.analysis.defects.stats import PixelStats, SeriesCollector
from ares.analysis.defects.inputs import _Dark, _Flat, _Slope, _level_flags, _levels, _match_dark, _need

_ROWS = 256  # rows per block of elementwise work on a frame
# a noisy pixel is RTS when its series shows a telegraph (two levels, persisting from frame to frame) beyond a
# white Gaussian series at this p: 0.1 % of truly noisy pixels (one of rts.HMM_NULL_P; benchmarks/defect_classes.md)
NOISY_RTS_P = 1e-3
# below this temporal noise (the population's, quantization included; in code steps) the noisy test is not
# available: with integer codes and 0.3 DN of noise (0.42 measured) half the pixels "noisy" at 256 frames were
# good, at 0.4 DN (0.49) 1 of 19 at 64 frames, at 0.5 DN (0.58) none (tests/defect_family.py, noise lowered)
NOISY_MIN_STEPS = 0.55

RtsSource = Callable[[np.ndarray, np.ndarray], np.ndarray] | SeriesCollector


def classify_defects(
    dark: PixelStats | Sequence[PixelStats],
    flats: PixelStats | Sequence[PixelStats] | None = None,
    *,
    gain_dn_per_e: float | None = None,
    thresholds: DefectThresholds | None = None,
    rts_series: RtsSource | None = None,
    origin: tuple[int, int] = (0, 0),
    step: tuple[int, int] = (1, 1),
) -> DefectResult:
    """Classify the defective pixels and lines of one region/channel.

    ``dark``: one or more dark levels (``exposure_s`` set on each for rates); ``flats``:
    optional illuminated levels (each is dark-subtracted with the dark of the nearest
    exposure); ``gain_dn_per_e``: K, enables the e-/s hot/warm criteria and the
    dark-shot-noise allowance of the noisy test; ``origin``/``step``: where local
    (row, col) sit in the full frame, for the defect list coordinates.
    """
    th = thresholds or DefectThresholds()
    darks = _levels(dark)
    flat_levels = _levels(flats)
    if not darks:
        raise ValueError("defect classification needs at least one dark level")
    shape = darks[0].shape
    for s in darks + flat_levels:
        if s.shape != shape:
            raise ValueError(f"all levels must have the same shape: {s.shape} != {shape}")
    if gain_dn_per_e is not None and not gain_dn_per_e > 0:
        raise ValueError("gain_dn_per_e must be positive")
    notes: list[str] = []
    nrow, ncol = shape
    D = [_Dark(s, gain_dn_per_e, th) for s in darks]
    rate_mode = all(d.rate_scale is not None for d in D)
    # several exposures: hot/warm by the slope of the dark signal over exposure (the rate),
    # which a trap held high for a whole stack (an offset that does not grow) does not have
    slope_mode = rate_mode and len({d.st.exposure_s for d in D}) >= 2
    if not rate_mode:
        why = "no gain" if not gain_dn_per_e else "no exposure time on every dark level"
        notes.append(f"hot/warm classified by robust z of the averaged dark ({why}): "
                     f"warm z > {th.warm_z}, hot z > {th.hot_z}")
    F = []
    for s in flat_levels:
        fl = _Flat(s, _match_dark(s, darks), th.background_block_px, th.max_false_alarm)
        if not fl.median > 0:
            notes.append(f"a flat level with median response {fl.median:.3g} DN was skipped (no light)")
            continue
        F.append(fl)

    def pixel_flags(col_var: np.ndarray, row_var: np.ndarray, col_resp: np.ndarray, row_resp: np.ndarray):
        """All pixel flags, given per-line factors that bad lines divide out (1 elsewhere)."""
        nd = len(D)
        hot_n = np.zeros(shape, np.int16)
        warm_n = np.zeros(shape, np.int16)
        noisy_n = np.zeros(shape, np.int16)
        stuck_n = np.zeros(shape, np.int16)
        hot_stat = np.full(shape, -np.inf)
        noisy_stat = np.zeros(shape)
        # the first pass has no bad lines (factors all 1): the maps are used as they are --
        # the same numbers (x / 1.0 == x) without three frames of float64 temporaries
        ones = bool(np.all(col_var == 1.0) and np.all(row_var == 1.0) and np.all(col_resp == 1.0)
                    and np.all(row_resp == 1.0))
        line_var = None if ones else col_var[None, :] * row_var[:, None]
        slope = _Slope(shape) if slope_mode else None
        for d in D:
            # robust z and rate made here, not kept: a frame of float64 each. The mean of a
            # pixel with its own excess temporal noise (a noisy or RTS pixel) scatters by
            # sqrt(excess variance / F) more: a mean offset is significant only against both,
            # or every noisy pixel with few frames is also "hot". Only a significant excess
            # (chi-square at rts_p_fa) counts: with 2 frames a normal variance swings 10x.
            dof = d.st.n_frames - 1
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(d.var_ratio > chi2_isf(th.rts_p_fa, dof) / dof, d.st.var * (1.0 - 1.0 / d.var_ratio), 0.0)
            z /= d.st.n_frames
            z += d.sigma * d.sigma
            if slope is not None:  # several exposures: the rate is the slope over them (below)
                slope.add(d, z)
            else:
                _level_flags(d, z, th, rate_mode, hot_n, warm_n, hot_stat)
            del z
            dof = d.st.n_frames - 1
            vr = d.var_ratio if ones else d.var_ratio / line_var
            noisy_n += vr > chi2_isf(th.noisy_p_fa, dof) / dof
            np.maximum(noisy_stat, vr, out=noisy_stat)
            if d.stuck_ok:
                stuck_n += (d.st.var < th.stuck_var_dn2) & (d.st.var < d.pop_var * chi2_ppf(th.noisy_p_fa, dof) / dof)
        need = _need(max(sum(d.stuck_ok for d in D), 1), th.confirm_fraction)
        stuck = stuck_n >= need if any(d.stuck_ok for d in D) else np.zeros(shape, bool)
        need = _need(nd, th.confirm_fraction)
        if slope is not None:
            hot, warm, rate = slope.flags(th, gain_dn_per_e)
            hot_n = hot.astype(np.int16) * need
            warm_n = warm.astype(np.int16) * need
            hot_stat = rate
        flags = {"hot": hot_n >= need}
        flags["warm"] = ((hot_n + warm_n) >= need) & ~flags["hot"]
        flags["noisy"] = (noisy_n >= need) if noisy_ok else np.zeros(shape, bool)
        stats = {"hot": hot_stat, "warm": hot_stat, "noisy": noisy_stat}
        dead = np.zeros(shape, bool)
        low = np.zeros(shape, bool)
        high = np.zeros(shape, bool)
        ratio_stat = np.broadcast_to(1.0, shape)  # read only at flagged pixels: no frame of ones
        if F:
            line_resp = None if ones else col_resp[None, :] * row_resp[:, None]
            nf = len(F)
            dn = np.zeros(shape, np.int16)
            ln = np.zeros(shape, np.int16)
            hn = np.zeros(shape, np.int16)
            sn = np.zeros(shape, np.int16)
            acc = np.zeros(shape)
            for fl in F:
                r = fl.ratio if ones else fl.ratio / line_resp
                sig = np.empty(shape, bool)
                for i in range(0, nrow, _ROWS):  # a block of rows at a time: no frames of float64 temporaries
                    b = slice(i, i + _ROWS)
                    sig[b] = np.abs(fl.resp[b] - (fl.bg[b] if ones else fl.bg[b] * line_resp[b])) > th.warm_z * fl.noise[b]
                dn += sig & (r < th.dead_fraction)
                ln += sig & (r < th.low_response_fraction)
                hn += sig & (r > th.high_response_fraction)
                if fl.stuck_ok:
                    sn += (fl.st.var < th.stuck_var_dn2) & (np.abs(fl.resp) < th.stuck_response_dn)
                acc += r
            needf = _need(nf, th.confirm_fraction)
            dead = dn >= needf
            low = (ln >= needf) & ~dead
            high = hn >= needf
            nfs = sum(fl.stuck_ok for fl in F)
            if nfs:  # stuck from flats and darks together: one code in the light too (a quiet
                # pixel repeating its dark code that follows the light is not stuck)
                flat_stuck = sn >= _need(nfs, th.confirm_fraction)
                stuck = flat_stuck & stuck if any(d.stuck_ok for d in D) else flat_stuck
            acc /= nf
            ratio_stat = acc
        flags.update(dead=dead, low_response=low, high_response=high, stuck=stuck)
        stats.update(dead=ratio_stat, low_response=ratio_stat, high_response=ratio_stat)
        stats["stuck"] = D[0].st.var if nd == 1 else np.minimum.reduce([d.st.var for d in D])
        return flags, stats

    # ---- what each class can detect at this frame count (limits.py)
    unavailable: dict[str, str] = {}
    detection: dict[str, str] = {}
    incomplete: dict[str, str] = {}  # rate classes whose limit is above 2x the threshold (see below)
    fmin = min(d.st.n_frames for d in D)
    noisy_ok, why = noisy_available(fmin, th.noisy_p_fa, th.noisy_detect_ratio)
    quiet = [d for d in D if d.st.code_step and math.sqrt(d.pop_var) < NOISY_MIN_STEPS * d.st.code_step]
    if noisy_ok and quiet:
        noisy_ok, why = False, (f"needs a temporal noise >= {NOISY_MIN_STEPS:g} code steps: at "
                                f"{math.sqrt(quiet[0].pop_var):.2g} DN a pixel's variance depends on where its mean "
                                "sits between two codes (quantization), which the chi-square test does not model")
    (detection if noisy_ok else unavailable)["noisy"] = why
    stuck_ok = any(d.stuck_ok for d in D) or any(fl.stuck_ok for fl in F)
    if not stuck_ok:
        unavailable["stuck"] = (next(d.stuck_why for d in D if d.stuck_why)
                                + ("" if F else "; and no flat level to test the response"))
    elif not all(d.stuck_ok for d in D):
        detection["stuck"] = "from the flat levels only (too few dark frames for the zero-variance test)"
    dref0 = max(D, key=lambda d: d.st.exposure_s or 0.0)
    if rate_mode:
        # the smallest dark rate found with 99 % probability: a class whose threshold is below
        # it would miss some of its pixels and is not available, with the exposure it needs
        lim = (th.warm_z + Z99) * (_Slope.se0(D) if slope_mode else dref0.sigma / dref0.rate_scale) / (
            gain_dn_per_e if slope_mode else 1.0)
        for c, thr in (("hot", th.hot_e_per_s), ("warm", th.warm_e_per_s)):
            ok, why = rate_available(c, thr, lim, float(dref0.st.exposure_s), dref0.sigma, slope_mode,
                                     th.rate_detect_factor)
            (detection if ok else unavailable)[c] = why
            if not ok and lim <= th.rate_partial_factor * thr:
                incomplete[c] = partial_rate_text(c, thr, lim, why)
    else:
        detection["hot"] = hot_limit_text(dref0.sigma, th.warm_z, gain_dn_per_e, dref0.st.exposure_s, th.hot_e_per_s)
    if max(d.st.n_frames for d in D) < th.line_noise_min_frames:
        notes.append(f"noisy rows/columns not tested: needs >= {th.line_noise_min_frames} dark frames (a line's "
                     "temporal variance over fewer frames swings with its own row/column noise)")
    if any(d.background_removed for d in D):
        notes.append("smooth or periodic dark structure (robust sigma "
                     f"{max(d.structure for d in D):.2f}x the pixel-to-pixel noise) removed by a 5x5 running "
                     "median before the hot/warm test")
    if not F:
        for c in ("dead", "low_response", "high_response"):
            unavailable[c] = "needs a flat (illuminated) level"

    ones_c, ones_r = np.ones(ncol), np.ones(nrow)
    flags, stats = pixel_flags(ones_c, ones_r, ones_c, ones_r)
    # one code in every frame of every dark level: no dark shot noise, so no hot, warm or noisy
    # pixel -- stuck where stuck can be tested, otherwise left unclassified (steady.py)
    const = one_code(D, flags["hot"] | flags["warm"] | flags["noisy"], gain_dn_per_e, th.rts_p_fa)
    if not stuck_ok:
        odd = const & (flags["hot"] | flags["warm"])
        if odd.any():
            notes.append(f"{int(odd.sum())} pixels repeat one code in every dark frame with a dark signal far from "
                         "their neighbours': stuck or hot cannot be told at this frame count, left unclassified")
    for c in ("hot", "warm", "noisy"):
        flags[c] &= ~const

    # ---- lines
    lines = {}
    line_factors = {}
    for axis, name, n_other in ((0, "bad_column", nrow), (1, "bad_row", ncol)):
        n = ncol if axis == 0 else nrow
        lf = LineFlags(n)
        hw = (flags["hot"] | flags["warm"]).sum(axis=axis)
        lf.add(hw >= th.line_hot_count, "hot pixel count", hw)
        dl = (flags["dead"] | flags["low_response"] | flags["stuck"]).sum(axis=axis)
        lf.add(dl >= th.line_dead_count, "dead pixel count", dl)
        dref = max(D, key=lambda d: d.st.exposure_s or 0.0)
        off = dref.col_off if axis == 0 else dref.row_off
        zo = line_z(off, dref.sigma, n_other)
        lf.add(np.abs(zo) > th.line_z, "dark offset z", zo)
        vals = dref.col_var if axis == 0 else dref.row_var
        zv = line_z(vals, math.sqrt(2.0 / (dref.st.n_frames - 1)), n_other)
        # a noisy line: significantly AND substantially (line_noise_factor) above expected;
        # with few frames a line's own row/column temporal noise (F - 1 dof, shared by
        # the whole line) swings its variance by tens of % -- not a defect
        if dref.st.n_frames >= th.line_noise_min_frames:
            lf.add((zv > th.line_z) & (vals > th.line_noise_factor), "temporal variance z", zv)
        factor_var = np.where(lf.bad, vals, 1.0)
        factor_resp = np.ones(n)
        if F:
            fref = max(F, key=lambda f: f.median)
            rr = fref.col_ratio if axis == 0 else fref.row_ratio
            zr = line_z(rr, robust_sigma(fref.ratio, floor=1e-9), n_other)
            lf.add(np.abs(zr) > th.line_z, "response z", zr)
            factor_resp = np.where(lf.bad & np.isfinite(rr) & (rr > 0), rr, 1.0)
        lines[name] = lf
        line_factors[name] = (np.maximum(factor_var, 1e-6), factor_resp)
    if lines["bad_column"].bad.any() or lines["bad_row"].bad.any():
        # inside a bad line a pixel is a pixel defect only if it is one both against its
        # neighbourhood and against the line's own level: a dead (or half-dead) column is
        # one bad column, and its good pixels do not turn "high-response" against it
        (cv, cr), (rv, rr_) = line_factors["bad_column"], line_factors["bad_row"]
        flags2, stats = pixel_flags(cv, rv, cr, rr_)
        flags = {k: flags[k] & flags2[k] for k in flags}

    # ---- RTS (pass 2 on the candidates: noisy pixels, and hot/warm ones -- an RTS that sits mostly in its high
    # state looks like a warm pixel whose variance the dark-shot-noise allowance explains) and every pixel whose
    # variance in the series' level (the first dark) is above the chi-square limit at rts_p_fa: an RTS of a few
    # sigma raises the variance only a few times, below the noisy limit at 16 frames. The separation of a Gaussian
    # series is independent of its sample variance (Basu): the joint false alarm per normal pixel is rts_p_fa^2.
    # Without K a warm pixel's own dark shot noise raises its variance, which the z-warm vote refuses (a trap
    # switching over a few frames raises mean and variance as well): such a pixel (z > warm_z, not hot) is a
    # candidate, warm where the telegraph tests clear it. With K a hot/warm claim needs the temporal variance of a
    # steady dark rate (steady.py): a trap mostly high, a noisy pixel with an offset is not -- noisy or rts where
    # its tests say
    no_rate, k_note = np.zeros(shape, bool), ""  # k_note: why the variance tests do not trust K (steady.py)
    withheld = np.zeros(shape, bool)  # a dark excess no class takes: "unclassified" (result.BITS)
    if rate_mode:
        hr, hc = np.nonzero(flags["hot"] | flags["warm"])
        lv = line_factors["bad_column"][0][hc] * line_factors["bad_row"][0][hr]
        no_rate[hr, hc], k_note = variance_unsteady(D, hr, hc, gain_dn_per_e, _need(len(D), th.confirm_fraction), lv)
        notes.extend([k_note] if k_note else [])
    dof0 = D[0].st.n_frames - 1
    zwarm = ((stats["hot"] > th.warm_z) & ~flags["hot"] & ~flags["warm"]) if not rate_mode else np.zeros(shape, bool)
    cand = (flags["noisy"] | flags["hot"] | flags["warm"] | zwarm
            | (D[0].var_ratio > chi2_isf(th.rts_p_fa, dof0) / dof0)) & ~flags["stuck"] & ~const
    crow, ccol = np.nonzero(cand)
    held = {c: flags[c] for c in incomplete}
    for c in ("hot", "warm"):  # candidates above; a class it cannot test takes no pixel
        if c in unavailable:
            flags[c] = np.zeros(shape, bool)
    rts = np.zeros(shape, bool)
    rts_stat = np.broadcast_to(0.0, shape)  # filled at the candidates, if tested
    rts_available, rts_note, rts_few_frames = False, "", False
    if rts_series is None:
        rts_note = "needs the time series of the candidate pixels (none was given)"
    else:
        if isinstance(rts_series, SeriesCollector):
            keyed = {(int(r), int(c)): i for i, (r, c) in enumerate(zip(rts_series.rows, rts_series.cols))}
            have = np.array([(int(r), int(c)) in keyed for r, c in zip(crow, ccol)], dtype=bool)
            missing = int((~have).sum())
            crow, ccol = crow[have], ccol[have]
            idx = np.array([keyed[(int(r), int(c))] for r, c in zip(crow, ccol)], dtype=np.intp)
            series = rts_series.series[:, idx] if idx.size else np.empty((rts_series.n_frames, 0))
            if missing:
                notes.append(f"{missing} RTS candidates had no time series and were not tested")
        else:
            series = np.asarray(rts_series(crow, ccol))
        nfr = series.shape[0] if series.ndim == 2 else 0
        if series.ndim != 2 or series.shape[1] != crow.size:
            raise ValueError(f"rts_series returned shape {series.shape}, expected (frames, {crow.size})")
        rts_few_frames = nfr < th.rts_min_frames
        if rts_few_frames:
            rts_note = (f"needs >= {th.rts_min_frames} frames: {nfr} in the time series (rts_min_frames="
                        f"{th.rts_min_frames}: over fewer a single-level series splits into two apparent levels "
                        "too often)")
        else:
            thr = rts_threshold(nfr, th.rts_min_separation, th.rts_min_occupancy, th.rts_p_fa)
            is_rts, sep = detect_rts(series, thr, th.rts_min_occupancy)
            # a noisy, hot or warm candidate whose series is a telegraph beyond what a white Gaussian series shows at
            # NOISY_RTS_P is RTS -- its levels closer than rts_min_separation, or a trap mostly in one level (which
            # looks warm or hot). The test: the likelihood ratio of a two-state hidden Markov model (two levels,
            # persisting from frame to frame) against one Gaussian (rts.telegraph_lr), against its table of white
            # series of as many frames (rts.HMM_NULL, false-alarm rate measured in benchmarks/defect_hmm_null.md).
            # It is offset- and scale-free: a truly noisy, hot or warm pixel is called RTS with probability
            # NOISY_RTS_P. Not on pixels whose variance is merely raised at rts_p_fa: the simulator's good pixels with
            # a slow drift of their own (not white) reached it (2 of 307 200 in the long dark at 64 frames). A
            # hot/warm pixel whose ratio reaches the white series' at P_TELEGRAPH is no steady rate (steady.py); a
            # z-warm pixel is warm only where the ratio was computed and cleared.
            tel = (flags["noisy"] | flags["hot"] | flags["warm"] | zwarm)[crow, ccol] & ~is_rts
            lr = np.full(crow.size, np.nan)
            if tel.any():
                lr[tel], note = telegraph_test(series[:, tel])
                notes.extend([note] if note else [])
            with np.errstate(invalid="ignore"):
                is_rts |= lr >= hmm_null_threshold(nfr, NOISY_RTS_P)
                cleared = lr < hmm_null_threshold(nfr, P_TELEGRAPH)
            no_rate[crow[tel & ~cleared], ccol[tel & ~cleared]] = True
            rts[crow[is_rts], ccol[is_rts]] = True
            # a hot/warm candidate whose series drops far below its own level in a frame is
            # no steady dark rate (a trap held high that fell back): no class takes it, it stays
            # in the defect mask (Grubbs at max_false_alarm: 1e-5 of the true hot/warm pixels)
            hw = (flags["hot"] | flags["warm"] | zwarm)[crow, ccol]
            for c in held:
                hw |= held[c][crow, ccol]
            drop = hw & ~is_rts & (low_outlier(series) >= low_outlier_critical(nfr, th.max_false_alarm))
            if drop.any():
                withheld[crow[drop], ccol[drop]] = True
                for c in ("hot", "warm"):
                    flags[c][crow[drop], ccol[drop]] = False
                    if c in held:
                        held[c] = held[c].copy()
                        held[c][crow[drop], ccol[drop]] = False
                notes.append(f"{int(drop.sum())} pixels with a dark excess drop far below it in a frame (a telegraph "
                             "trap held high, no steady dark rate): neither hot nor warm, 'unclassified' in the mask")
            zw = zwarm[crow, ccol] & ~is_rts & ~drop & cleared
            flags["warm"][crow[zw], ccol[zw]] = True
            rts_stat = np.zeros(shape)
            rts_stat[crow, ccol] = sep
            rts_available = True
            rts_note = (f"{crow.size} candidates (noisy, hot, warm, raised variance) tested over {nfr} frames; "
                        f"finds telegraph amplitudes >= {thr:.2g}x the within-level noise")
            detection["rts"] = rts_note
    if no_rate.any():
        no_rate &= flags["hot"] | flags["warm"] | np.logical_or.reduce(list(held.values()), initial=False)
        withheld |= no_rate
        for c in ("hot", "warm"):
            flags[c] = flags[c] & ~no_rate
            if c in held:
                held[c] = held[c] & ~no_rate
        n_left = int((no_rate & ~rts & ~flags["noisy"]).sum())
        notes.extend([f"{n_left} pixels with a dark excess are no steady dark rate at p = {P_STEADY:g} (a temporal "
                      "variance above or below the population's plus their own shot noise, or a telegraph) and not "
                      "rts or noisy either: in no class, in the defect mask ('unclassified')"] if n_left else [])
    flags["rts"] = rts
    stats["rts"] = rts_stat
    if rts_available:
        # a rate class whose 99 % limit is above rate_detect_factor x its threshold (up to rate_partial_factor x)
        # misses some of its pixels (recall), but the pixels it does find -- a dark excess > warm_z sigma AND a rate
        # above the threshold -- are of it (precision): they keep the class, its count marked incomplete, rather
        # than falling into none (issue 48: hot pixels 5-9 sigma above the noise were in no class once K and the
        # exposure were given). Only where the RTS test ran: a trap held high over the frames is an offset, which
        # the series of a switching trap tells apart; with too few frames nothing does.
        for c, why in incomplete.items():
            flags[c] = held[c]
            detection[c] = why
            del unavailable[c]
    if not rate_mode and rts_few_frames:
        # without a rate the hot/warm test is a dark offset; a telegraph trap held in its high
        # state over these frames has one too, and the RTS test that tells them apart cannot run
        for c in ("hot", "warm"):
            flags[c] = np.zeros(shape, bool)
            unavailable[c] = (f"without K and the exposure a {c} pixel is a dark offset, which a telegraph (RTS) "
                              f"trap held high over the frames shows too; RTS is not testable here ({rts_note})")

    if gain_dn_per_e and not k_note:  # noisy, or the shot noise of a dark signal its offset hides (steady.py)
        nr, nc = np.nonzero(flags["noisy"] & ~rts & ~flags["stuck"] & ~flags["hot"] & ~flags["warm"])
        amb = shot_noise_could_explain(D, nr, nc, gain_dn_per_e, _need(len(D), th.confirm_fraction),
                                       line_factors["bad_column"][0][nc] * line_factors["bad_row"][0][nr])
        flags["noisy"][nr[amb], nc[amb]] = False
        withheld[nr[amb], nc[amb]] = True
        if amb.any():
            notes.append(note_ambiguous_noisy(detection, int(amb.sum()), dref0.sigma, gain_dn_per_e))
    # ---- histograms (the last use of the levels' per-pixel maps: freed after them -- a
    # 4096x3072 classification held a dozen float64 frames of them to the end)
    dref = max(D, key=lambda d: d.st.exposure_s or 0.0)
    fref = max(F, key=lambda f: f.median) if F else None
    dark_dev = dref.res / dref.rate_scale if rate_mode else dref.res
    resp_dev = fref.ratio if F else None
    for d in D:
        d.res = d.var_ratio = None
    for fl in F:
        fl.resp = fl.bg = fl.ratio = fl.noise = None
    hists = {"dark_signal": deviation_histograms(dark_dev, "e-/s" if rate_mode else "DN")}
    del dark_dev
    if resp_dev is not None:
        resp_dev = 100.0 * (resp_dev - 1.0)
        hists["response"] = deviation_histograms(resp_dev, "%")
    del resp_dev

    # ---- mask, primary classes, list
    mask = np.zeros(shape, np.uint16)
    for c in PIXEL_CLASSES:
        mask[flags[c]] |= BITS[c]
    mask[:, lines["bad_column"].bad] |= BITS["bad_column"]
    mask[lines["bad_row"].bad, :] |= BITS["bad_row"]
    mask[withheld & ((mask & sum(BITS[c] for c in PIXEL_CLASSES)) == 0)] |= BITS["unclassified"]
    prim = primary_class(mask)
    # a withheld pixel (in no class) is listed, counted in "total" and in limits as "unclassified"
    listed = (prim >= 0) | ((mask & BITS["unclassified"]) != 0)
    rows, cols = np.nonzero(listed)
    pcls = prim[rows, cols]  # -1: unclassified, the last of ``names``
    defects = np.empty(rows.size, DEFECT_DTYPE)
    defects["x"] = origin[1] + step[1] * cols
    defects["y"] = origin[0] + step[0] * rows
    names = np.array(PIXEL_CLASSES + ("unclassified",))
    defects["cls"] = names[pcls]
    st = np.empty(rows.size)
    for i, c in enumerate(PIXEL_CLASSES):
        sel = pcls == i
        st[sel] = stats[c][rows[sel], cols[sel]]
    defects["statistic"] = np.where(pcls < 0, stats["hot"][rows, cols], st)
    counts = {c: int((pcls == i).sum()) for i, c in enumerate(PIXEL_CLASSES)} | {"unclassified": int((pcls < 0).sum())}
    flag_counts = {c: int(flags[c].sum()) for c in PIXEL_CLASSES}
    bad_columns = [dict(r, x=int(origin[1] + step[1] * r.pop("index"))) for r in lines["bad_column"].records()]
    bad_rows = [dict(r, y=int(origin[0] + step[0] * r.pop("index"))) for r in lines["bad_row"].records()]
    clusters = find_clusters(listed, th.cluster_min_size)
    clusters.pop("labels")
    for cl in clusters["clusters"]:
        cl.update(x0=origin[1] + step[1] * cl.pop("col0"), x1=origin[1] + step[1] * cl.pop("col1"),
                  y0=origin[0] + step[0] * cl.pop("row0"), y1=origin[0] + step[0] * cl.pop("row1"))
    counts.update(bad_columns=len(bad_columns), bad_rows=len(bad_rows), clusters=len(clusters["clusters"]),
                  total=int(rows.size))
    if not rts_available:
        counts["rts"] = None  # type: ignore[assignment]
        flag_counts["rts"] = None  # type: ignore[assignment]
        unavailable["rts"] = rts_note
    for c in unavailable:
        if c in counts and c != "rts":
            counts[c] = None  # type: ignore[assignment]
            flag_counts[c] = None  # type: ignore[assignment]
    warnings = tuple(
        f"{c}: {n} pixels ({100 * n / (nrow * ncol):.2g} % of the array) is implausibly many for one class; "
        "check the data (frame count, exposure, illumination) before trusting it"
        for c, n in flag_counts.items() if n is not None and n > th.max_plausible_fraction * nrow * ncol)
    count_for_limit = dict(counts, cluster_size=max((c["size"] for c in clusters["clusters"]), default=0))
    limits = []
    for name, mx in th.limits().items():
        cnt = count_for_limit.get(name)
        limits.append({"name": name, "count": cnt, "max": mx,
                       "passed": None if cnt is None else bool(cnt <= mx)})
    # an unavailable count (not measurable at this frame count) cannot pass a limit
    limits = [dict(lim, passed=bool(lim["passed"])) for lim in limits]

    statistics = {
        "stuck": "minimum temporal variance over the dark levels (DN^2)",
        "rts": "level separation / within-level noise",
        "hot": "excess dark rate (e-/s)" if rate_mode else "robust z of the averaged dark",
        "noisy": "temporal variance / expected population variance",
        "dead": "response / local median response",
    }
    statistics.update(warm=statistics["hot"], low_response=statistics["dead"], high_response=statistics["dead"])
    return DefectResult(
        shape=shape, origin=tuple(origin), step=tuple(step), mask=mask, counts=counts,
        flag_counts=flag_counts, defects=defects, statistics=statistics,
        bad_columns=bad_columns, bad_rows=bad_rows, clusters=clusters, histograms=hists,
        rts_available=rts_available, rts_note=rts_note, rts_candidates=(crow, ccol),
        limits=limits, thresholds=th, notes=tuple(notes), unavailable=unavailable, detection=detection,
        warnings=warnings)
