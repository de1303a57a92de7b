"""``ares dark-temperature``: dark current against temperature, per pixel and for the frame.

    ares dark-temperature RUN_DIR [--ref-c 0] [--json] [--hdf5 FILE] [--csv FILE]
    ares dark-temperature TABLE   [--ref-c 0] [--json] [--csv FILE]

A run directory (a scan with dark stages at >= 3 temperatures and >= 2 exposures each, e.g.
``scans/dark_temperature.xml`` or ``scans/temperature.xml``): each pixel's rate at each temperature
from the stage mean and variance maps the run keeps, then the Arrhenius law per pixel (E_a and
ln A maps with SEs, local doubling temperature, regimes, hot pixels by E_a, Meyer-Neldel) and for
the frame (rate at ``--ref-c`` and doubling temperature, E_a) -- ``ares.results.lowlight``.
A table of (temperature, rate[, rate_se]) rows gives the frame's figures. ``--hdf5`` writes the
maps, ``--csv`` the per-temperature table.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ares.commands.jsonable import jsonable
from ares.errors import InputError

NAME = "dark-temperature"
HELP = "dark current against temperature: Arrhenius per pixel and for the frame, doubling temperature"
TABLE_ALIASES = {"temperature_c": ("temperature_c", "t_celsius", "t_c", "temperature", "t"),
                 "rate": ("rate", "dark_e_per_pix_per_s", "rate_e_per_s", "dark_current_e_per_s", "dark_e_per_s",
                          "rate_dn_per_s", "dark"),
                 "rate_se": ("rate_se", "se", "rate_e_per_s_se", "rate_dn_per_s_se")}


def add_arguments(p) -> None:
    p.add_argument("source", help="a run directory, or a table of temperature_c,rate[,rate_se] rows")
    p.add_argument("--ref-c", type=float, default=0.0, help="temperature of the quoted rate, C (default 0)")
    p.add_argument("--unit", default=None, help="the table's rate unit (default e-/s, or DN/s when its header says dn)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--hdf5", default=None, metavar="FILE", help="write the per-pixel maps (run directory only)")
    p.add_argument("--csv", default=None, metavar="FILE", help="write the per-temperature rates as CSV")


def _from_table(path: Path, ref_c: float, unit: str | None) -> dict:
    import numpy as np

    from ares.analysis.lowlight.arrhenius import frame_fit
    from ares.hardware.number_table import read_number_table

    cols, lines = read_number_table(path, TABLE_ALIASES, ("temperature_c", "rate"), "dark-current table")
    head = path.read_text(errors="replace").lower()
    unit = unit or ("DN/s" if "dn" in head.split("\n", 1)[0] else "e-/s")
    T, r = cols["temperature_c"], cols["rate"]
    for i, (t, x) in enumerate(zip(T, r)):
        if math.isfinite(t) and not -273.15 < t < 1000:
            raise InputError(f"{path}:{lines[i]}: temperature {t:g} C is not a temperature")
    se = cols.get("rate_se")
    fit = frame_fit(T, r, se, ref_c=ref_c, unit=unit)
    dropped = int(np.sum(~(np.isfinite(T) & np.isfinite(r) & (r > 0))))
    out = {"table": str(path), "temperatures_c": [float(t) for t in T], "unit": unit, "ref_c": ref_c,
           "frame": {"rates": [float(x) for x in r], "rates_se": None if se is None else [float(x) for x in se],
                     **fit},
           "pixels": {"note": "not available: a (T, rate) table holds no pixels; give a run directory"}}
    if dropped:
        out["frame"]["note"] = f"{dropped} row(s) without a positive finite rate left out"
    return out


def run(args) -> int:
    src = Path(args.source)
    maps = {}
    if src.is_dir():
        from ares.results.lowlight import run_dark_temperature
        from ares.rundir.record import load_run

        out, maps = run_dark_temperature(load_run(src), args.ref_c)
        out = {"run": str(src), **out}
        if out.get("status") == "not available":
            raise InputError(f"{src}: {out['note']}")
    elif src.is_file():
        if args.hdf5:
            raise InputError("--hdf5 writes per-pixel maps: give a run directory, a table holds none")
        out = _from_table(src, args.ref_c, args.unit)
    else:
        raise InputError(f"{src}: no such run directory or table")
    if args.hdf5:
        _write_hdf5(Path(args.hdf5), maps, out)
    if args.csv:
        _write_csv(Path(args.csv), out)
    if args.json:
        print(json.dumps(jsonable(out), indent=2, allow_nan=False))
        return 0
    _print(out)
    for what, f in (("maps", args.hdf5), ("table", args.csv)):
        if f:
            print(f"{what} written to {f}")
    return 0


def _write_csv(path: Path, out: dict) -> None:
    from ares.rundir.files import storage, write_atomic

    fr = out["frame"]
    u = out["unit"].replace("-", "").replace("/", "_per_")
    lines = [f"temperature_c,rate_{u},rate_{u}_se"]
    ses = fr.get("rates_se") or [None] * len(fr["rates"])
    for t, r, s in zip(out["temperatures_c"], fr["rates"], ses):
        lines.append(f"{t:g},{r:.6g}," + ("" if s is None or not math.isfinite(s) else f"{s:.3g}"))
    with storage(path):
        write_atomic(path, ("\n".join(lines) + "\n").encode())


def _write_hdf5(path: Path, maps: dict, out: dict) -> None:
    import h5py
    import numpy as np

    from ares.rundir.files import storage

    units = {"activation_ev": "eV", "activation_se_ev": "eV", "ln_prefactor": f"ln({out['unit']})",
             "ln_prefactor_se": f"ln({out['unit']})", "doubling_c": "C", "hot_by_activation": "",
             "rates": out["unit"], "rates_se": out["unit"]}
    tmp = path.with_name(path.name + ".tmp")
    with storage(path):
        with h5py.File(tmp, "w") as f:
            for k, v in maps.items():
                ds = f.create_dataset(k, data=np.asarray(v), compression="gzip")
                ds.attrs["unit"] = units.get(k, "")
            f["temperatures_c"] = np.asarray(out["temperatures_c"], float)
            f["temperatures_c"].attrs["unit"] = "C"
            f.attrs["summary_json"] = json.dumps(jsonable(out), allow_nan=False)
        tmp.replace(path)


def _est(x):
    from ares.analysis.stats.estimate import Estimate

    return Estimate.from_dict(x) if isinstance(x, dict) else x


def _print(out: dict) -> None:
    fr = {k: _est(v) if isinstance(v, dict) and "verdict" in v else v for k, v in out["frame"].items()}
    u = out["unit"]
    print(f"temperatures       {', '.join(f'{t:g}' for t in out['temperatures_c'])} C")
    print(f"frame rates        {', '.join(f'{r:.4g}' for r in fr['rates'])} {u}")
    print(f"{'rate at %g C' % out['ref_c']:<19}{fr['rate_at_ref'].text(with_reason=True)}")
    print(f"doubling temp.     {fr['doubling_c'].text(with_reason=True)}  (log2 I linear in T)")
    print(f"activation energy  {fr['activation_ev'].text(with_reason=True)}  (frame, ln I vs 1/kT)")
    if "note" in fr:
        print(f"note               {fr['note']}")
    px = {k: _est(v) if isinstance(v, dict) and "verdict" in v else v for k, v in out["pixels"].items()}
    if "median_activation_ev" not in px:
        print(f"per pixel          {px.get('note', 'not available')}")
        return
    print(f"pixels fitted      {px['pixels']}" + (f" ({px['pixels_left_out']} left out: a rate not above 0 at some "
                                                 "temperature, too dark to take its logarithm)"
                                                 if px.get("pixels_left_out") else ""))
    print(f"E_a per pixel      median {px['median_activation_ev'].text()}, SD {px['activation_spread_ev'].text()} "
          f"(fit noise rms {px['activation_fit_noise_ev']:.2g} eV)")
    print(f"doubling per pixel median {px['median_doubling_c'].text(with_reason=True)} at {out['ref_c']:g} C")
    rg = px["regimes"]
    print(f"regimes            {rg['depletion']} depletion (0.45-0.85 eV), {rg['diffusion']} diffusion (>= 0.85 eV), "
          f"{rg['field_enhanced']} field-enhanced (< 0.45 eV)")
    print(f"hot by E_a         {px['hot_by_activation']} pixel(s) below the bulk by > 5 robust SDs and 5 SEs")
    print(f"Meyer-Neldel       E_MN {px['meyer_neldel_ev'].text(with_reason=True)}, isokinetic "
          f"{px['isokinetic_k'].text(with_reason=True)} (plain regression {px['naive_ev'].text()}; the fit errors "
          f"alone would give {px['artefact_ev'].text()})")
