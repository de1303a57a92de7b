"""A small Gaussian sensor with injected defects of known location and class.

Independent of ``ares.sim`` on purpose: the defect classifier is tested against a truth
that is simple enough to check by hand. Dark: offset + column FPN + pixel FPN + white
temporal noise; flat: dark + response (with PRNU and a smooth illumination fall-off) +
Gaussian shot noise. Units are DN throughout; ``gain`` converts injected e-/s.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

CLASSES = ("hot", "warm", "dead", "stuck", "noisy", "rts")


@dataclass
class Injected:
    dark: np.ndarray  # (F, R, C) uint16
    flat: np.ndarray  # (Ff, R, C) uint16
    truth: dict  # class -> (rows, cols); "bad_columns" -> column indices
    gain: float
    exposure_s: float
    params: dict = field(default_factory=dict)

    def truth_map(self) -> np.ndarray:
        """Class name per pixel ('' for good)."""
        m = np.full(self.dark.shape[1:], "", dtype="U13")
        for c in CLASSES:
            r, cc = self.truth[c]
            m[r, cc] = c
        return m


def inject(rows=240, cols=320, frames=100, flat_frames=20, seed=0, *, rate_ppm=1000.0,
           offset=200.0, temporal_dn=2.0, pixel_fpn_dn=1.0, col_fpn_dn=1.0, gain=0.5,
           exposure_s=10.0, hot_e_per_s=(8.0, 40.0), warm_e_per_s=(2.0, 4.0),
           rts_amp_sigma=(5.0, 10.0), rts_switch=0.1, noisy_factor=5.0, dead_response=0.3,
           flat_level=2000.0, prnu=0.01, bad_columns=2, bad_column_offset=20.0,
           rates: dict | None = None, pattern: str | None = None, pattern_dn: float = 10.0) -> Injected:
    """``pattern``: a dark structure under the defects -- "smooth" (a Gaussian glow of
    ``pattern_dn`` over a third of the array) or "periodic" (``pattern_dn`` x
    sin(2 pi x/48) sin(2 pi y/48), not separable into row and column offsets)."""
    rng = np.random.default_rng(seed)
    n = rows * cols
    rates = dict({c: rate_ppm for c in CLASSES}, **(rates or {}))
    counts = {c: int(round(rates[c] * 1e-6 * n)) for c in CLASSES}
    idx = rng.choice(n, size=sum(counts.values()), replace=False)
    truth, start = {}, 0
    for c in CLASSES:
        sel = np.sort(idx[start:start + counts[c]])
        start += counts[c]
        truth[c] = (sel // cols, sel % cols)
    bad = np.sort(rng.choice(cols, size=bad_columns, replace=False))
    truth["bad_columns"] = bad

    base = offset + rng.normal(0, col_fpn_dn, cols)[None, :] + rng.normal(0, pixel_fpn_dn, (rows, cols))
    base[:, bad] += bad_column_offset
    if pattern is not None:
        yy, xx = np.mgrid[0:rows, 0:cols].astype(float)
        if pattern == "smooth":
            s2 = (min(rows, cols) / 3.0) ** 2
            base += pattern_dn * np.exp(-((yy - 0.3 * rows) ** 2 + (xx - 0.6 * cols) ** 2) / (2 * s2))
        elif pattern == "periodic":
            base += pattern_dn * np.sin(2 * np.pi * xx / 48) * np.sin(2 * np.pi * yy / 48)
        else:
            raise ValueError(f"unknown pattern {pattern!r}")
    extra = np.zeros((rows, cols))  # dark signal excess (DN)
    r, c = truth["hot"]
    extra[r, c] = rng.uniform(*hot_e_per_s, r.size) * exposure_s * gain
    r, c = truth["warm"]
    extra[r, c] = rng.uniform(*warm_e_per_s, r.size) * exposure_s * gain
    sigma = np.full((rows, cols), temporal_dn)
    r, c = truth["noisy"]
    sigma[r, c] *= noisy_factor
    mean_dark = base + extra
    # dark shot noise of the excess
    sig_dark = np.sqrt(sigma**2 + extra * gain)

    def frames_of(mean, sig, nf):
        out = np.empty((nf, rows, cols), np.uint16)
        for f in range(nf):
            out[f] = np.clip(np.rint(mean + rng.standard_normal((rows, cols)) * sig), 0, 65535)
        return out

    dark = frames_of(mean_dark, sig_dark, frames)
    # RTS: two-state Markov chain per pixel
    r, c = truth["rts"]
    amp = rng.uniform(*rts_amp_sigma, r.size) * temporal_dn
    state = rng.random(r.size) < 0.5
    states = np.empty((frames, r.size), bool)
    for f in range(frames):
        flip = rng.random(r.size) < rts_switch
        state = state ^ flip
        states[f] = state
        dark[f, r, c] = np.clip(dark[f, r, c] + np.rint(amp * state), 0, 65535).astype(np.uint16)
    # stuck
    r, c = truth["stuck"]
    codes = rng.integers(0, 4096, r.size).astype(np.uint16)
    dark[:, r, c] = codes

    yy, xx = np.mgrid[0:rows, 0:cols]
    illum = 1.0 - 0.2 * (((yy - rows / 2) / rows) ** 2 + ((xx - cols / 2) / cols) ** 2)
    resp = flat_level * illum * (1 + rng.normal(0, prnu, (rows, cols)))
    r, c = truth["dead"]
    resp[r, c] *= dead_response
    flat = frames_of(mean_dark + resp, np.sqrt(sig_dark**2 + gain * resp), flat_frames)
    r, c = truth["stuck"]
    flat[:, r, c] = codes
    return Injected(dark, flat, truth, gain, exposure_s,
                    dict(temporal_dn=temporal_dn, pixel_fpn_dn=pixel_fpn_dn, offset=offset, rts_amp=amp,
                         rts_states=states))


def confusion(truth_map: np.ndarray, result) -> tuple[dict, str]:
    """Confusion counts {(true, predicted): n} over pixels, and a printable table."""
    from ares.analysis.defects.result import PIXEL_CLASSES, primary_class

    prim = primary_class(result.mask)
    pred = np.where(prim >= 0, np.array(PIXEL_CLASSES)[np.maximum(prim, 0)], "")
    pred_names = [""] + list(PIXEL_CLASSES)
    true_names = [""] + [c for c in CLASSES]
    table = {}
    for t in true_names:
        tm = truth_map == t
        for p in pred_names:
            table[(t, p)] = int(np.count_nonzero(tm & (pred == p)))
    w = 8
    lines = ["true \\ predicted".ljust(17) + "".join((p or "good")[:w].rjust(w + 1) for p in pred_names)]
    for t in true_names:
        lines.append((t or "good").ljust(17) + "".join(str(table[(t, p)]).rjust(w + 1) for p in pred_names))
    return table, "\n".join(lines)
