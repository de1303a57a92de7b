"""``ares rtn``: random telegraph noise measured per pixel over a long dark time series.

    ares rtn DARKS... [--z 5] [--bic-margin 10] [--two-levels] [--frame-period-s S] [--json] [--csv FILE] [--hdf5 FILE]

The dark frames (PNG/TIFF lists or folders, .npy, .npz, .h5:/dataset; >= 100 frames, 1000 or
more for dwell times to 10 %) are read three times, frame by frame (memory O(pixels) plus the
candidates' series): the pixels' means; each pixel's lag-1 autocorrelation after the row and
column terms (candidates: ``--z`` SEs above 0); the candidates' series, fitted with 1-, 2- and
3-level hidden Markov models, the number of levels chosen by BIC (``ares.analysis.lowlight.rtn``).
Per RTN pixel: levels, amplitude and mean dwell times with SEs; the fraction of RTN pixels, the
read noise with and without them, histograms, and the frames a given amplitude needs.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ares.commands.jsonable import jsonable
from ares.errors import InputError

NAME = "rtn"
HELP = "random telegraph noise per pixel: levels, amplitudes, dwell times, share of the read noise"
MIN_FRAMES = 100
SERIES_BYTES = 256 * 1024 * 1024  # the candidates' series held at once


def add_arguments(p) -> None:
    p.add_argument("darks", nargs="+", help="dark frames (PNG/TIFF, folders, .npy, .npz, .h5:/dataset), in time order")
    p.add_argument("--z", type=float, default=5.0, help="screen: lag-1 autocorrelation in SEs (default 5)")
    p.add_argument("--bic-margin", type=float, default=10.0,
                   help="BIC of 2 or 3 levels below 1 level's by at least this (default 10)")
    p.add_argument("--two-levels", action="store_true", help="fit 1 and 2 levels only (no 3-level model)")
    p.add_argument("--frame-period-s", type=float, default=None, help="time between frames, s: dwell times in s too")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--csv", default=None, metavar="FILE", help="write one row per RTN pixel")
    p.add_argument("--hdf5", default=None, metavar="FILE", help="write the RTN maps (amplitude, dwell times, noise)")


def analyse_files(darks, z: float, margin: float, three: bool):
    from ares.analysis.lowlight import rtn
    from ares.hardware.stackfiles import iter_frames

    mp = rtn.MeanPass()
    for f in iter_frames(darks):
        mp.add(f)
    if mp.n < MIN_FRAMES:
        raise InputError(f"the darks hold {mp.n} frame(s); RTN needs >= {MIN_FRAMES} (1000 or more for dwell times "
                         "to 10 %)")
    sc = rtn.Screen(mp.mean)
    for f in iter_frames(darks):
        sc.add(f)
    import numpy as np

    cand = sc.candidates(z)
    # the candidates' series in groups of at most SERIES_BYTES (float32), one more pass over the files each
    per = max(1, SERIES_BYTES // (4 * mp.n))
    parts = []
    for s in range(0, max(cand.size, 1), per):
        group = cand[s:s + per]
        se = rtn.Series(mp.mean, group)
        if group.size:
            for f in iter_frames(darks):
                se.add(f)
        parts.append(rtn.fit_levels(se.series if group.size else np.zeros((mp.n, 0)), group, margin, three))
    return rtn.join(parts), sc, mp.mean.shape


def run(args) -> int:
    from ares.analysis.lowlight import rtn

    if not (args.z > 0 and math.isfinite(args.z)):
        raise InputError(f"--z {args.z:g}: give a positive number of SEs")
    if not (args.bic_margin >= 0 and math.isfinite(args.bic_margin)):
        raise InputError(f"--bic-margin {args.bic_margin:g}: give a non-negative number")
    if args.frame_period_s is not None and not (args.frame_period_s > 0 and math.isfinite(args.frame_period_s)):
        raise InputError(f"--frame-period-s {args.frame_period_s:g}: give the time between frames in s (> 0)")
    px, sc, shape = analyse_files(args.darks, args.z, args.bic_margin, not args.two_levels)
    summ = rtn.summarize(px, sc.variance, shape, args.frame_period_s)
    summ.update(z_screen=args.z, bic_margin=args.bic_margin, model="hidden Markov, 1/2/3 levels by BIC"
                if not args.two_levels else "hidden Markov, 1/2 levels by BIC")
    if args.csv:
        _write_csv(Path(args.csv), px, shape, args.frame_period_s)
    if args.hdf5:
        _write_hdf5(Path(args.hdf5), px, sc, summ, shape)
    if args.json:
        out = {"darks": [str(d) for d in args.darks], **jsonable(summ), "pixels_rtn": _pixel_rows(px, shape)}
        print(json.dumps(out, indent=2, allow_nan=False))
        return 0
    _print(summ, px, args.frame_period_s)
    for what, f in (("pixels", args.csv), ("maps", args.hdf5)):
        if f:
            print(f"{what} written to {f}")
    return 0


def _pixel_rows(px, shape) -> list[dict]:
    from ares.analysis.lowlight.rtn import dwell_frames_needed

    rows = []
    need = dwell_frames_needed(px)
    for i in range(px.index.size):
        r, c = divmod(int(px.index[i]), shape[1])
        fin = lambda v: float(v) if math.isfinite(v) else None
        rows.append({"row": r, "col": c, "levels": px.n_levels[i].item(), "amplitude_dn": fin(px.amplitude_dn[i]),
                     "amplitude_se_dn": fin(px.amplitude_se_dn[i]), "sigma_dn": fin(px.sigma_dn[i]),
                     "dwell_low_frames": fin(px.dwell_low_frames[i]), "dwell_low_se": fin(px.dwell_low_se[i]),
                     "dwell_high_frames": fin(px.dwell_high_frames[i]), "dwell_high_se": fin(px.dwell_high_se[i]),
                     "occupancy_high": fin(px.occupancy_high[i]), "delta_bic": fin(px.delta_bic[i]),
                     "dwell_frames_needed": int(need[i])})
    return rows


def _write_csv(path: Path, px, shape, period) -> None:
    from ares.rundir.files import storage, write_atomic

    cols = ["row", "col", "levels", "amplitude_dn", "amplitude_se_dn", "sigma_dn", "dwell_low_frames", "dwell_low_se",
            "dwell_high_frames", "dwell_high_se", "occupancy_high", "delta_bic", "dwell_frames_needed"]
    lines = [",".join(cols + (["dwell_low_s", "dwell_low_se_s", "dwell_high_s", "dwell_high_se_s"] if period else []))]
    secs = _seconds(px, period) if period else None
    for i, r in enumerate(_pixel_rows(px, shape)):
        cells = ["" if r[c] is None else (f"{r[c]:.6g}" if isinstance(r[c], float) else str(r[c])) for c in cols]
        if secs is not None:
            cells += [f"{v[i]:.6g}" if math.isfinite(v[i]) else "" for v in secs]
        lines.append(",".join(cells))
    with storage(path):
        write_atomic(path, ("\n".join(lines) + "\n").encode())


def _write_hdf5(path: Path, px, sc, summ, shape) -> None:
    import h5py
    import numpy as np

    from ares.analysis.lowlight import rtn
    from ares.rundir.files import storage

    def m(values, fill=np.nan):
        a = np.full(shape[0] * shape[1], fill, np.float64)
        a[px.index] = values
        return a.reshape(shape)

    maps = {"amplitude_dn": (m(px.amplitude_dn, 0.0), "DN"), "amplitude_se_dn": (m(px.amplitude_se_dn), "DN"),
            "dwell_low_frames": (m(px.dwell_low_frames), "frames"), "dwell_high_frames": (m(px.dwell_high_frames), "frames"),
            "dwell_low_se": (m(px.dwell_low_se), "frames"), "dwell_high_se": (m(px.dwell_high_se), "frames"),
            "dwell_frames_needed": (m(rtn.dwell_frames_needed(px), -1.0), "frames"),
            "levels": (m(px.n_levels, 1.0), ""), "temporal_noise_dn": (np.sqrt(sc.variance), "DN"),
            "lag1_autocorrelation": (sc.rho1, "")}
    tmp = path.with_name(path.name + ".tmp")
    with storage(path):
        with h5py.File(tmp, "w") as f:
            for k, (v, unit) in maps.items():
                ds = f.create_dataset(k, data=v, compression="gzip")
                ds.attrs["unit"] = unit
            f.attrs["summary_json"] = json.dumps(jsonable(summ), allow_nan=False)
        tmp.replace(path)


def _seconds(px, period):
    """(tau_lo, se, tau_hi, se) in s of the continuous-time telegraph these frame dwells sample."""
    from ares.analysis.lowlight.rtn import continuous_dwell_s

    tl, th, sl, sh = continuous_dwell_s(px.dwell_low_frames, px.dwell_high_frames, period, px.dwell_low_se,
                                        px.dwell_high_se)
    return tl, sl, th, sh


def _print(s: dict, px, period) -> None:
    def sec(dl, dh):
        if not period:
            return ""
        from ares.analysis.lowlight.rtn import continuous_dwell_s

        tl, th, _, _ = continuous_dwell_s(dl, dh, period)
        return f" (continuous time: low {float(tl):.3g} s, high {float(th):.3g} s)"

    print(f"frames             {s['frames']} ({s['pixels']} pixels; {s['candidates']} candidates by lag-1 "
          f"autocorrelation >= {s['z_screen']:g} SE)")
    print(f"model              {s['model']}, margin {s['bic_margin']:g}")
    print(f"RTN pixels         {s['rtn_pixels']} ({s['rtn_fraction'].text()} of the pixels; {s['three_level']} with "
          "3 levels)")
    print(f"temporal noise     {s['temporal_noise_dn'].text()} with them, {s['temporal_noise_without_rtn_dn'].text()} without: "
          f"the RTN pixels raise it by {s['temporal_noise_increase_pct'].text(with_reason=True)}")
    if s["rtn_pixels"]:
        import numpy as np

        print(f"amplitude          median {s['median_amplitude_dn'].text()} (within-level sigma "
              f"{s['within_level_sigma_dn']:.3g} DN)")
        dl, dh = s["frames_needed_dwell_frames"]
        print(f"dwell (median)     low {dl:.3g} frames, high {dh:.3g} frames{sec(dl, dh)}")
        need = s["dwell_frames_needed"]
        print(f"dwell SE           median {s['dwell_se_median_pct']:.3g} % (10-90 %: {s['dwell_se_p10_pct']:.3g}-"
              f"{s['dwell_se_p90_pct']:.3g} %); within 10 % for {s['dwell_resolved']} of {s['rtn_pixels']} pixels"
              + (f"; the median pixel needs >= {need} frames for it" if need > s["frames"] else ""))
        h = s["amplitude_hist"]
        print("amplitude / sigma  " + ", ".join(f"{a}-{b}: {c}" for a, b, c in
                                               zip(h["edges_sigma"][:-1], h["edges_sigma"][1:], h["counts"]) if c))
        order = np.argsort(-px.amplitude_dn)[:10]
        print("largest            row  col  levels  amplitude DN       dwell low (frames)   dwell high (frames)")
        from ares.analysis.stats.estimate import format_value

        for i in order:
            r, c = divmod(int(px.index[i]), s["amplitude_map"].shape[1])
            print(f"                   {r:4d} {c:4d}  {px.n_levels[i]:6d}  "
                  f"{format_value(px.amplitude_dn[i], px.amplitude_se_dn[i]):17s}  "
                  f"{format_value(px.dwell_low_frames[i], px.dwell_low_se[i]):19s}  "
                  f"{format_value(px.dwell_high_frames[i], px.dwell_high_se[i])}")
    dl, dh = s["frames_needed_dwell_frames"]
    print("frames needed      " + ", ".join(f"amplitude {a} sigma: needs >= {n}" for a, n in s["frames_needed"].items())
          + f" (dwell {dl:.3g}/{dh:.3g} frames; amplitude to 5 %, dwell times to 10 %, found at {s['z_screen']:g} SE)")
