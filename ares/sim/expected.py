"""The expected image of a ``SimSensor`` at an operating point: per pixel the mean code that
infinitely many frames converge to, through the ADC's own transition levels -- the truth of a
figure defined on an averaged image (EMVA 1288 4.0 Linear Section 8: DSNU1288, PRNU1288, the
spatial variances of the mean dark and 50 % images once the temporal noise is gone).

Per pixel: the analog mean x (offsets, channel offsets and black level, dark charge, photo
signal through the gain map, a telegraph trap's mean bump) and its temporal sigma s (read noise
with the noisy pixels' factor, chain, row, column and frame-wide terms, dark and photo shot
noise, the light's flutter); the code's mean is sum_k Phi((x - T_k) / s) over the transition
levels T_k (k - 1/2 for an ideal ADC), which holds the INL/DNL, the dither the noise gives and
the clipping at 0 and the top code. A trap: the mixture of its two levels at its stationary
occupancy P_up / (P_up + P_down); a stuck pixel: its code. Left out: the full-well clip (the
mean of a pixel near it) and lag (a constant scene's mean is unchanged by it).
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr


def _mean_code(x: np.ndarray, s: np.ndarray, levels: np.ndarray, ideal: bool = False) -> np.ndarray:
    """sum_k Phi((x - T_k) / s) for each pixel: the levels below x - 9 s counted whole, the ones
    within +-9 s summed (a level farther off adds less than 1e-19). ``ideal``: the levels are
    k - 1/2 (an ideal ADC); there a pixel with s >= 1 whose +-9 s lies inside the levels has
    mean code x (E[round(x + s Z)] = x + a periodic term of amplitude exp(-2 pi^2 s^2) / pi
    < 1e-9 DN, Poisson summation), so only the others are summed (a bright image's +-9 s
    spans hundreds of levels: seconds a frame)."""
    s = np.maximum(s, 1e-9)
    if ideal and x.size:
        inside = (s >= 1.0) & (x - 9 * s > levels[0]) & (x + 9 * s < levels[-1])
        if inside.any():
            out = np.array(x, np.float64)
            rest = ~inside
            out[rest] = _mean_code(x[rest], s[rest], levels)
            return out
    lo = np.searchsorted(levels, x - 9 * s, side="right")
    hi = np.searchsorted(levels, x + 9 * s, side="right")
    out = lo.astype(np.float64)
    pad = np.concatenate((levels, [np.inf]))
    for j in range(int(np.max(hi - lo)) if x.size else 0):
        k = np.minimum(lo + j, levels.size)
        use = lo + j < hi
        out += np.where(use, ndtr((x - pad[k]) / s), 0.0)
    return out


def expected_codes(sensor, **kw) -> np.ndarray:
    """The expected image (float64, rows x cols, DN) of ``sensor`` at the operating point of
    ``SimSensor.render``'s keywords (``photon_flux``, ``exposure_s``, ``analog_gain``, ...)."""
    kw.pop("start_frame", None)
    kw.pop("offset_dn", None)
    sc = sensor.scene(**kw)
    p, fp = sensor.params, sensor.patterns
    G = sc.G
    adc = fp.adc
    x = np.broadcast_to(((fp.col_fpn_dn + fp.bad_column_offset_dn)[None, :] + fp.row_fpn_dn[:, None])
                        .astype(np.float64), sensor.shape).copy()
    if p.pixel_fpn_e > 0:
        x += G * fp.pixel_offset_e.astype(np.float64)
    var = (G * sc.read_noise_e * fp.read_noise_factor.astype(np.float64)) ** 2 + p.chain_noise_dn**2
    var += p.row_temporal_dn**2 + p.col_temporal_dn**2 + p.frame_global_dn**2
    if sc.dark_e is not None:
        d = np.minimum(np.asarray(sc.dark_e, np.float64), p.full_well_e)
        x += G * d
        var = var + G * G * d
    if np.any(np.asarray(sc.q) > 0):
        g = G * (fp.col_gain[None, :] * fp.row_gain[:, None]).astype(np.float64) * fp.pixel_gain * fp.response
        sig = g * np.asarray(sc.q, np.float64)
        x += sig
        var = var + g * sig + (p.flutter_pct / 100 * sig) ** 2
    x *= adc.gain_col
    var = var * adc.gain_col.astype(np.float64) ** 2
    x += adc.offset_col + sc.black_level_dn
    ideal = adc.thresholds is None
    levels = adc.thresholds if not ideal else np.arange(1, adc.max_code + 1) - 0.5
    s = np.sqrt(var)
    out = _mean_code(x, s, levels, ideal)
    rts = fp.defects.index["rts"]
    if len(rts):
        pu, pd = fp.rts_p_up.astype(np.float64), fp.rts_p_down.astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            occ = np.where(pu + pd > 0, pu / (pu + pd), fp.rts_state0)
        bump = G * fp.defects.rts_amplitude_e.astype(np.float64) * adc.gain_col[rts % sensor.shape[1]]
        xr, sr = x.ravel()[rts], s.ravel()[rts]
        out.ravel()[rts] = (1 - occ) * out.ravel()[rts] + occ * _mean_code(xr + bump, sr, levels)
    stuck = fp.defects.index["stuck"]
    if len(stuck):
        out.ravel()[stuck] = fp.defects.stuck_code
    return out
