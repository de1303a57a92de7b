"""Spatial frequency response by the slanted-edge method (ISO 12233:2017 e-SFR).

The steps of the standard's e-SFR (ISO 12233:2017 Annex D, as its reference implementation
sfrmat3 by Burns carries them out):

1. the edge runs near the vertical in the region of interest (a near-horizontal one is
   transposed first); each row is differentiated ([-1/2, +1/2]) and the centroid of its
   Hamming-windowed derivative located (the window centred on the row's middle); a
   first-order polynomial ``x = a + b y`` is fitted to the centroids, then again with each
   row's window centred on the first line;
2. the first ``round(floor(rows |b|) / |b|)`` rows are kept (a whole number of phase cycles);
3. every pixel is projected along the edge onto the row axis (``x - (a + b y)``) and the
   values averaged in bins of a quarter pixel, ``4 x columns`` bins centred on the edge (the
   4x oversampled edge-spread function, ESF); an empty bin takes its neighbours' line;
4. the ESF is differentiated by the [-1/2, 0, +1/2] FIR into the line-spread function (LSF),
   and a Hamming window the length of the array is centred on the LSF's centroid;
5. the modulus of its DFT, normalised to 1 at zero frequency, is divided by the FIR's own
   transfer ``sinc(2 k / n)`` (the derivative correction; sfrmat3's ``fir2fix`` has it one
   index off, the exact form is used here) and the frequency axis ``k / (n d)``, d = 1/4
   pixel, is rescaled by 1 / cos(angle) to cycles per pixel along the edge normal;
6. MTF50 (the first frequency where the SFR falls to 0.5, linear interpolation) and the
   SFR at the Nyquist frequency (0.5 cycles/pixel; 0.25 cycles per sensor pixel for one
   channel of a Bayer mosaic) are read off.

One option beside the standard: ``esf_half_width`` (e.g. ``LOW_NOISE_HALF_WIDTH``) keeps only
the ESF within that many pixels of the edge that every row covers, less noise in the LSF's
window; the standard value (None) bins the whole region.

Standard errors come
from a parametric bootstrap (fixed seed): the image analysed again with noise of its own
level added (each side's noise from row-to-row differences, the variance interpolated in
the level), which carries the noise through the edge fit, the binning and the DFT.
Verdicts: the edge angle must lie in 2-22 degrees, the edge step must be at
least ``MIN_STEP_SNR`` times the pixel noise, and no pixel of the region may be clipped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ares.analysis.stats.estimate import Estimate

OVERSAMPLE = 4
ANGLE_RANGE_DEG = (2.0, 22.0)
MIN_STEP_SNR = 10.0  # edge step / pixel noise below this: "too little contrast"
BOOTSTRAP = 40
LOW_NOISE_HALF_WIDTH = 16.0  # the option esf_half_width: ESF kept within 16 px of the edge (not the standard)
CHANNEL_NAMES = {"RGGB": ("R", "Gr", "Gb", "B"), "GRBG": ("Gr", "R", "B", "Gb"),
                 "GBRG": ("Gb", "B", "R", "Gr"), "BGGR": ("B", "Gb", "Gr", "R")}


@dataclass
class SfrResult:
    freq: np.ndarray  # cycles per (sensor) pixel
    mtf: np.ndarray
    nyquist: float
    angle_deg: Estimate
    mtf50: Estimate
    mtf_nyquist: Estimate
    step_snr: float
    notes: list = field(default_factory=list)

    def to_dict(self, curve: bool = True) -> dict:
        d = {"angle_deg": self.angle_deg.to_dict(), "mtf50_cy_per_px": self.mtf50.to_dict(),
             "mtf_at_nyquist": self.mtf_nyquist.to_dict(), "nyquist_cy_per_px": self.nyquist,
             "edge_step_snr": round(float(self.step_snr), 2) if math.isfinite(self.step_snr) else None}
        if curve and self.freq.size:
            keep = self.freq <= 2 * self.nyquist + 1e-9
            d["freq_cy_per_px"] = [round(float(f), 5) for f in self.freq[keep]]
            d["mtf"] = [round(float(m), 5) for m in self.mtf[keep]]
        if self.notes:
            d["notes"] = list(self.notes)
        return d


def _hamming(n: int, mid: float) -> np.ndarray:
    """A Hamming window of n samples centred on ``mid`` (sfrmat's ``ahamming``: the half-width
    is the longer side, so the window reaches 0.08 at the farther end)."""
    half = max(mid, n - 1 - mid, 1.0)
    return 0.54 + 0.46 * np.cos(np.pi * (np.arange(n) - mid) / half)


def _centroids(img: np.ndarray, centre: np.ndarray | None) -> np.ndarray:
    """Each row's centroid of its [-1/2, +1/2] derivative (at x + 0.5) times a Hamming window
    centred on the row's middle (first pass) or on ``centre`` (second pass)."""
    d = np.diff(img, axis=1) / 2.0
    d = d * np.sign(d.sum()) if d.sum() else d
    x = np.arange(d.shape[1]) + 0.5
    if centre is None:
        d = d * _hamming(d.shape[1], (d.shape[1] - 1) / 2.0)[None, :]
    else:
        d = d * np.stack([_hamming(d.shape[1], c - 0.5) for c in centre])
    s = d.sum(axis=1)
    s[s == 0] = np.nan
    return (d * x).sum(axis=1) / s


def fit_edge(img: np.ndarray) -> tuple[float, float]:
    """(a, b) of the edge line ``x = a + b y`` from the rows' windowed derivative centroids
    (first-order polynomial, fitted twice: the second pass windows each row on the first line)."""
    y = np.arange(img.shape[0], dtype=np.float64)
    c = _centroids(img, None)
    ok = np.isfinite(c)
    b, a = np.polyfit(y[ok], c[ok], 1)
    c = _centroids(img, a + b * y)
    ok = np.isfinite(c)
    b, a = np.polyfit(y[ok], c[ok], 1)
    return float(a), float(b)


def _esf_mtf(img: np.ndarray, a: float, b: float, half_width: float | None = None):
    """(freq in cycles/pixel along the edge normal, SFR, ESF) from rows ``img`` and the edge
    line ``x = a + b y``: the standard's projection along the edge onto the row axis in bins of
    a quarter pixel, ``4 x columns`` bins centred on the edge (``half_width``: only the bins
    within that many pixels of the edge, see ``sfr``), the frequency axis rescaled by
    1 / cos(angle) for the bins' spacing along the normal."""
    R, C = img.shape
    cos = 1.0 / math.sqrt(1.0 + b * b)
    y = np.arange(R, dtype=np.float64)[:, None]
    x = np.arange(C, dtype=np.float64)[None, :]
    rel = x - (a + b * y)  # along the rows, from the edge
    nb = C * OVERSAMPLE
    lo = -nb // 2
    if half_width is not None:  # the distance range every row covers, at most half_width either side
        lo_d = max(float(np.max(-(a + b * y))), -half_width / cos)
        hi_d = min(float(np.min(C - 1 - (a + b * y))), half_width / cos)
        lo, nb = int(math.ceil(lo_d * OVERSAMPLE)), int(math.floor((hi_d - lo_d) * OVERSAMPLE))
        if nb < 8 * OVERSAMPLE:
            return None
    idx = (np.floor(rel * OVERSAMPLE).astype(np.int64) - lo).ravel()
    v = img.ravel()
    keep = (idx >= 0) & (idx < nb)
    cnt = np.bincount(idx[keep], minlength=nb)
    tot = np.bincount(idx[keep], weights=v[keep], minlength=nb)
    have = cnt > 0
    if have.sum() < nb // 2:
        return None
    k = np.arange(nb)
    esf = np.interp(k, k[have], tot[have] / cnt[have])  # an empty bin: its neighbours' line
    lsf = np.zeros(nb)
    lsf[1:-1] = (esf[2:] - esf[:-2]) / 2.0  # [-1/2, 0, +1/2]
    lsf[0], lsf[-1] = lsf[1], lsf[-2]
    if lsf.sum() < 0:
        lsf = -lsf
    mid = int(round(float((lsf * k).sum() / lsf.sum()))) if lsf.sum() > 0 else nb // 2
    # the standard shifts the LSF's centroid to the array's middle and applies a symmetric
    # Hamming window of the array's length: the same |DFT| as this window about the centroid,
    # with the samples the shift pushes out dropped
    half = (nb - 1) / 2.0
    w = np.where(np.abs(k - mid) <= half, 0.54 + 0.46 * np.cos(np.pi * (k - mid) / half), 0.0)
    spec = np.abs(np.fft.rfft(lsf * w))
    if spec[0] <= 0:
        return None
    kf = np.arange(spec.size) / nb  # cycles per bin
    corr = np.sinc(2 * kf)  # the central difference's own transfer (its FIR correction)
    corr = np.where(kf < 0.4, corr, np.nan)
    mtf = spec / spec[0] / corr
    freq = kf * OVERSAMPLE / cos  # bins are 1/4 pixel along the rows, cos/4 along the normal
    ok = np.isfinite(mtf)
    return freq[ok], mtf[ok], esf


def mtf50_of(freq: np.ndarray, mtf: np.ndarray, level: float = 0.5) -> float:
    """First frequency where ``mtf`` falls to ``level`` (linear interpolation), else nan."""
    below = np.nonzero(mtf < level)[0]
    if not below.size or below[0] == 0:
        return math.nan
    i = below[0]
    f0, f1, m0, m1 = freq[i - 1], freq[i], mtf[i - 1], mtf[i]
    return float(f0 + (m0 - level) * (f1 - f0) / (m0 - m1))


def _noise(img: np.ndarray) -> float:
    """Pixel noise from row-to-row differences (the edge is near vertical), robust (MAD)."""
    d = np.diff(img, axis=0).ravel()
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


def _noise_map(img: np.ndarray, a: float, b: float) -> np.ndarray:
    """Per-pixel noise sigma: the dark and bright sides' noise (row-to-row differences, more
    than 4 pixels from the edge), the variance interpolated linearly in the level between
    them (shot noise)."""
    y = np.arange(img.shape[0])[:, None]
    dist = np.arange(img.shape[1])[None, :] - (a + b * y)
    d = np.diff(img, axis=0)
    sides = []
    for m in (dist[1:] < -4, dist[1:] > 4):
        sides.append((float(np.mean(img[1:][m])) if m.any() else math.nan,
                      float(np.var(d[m & ((dist[:-1] < -4) | (dist[:-1] > 4))], ddof=1)) / 2 if m.sum() > 2 else math.nan))
    (l0, v0), (l1, v1) = sides
    if not all(math.isfinite(x) for x in (l0, v0, l1, v1)) or l1 == l0:
        return np.full(img.shape, _noise(img))
    var = v0 + (img - l0) * (v1 - v0) / (l1 - l0)
    return np.sqrt(np.clip(var, min(v0, v1), max(v0, v1)))


def _one(img: np.ndarray, half_width: float | None = None):
    a, b = fit_edge(img)
    R = img.shape[0]
    if abs(b) > 1e-6:  # whole phase cycles: the first round(floor(R |b|) / |b|) rows (step 2)
        n = int(round(math.floor(R * abs(b)) / abs(b)))
        if n >= 16:
            img = img[:n]
    r = _esf_mtf(img, a, b, half_width)
    return a, b, r


def sfr(image, *, max_code: float | None = None, pixel_scale: int = 1, bootstrap: int = BOOTSTRAP,
        seed: int = 0, esf_half_width: float | None = None) -> SfrResult:
    """The e-SFR of one edge region (2-D array; a near-horizontal edge is transposed).

    ``max_code``: the full-scale code (clipping check; None: not checked);
    ``pixel_scale``: sensor pixels per image pixel (2 for one channel of a Bayer mosaic),
    frequencies are reported per sensor pixel;
    ``esf_half_width``: None (the standard) bins the whole region; a number (e.g.
    ``LOW_NOISE_HALF_WIDTH``) keeps only the ESF within that many pixels of the edge that every
    row covers, less noise in the LSF's window at the cost of the standard's tails."""
    img = np.asarray(image, dtype=np.float64)
    nyq = 0.5 / pixel_scale
    na = lambda why: SfrResult(np.zeros(0), np.zeros(0), nyq, Estimate.na(why, "deg"),  # noqa: E731
                               Estimate.na(why, "cy/px"), Estimate.na(why), math.nan, [why])
    if img.ndim != 2 or min(img.shape) < 16:
        return na(f"the edge region is {img.shape}, it needs at least 16x16 pixels")
    if not np.all(np.isfinite(img)):
        return na("the edge region holds values that are not finite numbers")
    if max_code is not None:
        clipped = int(np.sum(img >= max_code) + np.sum(img <= 0))
        if clipped:
            return na(f"clipping: {clipped} pixels of the edge region are at 0 or the full-scale code "
                      f"{max_code:g}; lower the exposure or the light")
    gx = abs(float(np.mean(img[:, -4:]) - np.mean(img[:, :4])))  # the net change across the rows ...
    gy = abs(float(np.mean(img[-4:]) - np.mean(img[:4])))  # ... and down the columns
    if gy > gx:
        img = img.T
    try:
        a, b, r = _one(img, esf_half_width)
    except (np.linalg.LinAlgError, ValueError, TypeError):
        r = None
    if r is None:
        return na("no edge found in the region (the row derivatives have no usable centroid)")
    freq, mtf, esf = r
    angle = math.degrees(math.atan(abs(b)))
    m = max(len(esf) // 10, 2)
    step = abs(float(np.mean(esf[-m:]) - np.mean(esf[:m])))
    noise = _noise(img)
    snr = step / noise if noise > 0 else math.inf
    if not ANGLE_RANGE_DEG[0] <= round(angle, 1) <= ANGLE_RANGE_DEG[1]:
        why = (f"the edge angle {angle:.2f} deg is outside {ANGLE_RANGE_DEG[0]:g}-{ANGLE_RANGE_DEG[1]:g} deg "
               "(ISO 12233 e-SFR needs a slanted edge)")
        out = na(why)
        out.angle_deg = Estimate(angle, math.nan, "deg", "edge line fit")
        return out
    if snr < MIN_STEP_SNR:
        return na(f"too little contrast: the edge step is {snr:.1f} times the pixel noise "
                  f"(needs at least {MIN_STEP_SNR:g})")
    f50 = mtf50_of(freq, mtf) / pixel_scale
    fs = freq / pixel_scale
    mn = float(np.interp(nyq, fs, mtf))
    sig = _noise_map(img, a, b)
    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(bootstrap):  # parametric: the same image with noise of its own level added again
        try:
            _, bb, rb = _one(img + sig * rng.standard_normal(img.shape), esf_half_width)
        except (np.linalg.LinAlgError, ValueError, TypeError):
            continue
        if rb is None:
            continue
        boot.append((math.degrees(math.atan(abs(bb))), mtf50_of(rb[0], rb[1]) / pixel_scale,
                     float(np.interp(nyq, rb[0] / pixel_scale, rb[1]))))
    se = np.nanstd(np.array(boot), axis=0, ddof=1) if len(boot) > 1 else np.full(3, np.nan)
    how = (f"ISO 12233 e-SFR{'' if esf_half_width is None else f' with the option esf_half_width={esf_half_width:g} px (not the standard)'}; "
           f"SE from {len(boot)} re-noised copies of the image")
    e50 = (Estimate(f50, float(se[1]), "cy/px", how) if math.isfinite(f50)
           else Estimate.na("the SFR does not fall to 0.5 within the measured frequencies", "cy/px"))
    return SfrResult(fs, mtf, nyq, Estimate(angle, float(se[0]), "deg", "edge line fit"), e50,
                     Estimate(mn, float(se[2]), "", how), snr)


def channels_dict(std: dict[str, SfrResult], opt: dict[str, SfrResult] | None = None,
                  esf_half_width: float | None = None, curve: bool = True) -> dict[str, dict]:
    """The JSON form of ``sfr_channels``' results: each channel's standard result, and when the
    option ``esf_half_width`` was run too, its result beside it under ``"option"`` (labelled with
    the option's value; never in place of the standard's figures)."""
    out = {}
    for name, r in std.items():
        d = r.to_dict(curve=curve)
        if opt is not None and name in opt:
            d["option"] = {"esf_half_width": esf_half_width, **opt[name].to_dict(curve=curve)}
        out[name] = d
    return out


def sfr_channels(image, pattern: str | None = None, **kw) -> dict[str, SfrResult]:
    """The e-SFR of a monochrome image (``{"mono": ...}``) or of each channel of a Bayer
    mosaic (``pattern`` one of RGGB, GRBG, GBRG, BGGR), each channel's own pixels."""
    img = np.asarray(image)
    if pattern is None or pattern.lower() in ("mono", "none", ""):
        return {"mono": sfr(img, **kw)}
    names = CHANNEL_NAMES[pattern.upper()]
    return {names[2 * r + c]: sfr(img[r::2, c::2], pixel_scale=2, **kw) for r in (0, 1) for c in (0, 1)}
