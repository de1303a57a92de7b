"""Fe-55 X-ray gain: events found in frames (or a list of event signals), the Mn K-alpha and
K-beta lines fitted, the gain in e-/DN from the line energy and the electron yield at the
sensor's declared temperature, and the charge-transfer trend across rows and columns.

- Electron yield: ``N = E_line / E_pair(T)``, ``E_pair = 3.654 eV x (1 - 1.31e-4 /K x (T - 270 K))``
  (B. G. Lowe and R. A. Sareen, NIM A 576 (2007) 367, Fig. 4; the relation LSST's eotest
  uses, with the Mn K-alpha energy 5889 eV): 1592 e- at -95 C, 1616 e- at 20 C. The pair
  energy's own uncertainty (0.040 eV, 1.1 %) is a systematic of the absolute gain, stated
  beside its statistical SE, never folded into it.
- Events: local maxima of the bias-subtracted frame above ``threshold`` x the frame's robust
  noise sigma (declared); the event's signal is the sum of its 3x3 pixels (no charge left out
  whatever the split); its grade is ``single`` when no neighbour is above ``split`` x sigma,
  else ``split``. Events within 2 pixels of another or of the border are dropped (pile-up).
- Lines: two Gaussians, K-beta at 6490/5889 of K-alpha with the same width (as eotest),
  fitted to the histogram around the K-alpha mode by Poisson-weighted least squares; SEs from
  the fit's covariance, scaled by chi2/dof when above 1.
- Charge transfer: the K-alpha signal of the events within 2 sigma of the peak against row and
  column, a line each; its slope / the peak is the fractional loss per transfer (CTI-like).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ares.analysis.stats.estimate import Estimate
from ares.analysis.stats.physical import resolved
from ares.analysis.stats.lsq import levenberg_marquardt
from ares.analysis.ptc.fit import line_fit

KALPHA_EV = 5889.0  # Mn K-alpha (eotest's value; the K-alpha1/alpha2 doublet is 5899/5888 eV)
KBETA_EV = 6490.0  # Mn K-beta
THRESHOLD_SIGMA = 5.0  # the default event threshold, noise sigmas
MAX_LINE_WIDTH = 0.2  # sigma / peak above which a histogram peak is no X-ray line (Fano + noise: ~1-5 %)
EPAIR_REF_EV = 3.654  # Lowe & Sareen 2007, at 270 K
EPAIR_REF_SIGMA_EV = 0.040
EPAIR_SLOPE_PER_K = -1.31e-4
EPAIR_REF_K = 270.0


def pair_energy_ev(temperature_c: float) -> tuple[float, float]:
    """(E_pair, its systematic sigma) in eV at ``temperature_c`` (Lowe & Sareen 2007)."""
    f = 1.0 + EPAIR_SLOPE_PER_K * (273.2 + float(temperature_c) - EPAIR_REF_K)
    return EPAIR_REF_EV * f, EPAIR_REF_SIGMA_EV * f


def electron_yield(temperature_c: float, line_ev: float = KALPHA_EV) -> float:
    """Electrons a photon of ``line_ev`` frees in silicon at ``temperature_c``."""
    return float(line_ev) / pair_energy_ev(temperature_c)[0]


@dataclass
class Events:
    """Found events: positions, 3x3 signal (DN), peak pixel (DN), pixels above the split
    threshold, grade (0 single, 1 split), and the declared thresholds (DN)."""

    row: np.ndarray
    col: np.ndarray
    signal_dn: np.ndarray
    peak_dn: np.ndarray
    n_pixels: np.ndarray
    grade: np.ndarray
    threshold_dn: float
    split_dn: float
    noise_dn: float
    frames: int

    def counts(self) -> dict:
        return {"single": int(np.sum(self.grade == 0)), "split": int(np.sum(self.grade == 1))}


def _lit(x: np.ndarray, split: float) -> np.ndarray:
    """Pixels above ``split`` robust sigmas of the roughly levelled frame ``x``, and their 8 neighbours."""
    hit = x > split * robust_sigma(x)
    near = hit.copy()
    near[1:] |= hit[:-1]
    near[:-1] |= hit[1:]
    near[:, 1:] |= near[:, :-1].copy()
    near[:, :-1] |= near[:, 1:].copy()
    return near


def _level(frame: np.ndarray) -> np.ndarray:
    x = np.asarray(frame, np.float64)
    x = x - np.median(x)
    return x - np.median(x, axis=0)[None, :]


def bias_frame(frames, split: float = 3.0) -> np.ndarray:
    """Each pixel's mean over the frames where neither it nor a neighbour is lit: the bias with
    every fixed pattern (pixel, row and column offsets, dark signal) and no X-ray charge."""
    total = count = None
    for frame in frames:
        x = np.asarray(frame, np.float64)
        dark = ~_lit(_level(x), split)
        total = np.where(dark, x, 0.0) if total is None else total + np.where(dark, x, 0.0)
        count = dark.astype(np.int64) if count is None else count + dark
    if total is None:
        return None
    with np.errstate(invalid="ignore", divide="ignore"):
        b = total / count
    return np.where(count > 0, b, np.nanmedian(b) if np.isfinite(b).any() else 0.0)


def _residual(frame: np.ndarray, split: float = 3.0, bias: np.ndarray | None = None) -> np.ndarray:
    """The frame minus its bias (``bias``, else its median), then minus each row's and each
    column's median of the pixels that are not lit (the line terms of this frame; lit pixels
    would raise the medians: by ~0.1 % of the K-alpha signal at 2 % of the pixels lit)."""
    x = np.asarray(frame, np.float64)
    x = x - (np.median(x) if bias is None else bias)
    near = _lit(_level(x), split)
    y = np.where(near, np.nan, x)
    if np.isfinite(y).sum() <= y.size // 2:
        return _level(x)
    for axis in (1, 0):
        ok = np.isfinite(y).any(axis=axis)
        med = np.zeros(ok.size)
        med[ok] = np.nanmedian(np.compress(ok, y, axis=1 - axis), axis=axis)
        x = x - (med[:, None] if axis == 1 else med[None, :])
        y = np.where(near, np.nan, x)
    return x


def robust_sigma(x: np.ndarray) -> float:
    """1.4826 x the median absolute deviation (events are too sparse to move it)."""
    x = np.asarray(x, np.float64).ravel()
    return 1.4826 * float(np.median(np.abs(x - np.median(x))))


def find_events(frames, threshold: float = THRESHOLD_SIGMA, split: float = 3.0, bias: np.ndarray | None = None) -> Events:
    """Events in each frame of ``frames`` (an iterable of 2-D arrays); ``threshold`` and
    ``split`` in units of each frame's robust noise sigma. The bias: ``bias``, else, when
    ``frames`` can be read twice (a list, an array, a re-readable source), ``bias_frame`` of
    them (a first pass), else each frame's own median (the pixel and row offsets then stay in
    the events' sums: a bias of the realized row offsets' mean against their median, ~0.05 %)."""
    if bias is None and iter(frames) is not frames:
        bias = bias_frame(frames, split)
    rows, cols, sig, peak, npx, grade, noise = [], [], [], [], [], [], []
    n = 0
    thr_dn = split_dn = math.nan
    for frame in frames:
        n += 1
        x = _residual(frame, split, bias)
        s = robust_sigma(x)
        if not s > 0:
            s = 1.0
        noise.append(s)
        thr_dn, split_dn = threshold * s, split * s
        R, C = x.shape
        pad = np.pad(x, 1, mode="constant", constant_values=-np.inf)
        nb = np.stack([pad[1 + dr:1 + dr + R, 1 + dc:1 + dc + C]
                       for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0)])
        seed = (x > thr_dn) & np.all(x >= nb, axis=0)
        r, c = np.nonzero(seed)
        keep = (r >= 2) & (r < R - 2) & (c >= 2) & (c < C - 2)
        r, c = r[keep], c[keep]
        if r.size > 1:  # pile-up: another event seed within 2 pixels
            occ = np.zeros((R, C), np.int32)
            occ[r, c] = 1
            cs = np.pad(occ, 2).cumsum(0).cumsum(1)
            cs = np.pad(cs, ((1, 0), (1, 0)))
            box = cs[r + 5, c + 5] - cs[r, c + 5] - cs[r + 5, c] + cs[r, c]
            r, c = r[box == 1], c[box == 1]
        if r.size == 0:
            continue
        win = np.stack([x[r + dr, c + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)], axis=1)
        above = np.sum(win > split_dn, axis=1)
        rows.append(r)
        cols.append(c)
        sig.append(win.sum(axis=1))
        peak.append(x[r, c])
        npx.append(above)
        grade.append((above > 1).astype(np.int8))
    cat = (lambda a, dt: np.concatenate(a).astype(dt) if a else np.empty(0, dt))
    return Events(cat(rows, np.int64), cat(cols, np.int64), cat(sig, np.float64), cat(peak, np.float64),
                  cat(npx, np.int64), cat(grade, np.int8), float(thr_dn), float(split_dn),
                  float(np.median(noise)) if noise else math.nan, n)


def _mode(v: np.ndarray) -> float:
    """The densest value: the highest bin of a histogram of the central 98 % of ``v``, in
    bins of a robust sigma / 2 of the values near its first guess."""
    lo, hi = np.percentile(v, [1, 99])
    h, e = np.histogram(v, bins=200, range=(lo, hi))
    m = 0.5 * (e[np.argmax(h)] + e[np.argmax(h) + 1])
    near = v[np.abs(v - m) < 0.1 * abs(m)]
    if near.size > 20:
        s = robust_sigma(near)
        h, e = np.histogram(v, bins=np.arange(m - 0.3 * abs(m), m + 0.3 * abs(m), max(s / 2, 1e-9)))
        if h.size:
            m = 0.5 * (e[np.argmax(h)] + e[np.argmax(h) + 1])
    return float(m)


def _lattice(v: np.ndarray) -> float:
    """The step of the lattice the values sit on (0 when they do not): bins of a width that is
    not a whole number of steps hold alternately more and fewer lattice points, a comb that
    the line's chi2 would count as misfit."""
    u = np.unique(np.round(v, 9))
    if u.size < 3 or u.size > 0.5 * v.size:
        return 0.0
    q = float(np.min(np.diff(u)))
    if q <= 0 or not np.allclose(u / q, np.round(u / q), atol=1e-6):
        return 0.0
    for m in (8, 4, 2):  # the coarser lattice nearly all of them sit on (integer codes, a few half-codes)
        if np.mean(np.abs(v / (m * q) - np.round(v / (m * q))) < 1e-6) >= 0.9:
            return m * q
    return q


@dataclass
class LineFit:
    kalpha_dn: Estimate
    sigma_dn: Estimate
    kbeta_ratio: Estimate  # K-beta / K-alpha counts
    chi2_dof: float
    n_events: int  # events in the fit window
    window_dn: tuple
    bin_dn: float
    hist: tuple  # (bin centres, counts, model)


def _model(x, p, ratio):
    mu, s, a, b, c = p
    return (a * np.exp(-0.5 * ((x - mu) / s) ** 2) + b * np.exp(-0.5 * ((x - mu * ratio) / s) ** 2) + c)


def fit_lines(signal_dn, min_events: int = 50) -> LineFit:
    """K-alpha (and K-beta at 6490/5889 of it, same width) fitted to the histogram of the
    event signals between 0.65 and 1.4 x the K-alpha mode (eotest fits 1500-3200 DN for a
    2300 DN peak)."""
    v = np.asarray(signal_dn, np.float64)
    v = v[np.isfinite(v) & (v > 0)]
    na = lambda why: LineFit(Estimate.na(why, "DN"), Estimate.na(why, "DN"), Estimate.na(why), math.nan, int(v.size),
                             (math.nan, math.nan), math.nan, ((), (), ()))
    if v.size < min_events:
        return na(f"needs >= {min_events} events, got {v.size}")
    m = _mode(v)
    lo, hi = 0.65 * m, 1.4 * m
    w = v[(v > lo) & (v < hi)]
    near = w[np.abs(w - m) < 0.06 * m]
    s0 = robust_sigma(near) if near.size > 10 else 0.02 * m
    s0 = max(s0, 1e-6 * m)
    width = max(s0 / 4, (hi - lo) / 400)
    q = _lattice(w)
    if q > 0:  # integer codes summed (and medians, halves) sit on a lattice: whole steps per bin, edges between them
        width = max(1, round(width / q)) * q
        lo = (math.floor(lo / q) + 0.5) * q
    edges = np.arange(lo, hi + width, width)
    h, e = np.histogram(w, bins=edges)
    x = 0.5 * (e[:-1] + e[1:])
    ratio = KBETA_EV / KALPHA_EV
    sig = np.sqrt(np.maximum(h, 1.0))  # Poisson (Neyman; 1 for empty bins)
    p0 = [m, s0, float(h.max()), 0.15 * float(h.max()), 0.0]
    res = levenberg_marquardt(lambda p: _model(x, p, ratio), h.astype(float), sig, p0,
                              scale=[m, s0, max(h.max(), 1), max(h.max(), 1), 1.0])
    if res is None:
        return na(f"no X-ray line among the {v.size} event signals: their histogram has no K-alpha peak a "
                  "two-Gaussian fit converges on")
    for _ in range(3):  # Pearson weights (the model's own Poisson variance): the Neyman weights of the counts
        # pull the fit towards bins that fluctuated low and misstate its SEs at small counts
        sig = np.sqrt(np.maximum(_model(x, res[0], ratio), 0.5))
        nxt = levenberg_marquardt(lambda p: _model(x, p, ratio), h.astype(float), sig, res[0],
                                  scale=[m, s0, max(h.max(), 1), max(h.max(), 1), 1.0])
        if nxt is None:
            break
        res = nxt
    p, cov = res
    dof = max(x.size - 5, 1)
    model = _model(x, p, ratio)
    chi2 = float(np.sum(((h - model) / sig) ** 2)) / dof
    se = np.sqrt(np.maximum(np.diag(cov), 0.0)) * math.sqrt(max(chi2, 1.0))
    mu, s = float(p[0]), abs(float(p[1]))
    if not (lo < mu < hi) or not s > 0:
        return na(f"no X-ray line among the {v.size} event signals: the K-alpha fit left its window")
    if s > MAX_LINE_WIDTH * mu:
        return na(f"no X-ray line among the {v.size} event signals: their histogram's peak at {mu:.4g} DN is "
                  f"{100 * s / mu:.0f} % wide (sigma; a K-alpha line is a few %)")
    r = float(p[3] / p[2]) if p[2] > 0 else math.nan
    # counts ratio: SE of b/a from the amplitude SEs (their covariance neglected: small)
    r_se = abs(r) * math.hypot(se[2] / p[2], se[3] / p[3]) if p[3] != 0 and p[2] > 0 else math.nan
    note = "two-Gaussian fit (K-beta at 6490/5889 of K-alpha, same width), Poisson (Pearson) weights"
    return LineFit(Estimate(mu, float(se[0]), "DN", note), Estimate(s, float(se[1]), "DN", "K-alpha line width"),
                   Estimate(r, r_se, "", "K-beta / K-alpha peak heights"), chi2, int(w.size), (float(lo), float(hi)),
                   float(width), (x, h, model))


def no_xray_reason(ev: Events, fit: LineFit, threshold_sigma: float | None = None) -> str | None:
    """The plain sentence when the frames hold no X-ray events (None when they do): no candidate
    above the threshold, or candidates whose peak sits where noise peaks do -- a local maximum just
    over the threshold sums, over its 3x3 pixels, to the threshold give or take 3 noise sigmas, so
    a "line" within 3 of those (9 sigma) of the threshold is the noise's, not a photon's -- or
    candidates well above the noise whose signals hold no line (hot pixels, cosmic rays)."""
    n, thr, noise = int(ev.signal_dn.size), ev.threshold_dn, ev.noise_dn
    if not math.isfinite(thr):  # an event list: no threshold to judge against
        return None
    t = f" ({threshold_sigma:g} x the {noise:.3g} DN noise)" if threshold_sigma else f" (noise {noise:.3g} DN)"
    where = f"above the threshold {thr:.4g} DN{t} in {ev.frames} frames"
    if n == 0:
        return f"no X-ray events found: 0 candidate events {where}"
    k = fit.kalpha_dn
    peak, what = (k.value, "peak") if k.available else (float(np.median(ev.signal_dn)), "have a median signal")
    if peak < thr + 9 * noise:
        return (f"no X-ray events found: the {n} candidate events {where} {what} at {peak:.4g} DN, within 9 noise "
                "sigmas of the threshold: noise peaks, not X-rays")
    if not k.available and k.note.startswith("no X-ray line"):  # signals well above the noise, but no line
        return (f"no X-ray line found among the {n} candidate events {where} (median signal {peak:.4g} DN): "
                + k.note.split(": ", 1)[1])
    return None


def gain_e_per_dn(kalpha_dn: Estimate, temperature_c: float, line_ev: float = KALPHA_EV) -> tuple[Estimate, float]:
    """(gain in e-/DN with its statistical SE, the relative systematic of the pair energy)."""
    ne = electron_yield(temperature_c, line_ev)
    ep, ep_sig = pair_energy_ev(temperature_c)
    if not kalpha_dn.available or kalpha_dn.value <= 0:
        return Estimate.na(kalpha_dn.note or "no K-alpha peak", "e-/DN"), ep_sig / ep
    g = ne / kalpha_dn.value
    return (Estimate(g, g * kalpha_dn.se / kalpha_dn.value, "e-/DN",
                     f"{ne:.1f} e- per K-alpha at {temperature_c:g} C / K-alpha peak"), ep_sig / ep)


def transfer_trend(ev: Events, fit: LineFit) -> dict[str, Estimate]:
    """Fractional K-alpha signal change per row and per column transfer (negative: lost)."""
    out = {}
    for name, pos in (("per_row", ev.row), ("per_col", ev.col)):
        if not fit.kalpha_dn.available or pos.size == 0:
            out[name] = Estimate.na("the events hold no positions" if pos.size == 0 else fit.kalpha_dn.note, "1/px")
            continue
        mu, s = fit.kalpha_dn.value, fit.sigma_dn.value
        sel = np.abs(ev.signal_dn - mu) < 2 * s
        if sel.sum() < 20 or np.ptp(pos[sel]) == 0:
            out[name] = Estimate.na(f"needs >= 20 K-alpha events spread over the {name[4:]}s", "1/px")
            continue
        lf = line_fit(pos[sel].astype(float), ev.signal_dn[sel])
        out[name] = resolved(Estimate(lf.slope / mu, lf.slope_se / mu, "1/px",
                                      f"slope of the K-alpha signal vs {name[4:]} / peak ({int(sel.sum())} events)"),
                             f"signal change per {name[4:]}")
    return out


def analyse(signal_dn, temperature_c: float, events: Events | None = None, line_ev: float = KALPHA_EV,
            threshold_sigma: float | None = None) -> dict:
    """Everything ``ares fe55`` reports, as Estimates and plain numbers; ``xray_events`` False
    (with ``no_xray`` the sentence why) when the frames hold no X-ray events."""
    fit = fit_lines(signal_dn)
    why = no_xray_reason(events, fit, threshold_sigma) if events is not None else None
    if why:
        fit = LineFit(Estimate.na(why, "DN"), Estimate.na(why, "DN"), Estimate.na(why), math.nan, fit.n_events,
                      fit.window_dn, fit.bin_dn, fit.hist)
    gain, sys_rel = gain_e_per_dn(fit.kalpha_dn, temperature_c, line_ev)
    out = {"kalpha_dn": fit.kalpha_dn, "kalpha_sigma_dn": fit.sigma_dn, "kbeta_ratio": fit.kbeta_ratio,
           "gain_e_per_dn": gain, "electrons_per_kalpha": electron_yield(temperature_c, line_ev),
           "pair_energy_ev": pair_energy_ev(temperature_c)[0], "gain_systematic_rel": sys_rel,
           "temperature_c": float(temperature_c), "line_ev": float(line_ev), "chi2_dof": fit.chi2_dof,
           "events_in_fit": fit.n_events, "events_total": int(np.size(signal_dn)), "fit_window_dn": fit.window_dn,
           "bin_dn": fit.bin_dn, "xray_events": why is None, "_fit": fit}
    if why:
        out["no_xray"] = why
    if events is not None:
        out.update(events.counts())
        out["threshold_dn"], out["split_dn"], out["noise_dn"], out["frames"] = (
            events.threshold_dn, events.split_dn, events.noise_dn, events.frames)
        tt = transfer_trend(events, fit)
        out["transfer_per_row"], out["transfer_per_col"] = tt["per_row"], tt["per_col"]
    return out
