"""Defect classes by behaviour against the simulator's truth (issue 34): the per-class
confusion matrix, recall and precision -- first the shipped main job as a user runs it
(scans/photon_transfer.xml through the Runner at 16 frames a stage, its own defects
analysis: K from its PTC, RTS from the dark series the runner keeps, the classes its 10 ms
exposure cannot test "not available" with what they need), then the classifier alone at
4, 16 and 64 frames.

Hot/warm are rates: a class is available where a pixel at 2x its rate threshold is found
with 99 % probability (``rate_detect_factor``), else "not available: needs an exposure >=
T s" from the averaged dark's noise; a pixel a run cannot class (a hot pixel at 10 ms, an
RTS trap whose levels the frames did not show) is "good", never put into another class.

Two sensors, default thresholds except where named:

* ``shipped``: the shipped simulator (protocols/sim_sensor.xml: VGA, seed 1, defect rates
  of SensorParams: 15 hot, 61 warm, 31 RTS, 6 dead, 2 stuck, 31 noisy) at the main job's
  operating point (10 ms, 25 C) and in a long dark (4 s, 40 C; hot_e_per_s=120,
  warm_e_per_s=15 -- the simulator's warm pixels reach 80 e-/s, from 26.5, its hot ones start at
  177 e-/s at 40 C) where hot pixels have a measurable rate; a flat at ~5000 e- each.
* ``dense``: 200 x 160 with 2000 ppm of every class (1000 stuck), RTS amplitude 40 e- (0.2-0.7 e-/s over 90 s: below warm),
  switching with probability 0.2 per frame, 90 s at 5 C (hot 8.5-25 e-/s, warm 1.3-3.8).

"rts (levels seen)" are the RTS pixels whose trap held each state in >= 2 frames of the
dark stack and whose amplitude is >= the frame count's separation threshold + 2 times the
pixel's temporal noise; the others ("rts (not seen)") showed no levels in these frames --
a classifier may call them good (or noisy, for an unresolved two-level variance), never hot.

Then held-out seeds (not the ones the tests use) at 64 frames, where noisy and RTS are
told apart by the telegraph test (issue 48), and the rate classes below their limit (an
injected set whose hot pixels stand 5-9 sigma above the averaged dark's noise).

    python benchmarks/bench_defect_classes.py            # writes benchmarks/defect_classes.md
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

from ares import sim
from ares.analysis.defects import DefectThresholds, classify_stack
from ares.analysis.defects.result import PIXEL_CLASSES, primary_class
from ares.analysis.defects.rts import rts_threshold
from ares.sim.defect_truth import render_with_rts_states, rts_levels_seen, truth_labels

OUT = Path(__file__).with_name("defect_classes.md")
FRAMES = (4, 16, 64)
ROWS = ("good", "hot", "warm", "rts (levels seen)", "rts (not seen)", "dead", "stuck", "noisy")
COLS = ("good",) + PIXEL_CLASSES


def shipped_params() -> sim.SensorParams:
    return sim.SensorParams(rows=480, cols=640, adc_bits=12, lag_fraction=1e-4, adc_inl_lsb=0.5)


def dense_params() -> sim.SensorParams:
    return sim.SensorParams(rows=160, cols=200, hot_rate_ppm=2000, warm_rate_ppm=2000, rts_rate_ppm=2000,
                            dead_rate_ppm=2000, stuck_rate_ppm=1000, noisy_rate_ppm=2000, rts_amplitude_e=40.0,
                            rts_switch_prob=0.2)


MAIN_JOB = "shipped main job through the Runner (scans/photon_transfer.xml, 10 ms, 25 C, seed 1)"
CASES = {
    "shipped, main job (10 ms, 25 C)": (shipped_params, 1, dict(exposure_s=0.01, temperature_c=25.0), 8.3e5, {}),
    "shipped, long dark (4 s, 40 C)": (shipped_params, 1, dict(exposure_s=4.0, temperature_c=40.0), 2.1e3,
                                       dict(hot_e_per_s=120, warm_e_per_s=15)),
    "dense (90 s, 5 C)": (dense_params, 7, dict(exposure_s=90.0, temperature_c=5.0), 93.0, {}),
}


def score(params_fn, seed: int, op: dict, flux: float, th_kw: dict, frames: int) -> dict:
    """Render, classify, and the confusion matrix {true row: {predicted: count}}."""
    p = params_fn()
    s = sim.SimSensor(p, seed)
    dark, states = render_with_rts_states(s, frames, dark=True, **op)
    flat = s.render(frames, photon_flux=flux, **op)
    truth = s.truth(dark=True, **op)
    th = DefectThresholds(**th_kw)
    t0 = time.perf_counter()
    res = classify_stack(dark, flat, gain_dn_per_e=p.gain_dn_per_e(), exposure_s=op["exposure_s"], thresholds=th)
    secs = time.perf_counter() - t0
    sigma = float(np.sqrt(np.median(dark.var(axis=0, ddof=1))))
    amp = truth["defects"]["properties"]["rts_amplitude_e"] * p.gain_dn_per_e()
    thr = rts_threshold(frames, th.rts_min_separation, th.rts_min_occupancy, th.rts_p_fa)
    seen = rts_levels_seen(states, 2) & (amp >= (thr + 2.0) * sigma)
    prim = primary_class(res.mask)
    pred = np.where(prim >= 0, np.array(PIXEL_CLASSES)[np.maximum(prim, 0)], "good")
    m = _matrix(truth, dark.shape[1:], seen, pred)
    return dict(matrix=m, unavailable=dict(res.unavailable), seconds=secs, rts_threshold=thr)


def score_main_job(frames: int = 16, seed: int = 1) -> dict:
    """The shipped main job (scans/photon_transfer.xml on protocols/sim_sensor.xml) through
    the real Runner at ``frames`` frames a stage (its dark too), classified by its own
    defects analysis (K from its PTC, RTS from the series the runner kept); the RTS trap
    states are recorded by rendering the dark frames one at a time."""
    import json
    import tempfile

    from ares.rig.factory import build_bench
    from ares.protocol import load_scan
    from ares.scan import Runner

    scan = load_scan(Path(__file__).resolve().parents[1] / "scans" / "photon_transfer.xml")
    bench = build_bench(scan.system, seed=seed)
    sensor = bench.info["sensor"]
    render, states, dark_kw = sensor.render, [], {}

    def one_at_a_time(n, **kw):  # the dark frames' trap states, frame by frame
        out = []
        for _ in range(n):
            out.append(render(1, **kw)[0])
            if kw.get("dark") or not np.any(kw.get("photon_flux", 0.0)):
                states.append(sensor.rts_state)
                dark_kw.update(kw)
        return np.stack(out)

    sensor.render = one_at_a_time
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        out = Runner(scan, bench=bench, out_dir=Path(tmp) / "run", seed=seed, frames=frames).run()
        res = json.loads((Path(out.run_dir) / "scan_results.json").read_text())["analyses"]
    secs = time.perf_counter() - t0
    d = res["defects"]
    shape = tuple(d["shape"])
    kw = {k: v for k, v in dark_kw.items() if k in ("exposure_s", "temperature_c", "analog_gain")}
    truth = sensor.truth(dark=True, **kw)
    K = res["ptc"]["gain_dn_per_e"]["value"]
    th = DefectThresholds()
    thr = rts_threshold(frames, th.rts_min_separation, th.rts_min_occupancy, th.rts_p_fa)
    sigma = res["ptc"]["read_noise_dn"]["value"]
    amp = truth["defects"]["properties"]["rts_amplitude_e"] * K
    seen = rts_levels_seen(np.asarray(states[:frames]), 2) & (amp >= (thr + 2.0) * sigma)
    pred = np.full(shape, "good", dtype="U20")
    for cls, pts in d["locations"].items():
        for x, y in pts:
            pred[y, x] = cls
    return dict(matrix=_matrix(truth, shape, seen, pred), unavailable=dict(d["unavailable"]), seconds=secs,
                rts_threshold=thr)


def _matrix(truth: dict, shape, seen: np.ndarray, pred: np.ndarray) -> dict:
    lab = truth_labels(truth, shape).astype("U20")
    rr, rc = truth["defects"]["rts"]
    lab[rr[seen], rc[seen]] = "rts (levels seen)"
    lab[rr[~seen], rc[~seen]] = "rts (not seen)"
    lab[lab == ""] = "good"
    return {r: {c: int(np.count_nonzero((lab == r) & (pred == c))) for c in COLS} for r in ROWS}


def recall_precision(m: dict, cls: str) -> tuple[float | None, float | None]:
    row = "rts (levels seen)" if cls == "rts" else cls
    n_true = sum(m[row].values())
    n_pred = sum(m[r][cls] for r in ROWS)
    tp = m[row][cls]
    true_any = tp + (m["rts (not seen)"][cls] if cls == "rts" else 0)
    return (tp / n_true if n_true else None), (true_any / n_pred if n_pred else None)


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.0f} %"


HELD_OUT_TEXT = """The noisy-vs-RTS test (issue 48): a noisy, hot or warm pixel is RTS when its series is a
telegraph beyond a white Gaussian series at p = 1e-3 by the likelihood ratio of a two-state
hidden Markov model (two levels that persist from frame to frame) against one Gaussian
(ares.analysis.defects.rts.telegraph_lr; its null a table of white series of as many frames,
false-alarm rate measured in benchmarks/defect_hmm_null.md). Before it, Fisher's combination of
the two-level split and the lag-1 autocorrelation (noisy pixels only): 13 of these 16 stacks
>= 95 % in every class, the three below (dense seed 3: noisy 63/67; long dark seeds 4 and 5:
31/33) RTS traps of ~3 sigma_w called noisy. With the ratio: 14 of 16 strict (long dark seed 4
now 31/32); the two below (dense seed 3, long dark seed 5) are traps whose telegraph 64 frames
do not show at p = 1e-3.

"noisy" asserts that a pixel's temporal noise is significantly above the population's (white,
or a telegraph these frames do not resolve; ares.analysis.defects.params): an RTS trap's
telegraph raises its temporal noise as truly, so "as defined" counts an RTS pixel given noisy
as right -- every stack's noisy is then >= 95 %. The strict cell (only the simulator's noisy
pixels) is the one above it. A wider family (frames 4-256, densities, amplitudes, dwell times,
with and without K): benchmarks/defect_family.md.

The strict misses, measured: dense seed 3's four and long dark seed 5's two "noisy" pixels that
the simulator made RTS are traps of 2.3-3.3 sigma_w (4.4-6.6 DN) switching 11-21 times in the
64 frames. Their temporal variance is 3.0-4.3x the population's (the noisy limit at p = 1e-7
is 2.2x), their telegraph ratio 10.9-15.9 against 18.4 at p = 1e-3 (three of the six reach the
p = 1e-2 level, 13.0, where one truly noisy pixel in a hundred would be called RTS): noisy by the
written definition -- temporal noise significantly above the population's, a telegraph these
frames do not resolve -- which the "as defined" cell counts; the definition is unchanged.
The steady-rate check on hot/warm claims (ares.analysis.defects.steady) changed no precision
here and withheld the class of 11 of the 1735 true hot/warm pixels (0.6 %; they stay in the
defect mask, "unclassified")."""
RATE_TEXT = """A rate class whose 99 % limit is between ``rate_detect_factor`` (2x) and ``rate_partial_factor``
(10x) its threshold keeps the pixels it finds, its count a lower bound ("incomplete", `ares
defects` shows ">= N"), with the exposure that would find all; beyond 10x (the main job's 10 ms:
limit 922 e-/s for a 5 e-/s threshold) it stays "not available": what one short exposure finds
there are offsets that are no rate (traps held high: 0 of 9 "hot" were hot at 16 frames). A
hot/warm pixel whose series drops far below its own level in a frame (one-sided Grubbs test at
max_false_alarm, 1e-5) is no steady dark rate and takes neither class. Seed 5's extra pixel is
an RTS trap high in 31 of 32 frames: its one low frame sits at Grubbs 4.10 against the critical
4.13 (p ~ 1.3e-5 for a steady pixel) and the telegraph ratio cannot see one frame either. Two of
the 77 true hot pixels of tests/test_defects_injected.py (100 frames) have a low frame at
p ~ 3e-5 and 1e-4: a threshold that drops the trap and keeps them would be fitted to these
seeds; at rts_p_fa (1e-3) both leave the defect mask. A trap in one state in all but <= 2
frames is "indistinguishable" in benchmarks/defect_family.md, which leaves it out of every
class's precision."""
HELD_OUT = {"dense (90 s, 5 C)": range(1, 11), "shipped, long dark (4 s, 40 C)": range(1, 7)}


def held_out(frames: int = 64) -> list[str]:
    """Per-class precision over held-out seeds: pixels given the class / those truly of it
    (every RTS trap counts as RTS, seen or not)."""
    out = [f"## Held-out seeds, {frames} frames: per-class precision", "",
           "Each row one seed (the tests use dense seed 7 and shipped seed 1); a class below 95 % in bold.", "",
           "| case | seed | " + " | ".join(PIXEL_CLASSES) + " |", "|---|---:|" + "---:|" * len(PIXEL_CLASSES)]
    n_ok = n_all = 0
    for name, seeds in HELD_OUT.items():
        params_fn, _seed, op, flux, th_kw = CASES[name]
        for seed in seeds:
            p = params_fn()
            s = sim.SimSensor(p, seed)
            dark = s.render(frames, dark=True, **op)
            flat = s.render(frames, photon_flux=flux, **op)
            truth = s.truth(dark=True, **op)
            res = classify_stack(dark, flat, gain_dn_per_e=p.gain_dn_per_e(), exposure_s=op["exposure_s"],
                                 thresholds=DefectThresholds(**th_kw))
            lab = truth_labels(truth, dark.shape[1:])
            prim = primary_class(res.mask)
            pred = np.where(prim >= 0, np.array(PIXEL_CLASSES)[np.maximum(prim, 0)], "")
            cells, good = [], True
            for c in PIXEL_CLASSES:
                n = int(np.count_nonzero(pred == c))
                if res.counts.get(c) is None or n == 0:
                    cells.append("n/a" if res.counts.get(c) is None else "-")
                    continue
                tp = int(np.count_nonzero((pred == c) & (lab == c)))
                bad = tp < 0.95 * n
                good &= not bad
                cell = ("**" if bad else "") + f"{tp}/{n}" + ("**" if bad else "")
                if c == "noisy":  # as defined: excess temporal noise, white or an unresolved telegraph
                    cell += f" ({tp + int(np.count_nonzero((pred == c) & (lab == 'rts')))}/{n} as defined)"
                cells.append(cell)
            n_ok += good
            n_all += 1
            out.append(f"| {name} | {seed} | " + " | ".join(cells) + " |")
            print("held out", name, seed, file=sys.stderr)
    out += ["", f"{n_ok} of {n_all} stacks have every reported class >= 95 % precise.", "", HELD_OUT_TEXT, ""]
    return out


def rate_classes_below_limit() -> list[str]:
    """tests/defect_injection.py at 1 s, K 0.5 DN/e-, hot pixels 10-18 e-/s (5-9 sigma of the
    averaged dark's noise), 32 frames: before, hot and warm were "not available" and every
    hot pixel in no class."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from defect_injection import inject

    out = ["## Rate classes below their limit (issue 48)", "",
           "tests/defect_injection.py, 96 x 128, 32 frames at 1 s, K 0.5 DN/e-, hot pixels 10-18 e-/s (5-9 sigma of "
           "the averaged dark's noise; the 99 % limit ~15 e-/s is 3x the 5 e-/s threshold): before, hot and warm "
           "were \"not available\" and every hot pixel in no class. Held: RTS traps in one state in every frame "
           "(a constant offset in these frames, which no classifier can tell from a dark rate); precision without "
           "them.", "",
           "| seed | hot found | given hot | of them held traps | precision | warm |", "|---:|---:|---:|---:|---:|---|"]
    for seed in range(1, 6):
        inj = inject(rows=96, cols=128, frames=32, flat_frames=10, seed=seed, exposure_s=1.0, gain=0.5,
                     hot_e_per_s=(10.0, 18.0))
        res = classify_stack(inj.dark, inj.flat, gain_dn_per_e=inj.gain, exposure_s=inj.exposure_s)
        prim = primary_class(res.mask)
        hot = prim == PIXEL_CLASSES.index("hot")
        lab = inj.truth_map()
        st = inj.params["rts_states"]
        r, c = inj.truth["rts"]
        held = np.zeros(lab.shape, bool)
        held[r, c] = st.all(axis=0) | ~st.any(axis=0)
        tp = int(np.count_nonzero(hot & (lab == "hot")))
        n_held = int(np.count_nonzero(hot & held))
        given = int(hot.sum()) - n_held
        out.append(f"| {seed} | {tp} of {inj.truth['hot'][0].size} | {int(hot.sum())} | {n_held} | "
                   f"{tp}/{given} = {100 * tp / max(given, 1):.0f} % | "
                   + ("not available" if "warm" in res.unavailable else "available") + " |")
    out += ["", RATE_TEXT, "", "hot: " + res.detection.get("hot", res.unavailable.get("hot", "")), ""]
    return out


def main() -> int:
    lines = ["# Defect classes against the simulator's truth", "",
             (__doc__ or "").split("\n\n    python")[0].strip(), "",
             "Rows: the simulator's class; columns: the class ARES gives the pixel (its primary class). "
             "Recall: found in its class / pixels of the class (RTS: of those whose levels were seen); "
             "precision: of the pixels given the class, those truly of it. A class that is not available "
             "at the frame count shows \"n/a\" and the reason.", ""]
    load0 = os.getloadavg()
    runs = [(MAIN_JOB, 16, lambda f: score_main_job(f))]
    runs += [(name, f, lambda f, c=c: score(*c, f)) for name, c in CASES.items() for f in FRAMES]
    verdicts, undefined = [], []
    for name, f, fn in runs:
        r = fn(f)
        m = r["matrix"]
        lines += [f"## {name}, {f} frames", "",
                  f"RTS separation threshold {r['rts_threshold']:.2f} sigma_w; "
                  + ("the whole run (acquisition, analyses, reports)" if name == MAIN_JOB else "classification")
                  + f" {r['seconds']:.2f} s.", "",
                  "| true \\ given | " + " | ".join(COLS) + " |", "|---|" + "---:|" * len(COLS)]
        for row in ROWS:
            lines.append(f"| {row} | " + " | ".join(str(m[row][c]) for c in COLS) + " |")
        lines += ["", "| class | recall | precision | verdict |", "|---|---:|---:|---|"]
        for cls in ("hot", "warm", "rts", "dead", "stuck", "noisy"):
            if cls in r["unavailable"]:
                lines.append(f"| {cls} | n/a | n/a | not available: {r['unavailable'][cls]} |")
                continue
            rec, prec = recall_precision(m, cls)
            note = ""
            if cls == "rts":  # recall is over the traps the frames show; say how many that is
                seen, unseen = m["rts (levels seen)"], m["rts (not seen)"]
                note = (f"{seen['rts'] + unseen['rts']} of {sum(seen.values()) + sum(unseen.values())} traps "
                        f"found; {sum(seen.values())} showed levels >= the threshold + 2 sigma")
            lines.append(f"| {cls} | {_pct(rec)} | {_pct(prec)} | {note} |")
            if f == 16 and any(x is not None and x < 0.95 for x in (rec, prec)):
                verdicts.append(f"{name}, {cls}: recall {_pct(rec)}, precision {_pct(prec)}")
            if f == 16 and rec is None:
                undefined.append(f"{name.split(' (')[0]}, {cls}" + (f" ({note})" if note else ""))
        lines.append("")
        print(name, f, "done", file=sys.stderr)
    lines += held_out() + rate_classes_below_limit()
    load1 = os.getloadavg()
    head = [f"Machine load (1-min load average, 2 cores shared): {load0[0]:.1f} at the start, {load1[0]:.1f} at "
            "the end; the seconds above are indicative only, the matrices do not depend on them.",
            "",
            "At 16 frames every class the frame count can detect has recall and precision >= 95 %"
            + ("; recall is not defined where no pixel of the class showed itself in the frames: "
               + "; ".join(undefined) if undefined else "")
            if not verdicts else "At 16 frames below 95 %: " + "; ".join(verdicts), ""]
    i = lines.index("", 4)
    lines[i + 1:i + 1] = head
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
