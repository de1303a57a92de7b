"""Dark current against temperature and the Fe-55 gain against public data and the simulator's truth:

* the DESI GFA table (``../shared/data/real/desi-dark-vs-temp``): rate at 0 C and doubling temperature
  against the published 0.0957 e-/px/s and 6.774 C;
* the eotest Fe-55 event list (``../shared/data/real/eotest-fe55``): K-alpha peak against the published
  2300 DN mode and an independent unbinned maximum-likelihood fit; the gain against 0.69 e-/DN;
* ``scans/dark_temperature.xml`` (per-pixel Arrhenius on ``protocols/sim_lowlight.xml``): the E_a map
  against the simulator's (pulls), Meyer-Neldel against its isokinetic temperature, hot pixels by E_a;
* the simulator's X-ray source: the Fe-55 gain over seeds at two temperatures.

    PYTHONPATH=. python benchmarks/bench_lowlight.py
"""

from __future__ import annotations

import dataclasses
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from topic_table import publish  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / ".." / "shared" / "data" / "real"


def desi() -> list[str]:
    from ares.analysis.lowlight.arrhenius import frame_fit
    from ares.hardware.number_table import read_number_table
    from ares.commands.dark_temperature import TABLE_ALIASES

    cols, _ = read_number_table(DATA / "desi-dark-vs-temp" / "desi_dark_vs_temp.csv", TABLE_ALIASES,
                                ("temperature_c", "rate"), "table")
    f = frame_fit(cols["temperature_c"], cols["rate"])
    r, d = f["rate_at_ref"], f["doubling_c"]
    return ["## DESI GFA dark current against temperature (4 points, no uncertainties published)", "",
            "| figure | ARES | published | difference |", "|---|---|---|---|",
            f"| rate at 0 C (e-/px/s) | {r.value:.5f} ± {r.se:.3f} | 0.0957 | {100 * (r.value / 0.0957 - 1):+.2f} % |",
            f"| doubling temperature (C) | {d.value:.4f} ± {d.se:.2f} | 6.774 | {100 * (d.value / 6.774 - 1):+.3f} % |",
            f"| activation energy (eV) | {f['activation_ev'].value:.3f} ± {f['activation_ev'].se:.2f} | (0.71 "
            "recomputed, not published) | |", ""]


def eotest() -> list[str]:
    sys.path.insert(0, str(ROOT / "tests"))
    from test_fe55 import _unbinned_kalpha

    from ares.analysis.lowlight import fe55

    v = np.loadtxt(DATA / "eotest-fe55" / "Fe55_DN_values.txt")
    r = fe55.analyse(v, -95.0)
    k, g = r["kalpha_dn"], r["gain_e_per_dn"]
    ind = _unbinned_kalpha(v)
    return ["## eotest Fe-55 event list (1228 cluster signals, LSST CCD, -95 C)", "",
            "| figure | ARES | reference | difference |", "|---|---|---|---|",
            f"| K-alpha peak (DN) | {k.value:.1f} ± {k.se:.1f} | {ind:.1f} (unbinned ML fit, tests/test_fe55.py) | "
            f"{100 * (k.value / ind - 1):+.3f} % |",
            f"| K-alpha peak (DN) | | 2300 (eotest's mode0) | {100 * (k.value / 2300 - 1):+.3f} % |",
            f"| gain (e-/DN) | {g.value:.4f} ± {g.se:.4f} (+- {g.value * r['gain_systematic_rel']:.4f} pair-energy "
            f"systematic) | 0.69 (eotest's gain0) | {100 * (g.value / 0.69 - 1):+.2f} % |",
            f"| K-beta / K-alpha | {r['kbeta_ratio'].value:.3f} ± {r['kbeta_ratio'].se:.3f} | | |", ""]


def arrhenius_scan() -> list[str]:
    from ares.protocol import load_scan
    from ares.results.lowlight import run_dark_temperature
    from ares.rundir.record import load_run
    from ares.scan import Runner
    from ares.sim import SimSensor
    from ares.sim.from_system import sim_params

    scan = load_scan(ROOT / "scans" / "dark_temperature.xml")
    scan = dataclasses.replace(scan, output=dataclasses.replace(scan.output, pdf=False, csv=False))
    with tempfile.TemporaryDirectory() as d:
        Runner(scan, out_dir=Path(d) / "run").run()
        out, maps = run_dark_temperature(load_run(Path(d) / "run"))
    s = SimSensor(sim_params(scan.system), scan.system.simulator.seed)
    tr = s.truth(temperature_c=60)["lowlight"]["arrhenius"]
    pull = (maps["activation_ev"] - tr["activation_ev"]) / maps["activation_se_ev"]
    rts = np.zeros(pull.shape, bool)
    r, c = s.patterns.defects.locations("rts")
    rts[r, c] = True
    hot = np.zeros(pull.shape, bool)
    for n in ("hot", "warm"):
        r, c = s.patterns.defects.locations(n)
        hot[r, c] = True
    found = maps["hot_by_activation"]
    px = out["pixels"]

    def row(name, m):
        p = pull[m & np.isfinite(pull)]
        return (f"| {name} | {p.size} | {np.mean(p):+.3f} | {np.std(p):.3f} | {100 * np.mean(np.abs(p) < 1):.1f} % | "
                f"{100 * np.mean(np.abs(p) < 2):.1f} % |")

    mn = px["meyer_neldel_ev"]
    return ["## Activation-energy map: `scans/dark_temperature.xml` against the simulator", "",
            "128x128, E_a = 0.65 ± 0.02 eV per pixel, hot and warm pixels at 0.45 eV, 5 temperatures 40-100 C x 6 "
            "exposures x 16 frames. Pull = (E_a measured - E_a true) / its reported SE (a Gaussian gives 68.3 % "
            "within 1, 95.4 % within 2).", "",
            "| pixels | n | mean pull | pull SD | within 1 SE | within 2 SE |", "|---|---|---|---|---|---|",
            row("all", np.ones(pull.shape, bool)), row("without the RTS pixels", ~rts), "",
            f"Median E_a {px['median_activation_ev']['value']:.4f} ± {px['median_activation_ev']['se']:.4f} eV "
            f"(truth 0.65); per-pixel SE median {np.nanmedian(maps['activation_se_ev']):.4f} eV. Hot pixels by E_a: "
            f"{int(found.sum())} flagged, {int((found & hot).sum())} of the {int(hot.sum())} hot/warm pixels among "
            f"them. Meyer-Neldel energy {mn['value']:.5f} ± {mn['se']:.5f} eV (truth k T_ref = "
            f"{tr['meyer_neldel_ev']:.5f} eV; the plain regression {px['naive_ev']['value']:.5f} and the fit errors "
            f"alone {px['artefact_ev']['value']:.5f}).", ""]


def fe55_sim() -> list[str]:
    from ares.analysis.lowlight import fe55
    from ares.sim import SensorParams, SimSensor

    lines = ["## Fe-55 gain on the simulator (96x96, every defect class on, 40 X-rays a frame, 60 frames)", "",
             "| temperature (C) | seed | events | K-alpha (DN) | gain (e-/DN) | truth | error | error / SE |",
             "|---|---|---|---|---|---|---|---|"]
    worst = worst_pull = 0.0
    pulls = []
    for t in (-30.0, 20.0):
        for seed in range(5):
            s = SimSensor(SensorParams(rows=96, cols=96).replace(xray_events_per_frame=40), seed=seed)
            ev = fe55.find_events(s.render(60, exposure_s=0.01, dark=True, temperature_c=t))
            r = fe55.analyse(ev.signal_dn, t, ev)
            g = r["gain_e_per_dn"]
            truth = s.truth(temperature_c=t)["lowlight"]["xray"]["gain_e_per_dn"]
            e = g.value / truth - 1
            worst = max(worst, abs(e))
            worst_pull = max(worst_pull, abs(g.value - truth) / g.se)
            pulls.append((g.value - truth) / g.se)
            lines.append(f"| {t:g} | {seed} | {ev.signal_dn.size} | {r['kalpha_dn'].value:.2f} ± {r['kalpha_dn'].se:.2f} | "
                         f"{g.value:.4f} ± {g.se:.4f} | {truth:.4f} | {100 * e:+.2f} % | {(g.value - truth) / g.se:+.1f} |")
    lines += ["", f"Worst gain error {100 * worst:.2f} % (target 1 %), at most {worst_pull:.1f} of its SE; error/SE "
              f"SD {np.std(pulls):.2f} over the {len(pulls)} runs (the same seed draws the same X-rays at both "
              "temperatures). The bias is a bias frame of the frames themselves (each pixel's mean where neither it "
              "nor a neighbour is lit) and each frame's row and column medians of the unlit pixels: with per-frame "
              "medians alone the events' charge raised them (+0.05..+0.18 %, 2-6 SE) and the row offsets stayed in "
              "the sums (error/SE SD 1.4, and a spurious charge-transfer trend along the rows).", ""]
    return lines


def main() -> int:
    lines = ["# Low light and heat: dark current against temperature, Fe-55 gain", "",
             "`benchmarks/bench_lowlight.py`.", ""]
    lines += desi() + eotest() + arrhenius_scan() + fe55_sim()
    return publish("lowlight", lines)


if __name__ == "__main__":
    raise SystemExit(main())
