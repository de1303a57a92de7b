"""RTN measured (``ares.analysis.lowlight.rtn``) against the simulator's RTS pixels: a 96x96 dark
stack of the default sensor (hot, warm, noisy, dead and stuck pixels on; 2 % of the pixels RTS,
amplitudes uniform in 6-18 e- = 2-6x the read noise, mean dwell times log-uniform in 5-20 frames
in each level, independently), 1000, 4000 and 10000 frames. Recall over the RTS pixels with
amplitude >= 3x the read noise (pixel + chain noise, the line terms being removed), precision over
every RTN call; amplitude and dwell errors over the found >= 3x pixels.

Truth for the dwell times: the simulator's trap is a two-state chain on the frames (it leaves a
level with probability 1/d per frame), so its mean dwell parameter d (frames) is exactly what a
frame series measures (``rtn``'s docstring derives it, and the continuous-time case). What a
series can know of d is limited by the departures m it holds: relative SE ~ sqrt((1 - 1/d)/m),
m ~ frames / (d_lo + d_hi). The table therefore shows, beside "within 10 %", the same for the
known-state estimate (the trap's true states, departures / frames in the level: the best any
estimator can do from these frames), the reported SEs' distribution, and their coverage
(fraction of pixels whose error is within 1, 2, 3 SE; a Gaussian gives 68, 95, 99.7 %).

    PYTHONPATH=. python benchmarks/bench_rtn.py [SEEDS] [FRAMES...]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from topic_table import publish  # noqa: E402

from ares.analysis.lowlight import rtn  # noqa: E402
from ares.sim import SensorParams, SimSensor  # noqa: E402
from ares.sim.defect_truth import render_with_rts_states  # noqa: E402

SIZE = 96
PARAMS = dict(rows=SIZE, cols=SIZE, rts_rate_ppm=20000, rts_amplitude_e=12.0, rts_switch_prob=0.1,
              rts_dwell_spread=2.0)


def known_state_dwell(states: np.ndarray, level: int) -> np.ndarray:
    """The maximum-likelihood mean dwell in ``level`` from the true states (F, n): frames in the level
    (but the last) / departures from it -- the HMM's estimate had it known every state."""
    inl = states[:-1] == level
    dep = (inl & (states[1:] != level)).sum(0)
    with np.errstate(divide="ignore"):
        return np.where(dep > 0, inl.sum(0) / np.maximum(dep, 1), np.inf)


def one(seed: int, frames: int) -> dict:
    s = SimSensor(SensorParams(**PARAMS), seed=seed)
    stack, states = render_with_rts_states(s, frames, exposure_s=0.01, dark=True)
    t0 = time.perf_counter()
    px, summ = rtn.analyse_stack(stack)
    dt = time.perf_counter() - t0
    truth = s.truth(exposure_s=0.01, dark=True)
    ll = truth["lowlight"]
    idx = s.patterns.defects.index["rts"]
    sigma = np.sqrt(truth["read_noise_dn"] ** 2 + s.params.chain_noise_dn**2)
    big = ll["rts_amplitude_dn"] >= 3 * sigma
    found = {int(i): k for k, i in enumerate(px.index)}
    true_set = set(int(i) for i in idx)
    hit = np.array([int(i) in found for i in idx])
    sel = big & hit
    k = np.array([found[int(i)] for i in idx[sel]], int)
    amp = px.amplitude_dn[k] / ll["rts_amplitude_dn"][sel] - 1
    out = {"frames": frames, "seed": seed, "time_s": dt, "true": len(idx), "big": int(big.sum()),
           "recall": hit[big].mean(), "precision": np.mean([i in true_set for i in found]) if found else 1.0,
           "calls": len(found), "candidates": px.candidates, "amp_med": np.median(np.abs(amp)),
           "amp_max": np.max(np.abs(amp)), "amp_5": np.mean(np.abs(amp) < 0.05),
           "rn_inc": summ["temporal_noise_increase_pct"].value, "need3": summ["frames_needed"]["3x"]}
    errs, pulls, rels, known = [], [], [], []
    for est, se, key, lev in ((px.dwell_low_frames, px.dwell_low_se, "rts_dwell_low_frames", 0),
                              (px.dwell_high_frames, px.dwell_high_se, "rts_dwell_high_frames", 1)):
        tr = ll[key][sel]
        errs.append(est[k] / tr - 1)
        pulls.append((est[k] - tr) / se[k])
        rels.append(se[k] / est[k])
        known.append(known_state_dwell(states[:, sel], lev) / tr - 1)
    e, pull, rel, kn = (np.concatenate(v) for v in (errs, pulls, rels, known))
    good = rel <= 0.05  # SE small enough for "within 10 %" to be expected (2 SE)
    need = rtn.dwell_frames_needed(px)[k]
    fin = np.isfinite(kn)
    out.update({"dw_med": np.median(np.abs(e)), "dw_bias": np.mean(e), "dw_10": np.mean(np.abs(e) < 0.10),
                "known_bias": np.mean(kn[fin]),
                "known_10": np.mean(np.abs(kn) < 0.10), "se_q": np.quantile(rel, (0.1, 0.5, 0.9)),
                "good_n": int(good.sum()), "good_10": np.mean(np.abs(e[good]) < 0.10) if good.any() else np.nan,
                "cov": [np.mean(np.abs(pull) < z) for z in (1, 2, 3)], "pull_sd": np.std(pull),
                "need10": int(np.median(need[need > 0]))})
    return out


def main() -> int:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    sizes = [int(a) for a in sys.argv[2:]] or [1000, 4000, 10000]
    rows = [one(seed, f) for f in sizes for seed in range(1, (seeds if f <= 1000 else 1 if f > 4000 else 2) + 1)]
    lines = ["# RTN: levels, amplitudes and dwell times against the simulator's RTS pixels", "",
             f"`benchmarks/bench_rtn.py`: {SIZE}x{SIZE} darks of the default simulated sensor (every defect class on), "
             "2 % of the pixels RTS with amplitudes uniform in 6-18 e- (2-6x the 3.1 e- read noise) and mean dwell "
             "times log-uniform in 5-20 frames per level; `ares.analysis.lowlight.rtn.analyse_stack` (lag-1 "
             "autocorrelation screen at 5 SE, 1/2/3-level HMMs by BIC, margin 10). Recall: RTS pixels with amplitude "
             ">= 3x the read noise found; precision: RTN calls that are RTS pixels. Amplitude and dwell errors over "
             "the found >= 3x pixels (dwell columns: both levels pooled), against the simulator's parameters, which "
             "are exactly what a frame series measures (the trap is a chain on the frames; `rtn`'s docstring). "
             "'Known states': the same estimate from the trap's true states (the best any estimator can do with "
             "these frames). Dwell SE: the reported SE relative to the dwell, 10/50/90 % quantiles. Coverage: "
             "errors within 1/2/3 reported SEs (Gaussian: 68/95/99.7 %). 'SE <= 5 %': within 10 % over the pixels "
             "whose SE says it should be (2 SE). 'Needs >= N frames': the median pixel's frames for dwell SEs of "
             "10 %.", "",
             "| frames | seed | RTS (>= 3x) | calls | recall | precision | amplitude median / max abs err | "
             "amplitude within 5 % | dwell median abs err (mean err; known states' mean err) | dwell within 10 %: HMM / known states | "
             "dwell SE 10/50/90 % | coverage 1/2/3 SE | within 10 % where SE <= 5 % (pixels) | dwell needs >= N "
             "frames | read noise raised | analysis time (s) |", "|" + "---|" * 16]
    for r in rows:
        q = r["se_q"]
        c = r["cov"]
        good = f"{100 * r['good_10']:.0f} % ({r['good_n']})" if r["good_n"] else "none"
        lines.append(
            f"| {r['frames']} | {r['seed']} | {r['true']} ({r['big']}) | {r['calls']} | {100 * r['recall']:.1f} % | "
            f"{100 * r['precision']:.1f} % | {100 * r['amp_med']:.2f} / {100 * r['amp_max']:.2f} % | "
            f"{100 * r['amp_5']:.0f} % | {100 * r['dw_med']:.1f} % ({100 * r['dw_bias']:+.1f} %; "
            f"{100 * r['known_bias']:+.1f} %) | "
            f"{100 * r['dw_10']:.0f} % / {100 * r['known_10']:.0f} % | {100 * q[0]:.1f} / {100 * q[1]:.1f} / "
            f"{100 * q[2]:.1f} % | {100 * c[0]:.0f} / {100 * c[1]:.1f} / {100 * c[2]:.1f} % | {good} | "
            f"{r['need10']} | {r['rn_inc']:.1f} % | {r['time_s']:.0f} |")
    by = {f: [r for r in rows if r["frames"] == f] for f in sizes}
    r1 = by.get(1000) or rows
    rl = by[max(sizes)]
    lines += ["", f"At 1000 frames: recall >= {100 * min(r['recall'] for r in r1):.1f} %, precision >= "
              f"{100 * min(r['precision'] for r in r1):.1f} % (targets 95 %); amplitude within 5 % for >= "
              f"{100 * min(r['amp_5'] for r in r1):.0f} % of the pixels. Dwell times within 10 % of the simulator's "
              f"parameter for {100 * min(r['dw_10'] for r in r1):.0f}-{100 * max(r['dw_10'] for r in r1):.0f} % of "
              f"the pixels -- and the trap's true states do no better ({100 * min(r['known_10'] for r in r1):.0f}-"
              f"{100 * max(r['known_10'] for r in r1):.0f} %): with 5-20-frame dwells 1000 frames hold 25-100 "
              f"departures per level, a dwell SE of {100 * min(r['se_q'][0] for r in r1):.0f}-"
              f"{100 * max(r['se_q'][2] for r in r1):.0f} %, so the 10 % target is not reachable at 1000 frames by any "
              "estimator. The HMM's mean error ("
              f"{100 * min(r['dw_bias'] for r in r1):+.1f}..{100 * max(r['dw_bias'] for r in r1):+.1f} %) is the "
              "departures-per-frame estimate's own small-sample bias ((1 - P)/m, ~1.5 % at 60 departures; the known "
              f"states show it too), a tenth of the SE, and its SEs cover its errors ({100 * min(r['cov'][2] for r in r1):.1f}-{100 * max(r['cov'][2] for r in r1):.1f} % "
              "within 3 SE). Dwell times within 10 % need SEs near 5 %: 'needs >= N frames' (median pixel, SE 10 %: "
              f"~{min(r['need10'] for r in r1)}-{max(r['need10'] for r in r1)}; four times that for SE 5 %). At "
              f"{max(sizes)} frames the dwells are within 10 % for {100 * min(r['dw_10'] for r in rl):.0f} % of the "
              f"pixels (median SE {100 * min(r['se_q'][1] for r in rl):.1f} %), and for "
              f"{100 * np.nanmin([r['good_10'] for r in rl]):.0f} % of those whose SE is <= 5 %.",
              "", "Measured on the shared 2-core machine (analysis times under its load of the day; the Baum-Welch "
              "loops are a numba kernel, `analysis/kernels/hmm.py`)."]
    return publish("rtn", lines)


if __name__ == "__main__":
    raise SystemExit(main())
