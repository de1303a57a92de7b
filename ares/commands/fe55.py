"""``ares fe55``: the absolute gain from the Fe-55 (Mn K-alpha, 5.9 keV) X-ray line.

    ares fe55 FRAMES... --temperature-c T [--threshold 5] [--split 3] [--json] [--csv FILE]
    ares fe55 --events TABLE --temperature-c T [--json] [--csv FILE]

Frames (PNG/TIFF, .npy, .npz, .h5:/dataset) are searched for events
(``ares.analysis.lowlight.fe55.find_events``: threshold and split threshold in units of the
frame's robust noise sigma, both stated in DN in the output); ``--events`` takes a list of event
signals in DN (one per line, or a table with a ``signal_dn`` column and optional ``row``/``col``).
The K-alpha/K-beta fit, the gain in e-/DN from the electron yield at the declared temperature
(with the pair energy's 1.1 % systematic beside the statistical SE), and, with positions, the
charge-transfer trend across rows and columns. ``--csv`` writes the events. Frames without
X-ray events (no candidate above the threshold, or candidates that are noise peaks) say so in one
sentence and exit with 1.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from ares.commands.jsonable import jsonable
from ares.errors import InputError

NAME = "fe55"
HELP = "Fe-55 X-ray gain: events, K-alpha/K-beta fit, gain in e-/DN, charge-transfer trend"
EVENT_ALIASES = {"signal_dn": ("signal_dn", "signal", "dn", "sum_dn", "adu"), "row": ("row", "y"), "col": ("col", "x")}


def add_arguments(p) -> None:
    p.add_argument("frames", nargs="*", help="X-ray frames (PNG/TIFF, .npy, .npz, .h5:/dataset)")
    p.add_argument("--events", default=None, metavar="TABLE",
                   help="a list of event signals in DN instead of frames (one per line, or columns signal_dn,row,col)")
    p.add_argument("--temperature-c", type=float, default=None, metavar="T",
                   help="the sensor's temperature in C (the electron yield depends on it: 1592 e- at -95 C, "
                        "1616 e- at 20 C)")
    p.add_argument("--threshold", type=float, default=5.0, help="event threshold in noise sigmas (default 5)")
    p.add_argument("--split", type=float, default=3.0,
                   help="split threshold in noise sigmas: a neighbour above it makes a split event (default 3)")
    p.add_argument("--line-ev", type=float, default=None, help="K-alpha line energy in eV (default 5889, Mn)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--csv", default=None, metavar="FILE", help="write the events (row, col, signal, grade) as CSV")


def run(args) -> int:
    import numpy as np

    from ares.analysis.lowlight import fe55

    if args.temperature_c is None or not math.isfinite(args.temperature_c) or not -273 < args.temperature_c < 200:
        raise InputError("give --temperature-c, the sensor's temperature in C (-273 to 200): the electron yield "
                         "of the K-alpha line depends on it")
    if bool(args.frames) == bool(args.events):
        raise InputError("give either frames or --events TABLE")
    if not (0 < args.split <= args.threshold):
        raise InputError(f"--split {args.split:g} must be above 0 and at most --threshold {args.threshold:g}")
    line = fe55.KALPHA_EV if args.line_ev is None else args.line_ev
    if not (1000 <= line <= 100000):
        raise InputError(f"--line-ev {line:g}: give the line energy in eV (5889 for Mn K-alpha)")
    if args.events:
        from ares.hardware.number_table import read_number_table

        cols, _lines = read_number_table(args.events, EVENT_ALIASES, ("signal_dn",), "event list")
        sig = cols["signal_dn"]
        ev = None
        if "row" in cols and "col" in cols:
            ok = np.isfinite(cols["row"]) & np.isfinite(cols["col"]) & np.isfinite(sig)
            ev = fe55.Events(cols["row"][ok].astype(np.int64), cols["col"][ok].astype(np.int64), sig[ok], sig[ok],
                             np.ones(int(ok.sum()), np.int64), np.zeros(int(ok.sum()), np.int8), math.nan, math.nan,
                             math.nan, 0)
            sig = sig[ok]
        res = fe55.analyse(sig, args.temperature_c, ev, line)
        if ev is not None:
            for k in ("single", "split", "threshold_dn", "split_dn", "noise_dn", "frames"):
                res.pop(k, None)
        source = {"events": str(args.events)}
    else:
        from ares.hardware.stackfiles import iter_frames

        class Frames:  # read twice, frame by frame: the bias frame, then the events
            def __iter__(self):
                return iter_frames(args.frames)

        ev = fe55.find_events(Frames(), args.threshold, args.split)
        if ev.frames == 0:
            raise InputError("the frames hold no image")
        res = fe55.analyse(ev.signal_dn, args.temperature_c, ev, line, args.threshold)
        res["threshold_sigma"], res["split_sigma"] = args.threshold, args.split
        source = {"frames": [str(f) for f in args.frames]}
    if args.csv:
        _write_csv(Path(args.csv), ev, res)
    out = {**source, **jsonable(res)}
    rc = 0 if res["xray_events"] else 1  # no X-ray events: nothing measured, the exit says so
    if args.json:
        print(json.dumps(out, indent=2, allow_nan=False))
        return rc
    _print(res)
    if args.csv:
        print(f"events written to {args.csv}")
    return rc


def _write_csv(path: Path, ev, res) -> None:
    from ares.rundir.files import storage, write_atomic

    rows = [["row", "col", "signal_dn", "peak_dn", "n_pixels", "grade"]]
    if ev is not None:
        for i in range(ev.signal_dn.size):
            rows.append([int(ev.row[i]), int(ev.col[i]), f"{ev.signal_dn[i]:.3f}", f"{ev.peak_dn[i]:.3f}",
                         int(ev.n_pixels[i]), "single" if ev.grade[i] == 0 else "split"])
    else:
        rows = [["signal_dn"]]
    import io

    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    with storage(path):
        write_atomic(path, buf.getvalue().encode())


def _print(res: dict) -> None:
    if not res["xray_events"]:
        print(res["no_xray"][0].upper() + res["no_xray"][1:] + ".")
        return
    chi2 = f"{res['chi2_dof']:.2f}" if math.isfinite(res["chi2_dof"]) else "n/a"
    print(f"K-alpha peak       {res['kalpha_dn'].text(with_reason=True)}  (width {res['kalpha_sigma_dn'].text()}, "
          f"chi2/dof {chi2}, {res['events_in_fit']} of {res['events_total']} events in the fit window)")
    print(f"K-beta/K-alpha     {res['kbeta_ratio'].text(with_reason=True)}")
    print(f"electron yield     {res['electrons_per_kalpha']:.1f} e- per {res['line_ev']:g} eV photon at "
          f"{res['temperature_c']:g} C (pair energy {res['pair_energy_ev']:.4f} eV, Lowe & Sareen 2007)")
    g = res["gain_e_per_dn"]
    sys_txt = ""
    if g.available:
        sys_txt = (f"; pair-energy systematic ± {g.value * res['gain_systematic_rel']:.2g} e-/DN (1.1 %) not in "
                   "the SE")
    print(f"gain               {g.text(with_reason=True)}{sys_txt}")
    if "single" in res:
        print(f"events             {res['single']} single-pixel, {res['split']} split (threshold "
              f"{res['threshold_dn']:.1f} DN, split {res['split_dn']:.1f} DN; noise {res['noise_dn']:.2f} DN; "
              f"{res['frames']} frames)")
    if "transfer_per_row" in res:
        print(f"transfer per row   {res['transfer_per_row'].text(with_reason=True)}")
        print(f"transfer per col   {res['transfer_per_col'].text(with_reason=True)}")
    else:
        print("transfer trend     not available (the event list holds no positions)")
