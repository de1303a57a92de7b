"""Per-class precision and recall of the defect classifier over a wide injected family
(tests/defect_family.py, issue 48): frames 4, 8, 16, 64, 256; defect densities 0.01-2 %;
RTS amplitude 1-10 sigma, dwell 2-50 frames; hot/warm rates 0.3-60 e-/s (across both
thresholds); stuck at 0, 4095, 65535, the dark level or anywhere; clusters, bad columns;
an RTS trap on a hot pixel, a stuck pixel at 0, a noisy pixel in a bad column; with and
without K and the exposure. Tuning seeds (the ones the classifier was adjusted on) and
held-out seeds apart.

    python benchmarks/bench_defect_family.py [--seeds tune|held|quiet0.3|quiet0.5tune|offgrid]  # rows (JSON)
    python benchmarks/bench_defect_family.py --write BEFORE_TUNE BEFORE_HELD AFTER_TUNE AFTER_HELD \
        [TEMPORAL BEFORE AFTER ...] [--offgrid BEFORE AFTER]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from ares.analysis.defects.result import BITS, PIXEL_CLASSES, primary_class  # noqa: E402
from defect_family import CLASSES, classify, make_case, score  # noqa: E402

OUT = Path(__file__).with_name("defect_family.md")
FRAMES = (4, 8, 16, 64, 256)
DENSITIES = (1e-4, 1e-3, 5e-3, 2e-2)
SEEDS = {"tune": (1, 2, 3, 4, 5), "held": (101, 102, 103, 104, 105), "offgrid": (201, 202, 203, 204, 205)}
QUIET_FRAMES = (64, 256)
# outside the grid the classifier was adjusted on: other frame counts, a 5 % density
OFF_FRAMES = (8, 12, 24, 32, 48, 128)
OFF_DENSITIES = (3e-3, 5e-2)


def run(seeds, frames=FRAMES, temporal: float | None = None, densities=DENSITIES) -> dict:
    agg: dict = {}
    t0 = time.time()
    kw = {} if temporal is None else dict(temporal=temporal)
    for seed in seeds:
        for fr in frames:
            for di, d in enumerate(densities):
                for g in (True, False):
                    case = make_case(seed * 1000 + fr * 10 + di, fr, d, g, **kw)
                    res = classify(case)
                    sc = score(case, res)
                    prim = primary_class(res.mask).ravel()
                    unc = (res.mask.ravel() & BITS["unclassified"]) != 0  # withheld: in the mask, in no class
                    name = lambda i: PIXEL_CLASSES[prim[i]] if prim[i] >= 0 else "unclassified" if unc[i] else "good"  # noqa: E731
                    hard = case.info["hard"]
                    ex = case.excluded.ravel()
                    for key, pix, ok in (("stuck at 0", [hard["stuck0"]], lambda i: name(i) == "stuck"),
                                         ("noisy pixel in a bad column", [hard["noisy_col"]] if hard["noisy_col"]
                                          is not None else [], lambda i: name(i) == "noisy"),
                                         ("RTS trap on a hot pixel", [i for i in hard["rts_hot"] if not ex[i]],
                                          lambda i: name(i) in ("rts", "hot", "warm", "noisy"))):
                        h = agg.setdefault(f"hard|{fr}|{int(g)}|{key}", dict(right=0, n=0, got={}))
                        for i in pix:
                            h["n"] += 1
                            h["right"] += ok(i)
                            h["got"][name(i)] = h["got"].get(name(i), 0) + 1
                    for c, v in sc.items():
                        a = agg.setdefault(f"{fr}|{int(g)}|{c}", dict(given=0, right=0, strict=0, found=0, total=0,
                                                                       na=0, n=0, na_silent=0))
                        for k in ("given", "right", "strict", "found", "total"):
                            a[k] += v[k]
                        a["na"] += not v["available"]
                        a["inc"] = a.get("inc", 0) + (v["available"] and "incomplete" in v["verdict"])
                        a["na_silent"] += (not v["available"]) and not v["verdict"]
                        a["n"] += 1
                    ex = int(case.excluded.sum())
                    agg.setdefault(f"{fr}|{int(g)}|excluded", dict(n=0))["n"] += ex
    agg["seconds"] = time.time() - t0
    return agg


def pct(a, b):
    if not b:
        return "-"
    # a share below 95 % never shows as "95 %" (241/254 = 94.9 %)
    return f"{a}/{b} = {100 * a / b:.{1 if a < 0.95 * b and round(100 * a / b) >= 95 else 0}f} %"


def bold(a, b):
    return f"**{pct(a, b)}**" if b and a < 0.95 * b else pct(a, b)


def table(before: dict, after: dict, title: str, frames=FRAMES) -> list[str]:
    lines = [f"### {title}", "",
             "| frames | K, t | class | precision before | precision after | strict after | recall after | n/a |",
             "|---:|---|---|---:|---:|---:|---:|---:|"]
    for fr in frames:
        for g in (1, 0):
            for c in CLASSES:
                a, b = after.get(f"{fr}|{g}|{c}"), before.get(f"{fr}|{g}|{c}")
                if not a or not (a["given"] or a["total"] or (b and b["given"])):
                    continue
                p_after = bold(a["right"], a["given"])
                na = (f"{a['na']}/{a['n']}" + (f" ({a['na_silent']} silent)" if a["na_silent"] else "")
                      + (f"; incomplete {a['inc']}" if a.get("inc") else ""))
                lines.append(f"| {fr} | {'given' if g else 'no'} | {c} | {bold(b['right'], b['given']) if b else '-'} | "
                             f"{p_after} | {pct(a['strict'], a['given'])} | {pct(a['found'], a['total'])} | {na} |")
    hard = sorted({k.split("|", 3)[3] for k in after if k.startswith("hard|")})
    if hard:
        lines += ["", "The hard pixels (one of each per stack; an RTS trap on a hot pixel is right as rts, hot, "
                  "warm -- by its rate -- or noisy; indistinguishable traps left out; noisy is not available "
                  "below 19 frames, so the noisy pixel in a bad column is in no class there):", "",
                  "| frames | K, t | " + " | ".join(hard) + " |", "|---:|---|" + "---|" * len(hard)]
        for fr in frames:
            for g in (1, 0):
                cells = []
                for key in hard:
                    h = after.get(f"hard|{fr}|{g}|{key}")
                    got = ", ".join(f"{c} {n}" for c, n in sorted(h["got"].items())) if h else ""
                    cells.append(f"{h['right']}/{h['n']} ({got})" if h and h["n"] else "-")
                lines.append(f"| {fr} | {'given' if g else 'no'} | " + " | ".join(cells) + " |")
    ex = sum(after.get(f"{fr}|{g}|excluded", {"n": 0})["n"] for fr in frames for g in (0, 1))
    lines += ["", f"Indistinguishable RTS traps (not in any precision or recall): {ex}; "
              f"classification of these stacks: {after['seconds']:.0f} s (after).", ""]
    return lines


def main() -> None:
    if "--write" in sys.argv:
        args = sys.argv[sys.argv.index("--write") + 1:]
        off = None
        if "--offgrid" in args:
            i = args.index("--offgrid")
            off = [json.loads(Path(p).read_text()) for p in args[i + 1:i + 3]]
            args = args[:i]
        bt, bh, at, ah = (json.loads(Path(p).read_text()) for p in args[:4])
        quiet = [(args[i], json.loads(Path(args[i + 1]).read_text()), json.loads(Path(args[i + 2]).read_text()))
                 for i in range(4, len(args) - 2, 3)]  # TEMPORAL: 0.5 (held-out seeds) or 0.5tune (tuning seeds)
        text = ["# Defect classes over a wide injected family (issue 48)", "", HEAD, ""]
        text += table(bt, at, "Tuning seeds 1-5")
        text += table(bh, ah, "Held-out seeds 101-105")
        for spec, qb, qa in quiet:
            tn, seeds = float(spec.removesuffix("tune")), "tuning seeds" if spec.endswith("tune") else "held-out seeds"
            text += table(qb, qa, f"A quiet sensor: temporal noise {tn:g} DN (FPN {min(1.0, tn):g} DN), {seeds}, "
                                  f"{' and '.join(map(str, QUIET_FRAMES))} frames", QUIET_FRAMES)
        if off:
            text += table(off[0], off[1], f"Off the grid: {', '.join(map(str, OFF_FRAMES))} frames, densities "
                          f"{', '.join(f'{100 * d:g}' for d in OFF_DENSITIES)} %, seeds "
                          f"{SEEDS['offgrid'][0]}-{SEEDS['offgrid'][-1]}", OFF_FRAMES)
        text += [TAIL]
        OUT.write_text("\n".join(text) + "\n")
        return
    which = sys.argv[sys.argv.index("--seeds") + 1] if "--seeds" in sys.argv else "tune"
    if which == "offgrid":
        print(json.dumps(run(SEEDS["offgrid"], OFF_FRAMES, densities=OFF_DENSITIES)))
    elif which.startswith("quiet"):  # a quiet sensor, held-out seeds: --seeds quiet0.3; tuning seeds: quiet0.5tune
        tune = which.endswith("tune")
        print(json.dumps(run(SEEDS["tune" if tune else "held"], QUIET_FRAMES, float(which[5:-4 if tune else None]))))
    else:
        print(json.dumps(run(SEEDS[which])))


HEAD = """tests/defect_family.py, 96 x 128 pixels, K 0.5 DN/e-, temporal noise 2 DN, pixel FPN 1 DN,
exposure 1 or 10 s; per (frames, with/without K and t): 5 seeds x 4 densities (0.01, 0.1,
0.5, 2 %). Measured 2026-12-07 (UTC; two shared cores, the seconds indicative only).
"before": the classifier of main at 930db50 -- issue 48's telegraph ratio (the two-state HMM
likelihood ratio against its measured null on every noisy, hot and warm candidate) and the
steady-rate check on hot/warm claims (ares.analysis.defects.steady: with K a temporal
variance neither above nor below the population's plus the shot noise of its own excess, and
no telegraph at p = 3e-3 -- together 1 % of true hot/warm pixels withheld; without K a z-warm
pixel needs its telegraph ratio computed and cleared; that check's own before/after is this
file at 930db50); "after": with K a noisy claim also needs a variance above what the shot
noise of a dark signal its offset may hide could give (steady.shot_noise_could_explain,
"What stays below 95 %" below), else the pixel is "unclassified". A withheld pixel that
takes no other class stays in the defect mask as "unclassified" and in no class. Where the claimed pixels' own variance shows a K
more than 1.5x (and 3 SE) off the K given, or most of a stack's claims (>= 10) fail the
variance tests, K or the shot-noise model is what the data contradict: the variance is then
not used to withhold, and a note says to check K (never the case in these stacks).

Precision is scored against the truth *set* of each pixel (tests/defect_family.py): its own
class; hot/warm by the true rate, either where the rate is within 3 SE of a threshold;
without K or t hot/warm are dark offsets (any pixel with a dark excess; it may also be
noisy, its dark shot noise raises its temporal noise); **noisy means "temporal noise
significantly above the population, white or a telegraph these frames do not resolve"**
-- a truly noisy pixel or an RTS trap that showed its telegraph; an RTS trap on a hot
pixel may be rts or hot. "strict": only the injected class itself counts (an RTS trap
called noisy is wrong there). RTS traps that did not show their telegraph in the frames
(one state in all but <= 2 frames, or amplitude < 2 sigma) are indistinguishable and in no
count. "n/a": stacks where the class was "not available" (its verdict says why; "silent"
would be one without a reason -- none); "incomplete": stacks where a rate class kept the pixels
it found, its count a lower bound (its verdict says so and names the exposure that finds all).
Bold: below 95 %.

Which false members made warm (with K) imprecise before the steady-rate check, on the tuning seeds: at 4 frames a
noisy pixel (10x the temporal noise) whose 4 frames put its mean 6.8 DN high (z 4.8, rate 1.35
e-/s; its variance 5x the steady-rate expectation); at 16 frames four RTS traps of 2.9-6.8
sigma high in 10-13 of the 16 frames (variance 1.4-3.6x the expectation, telegraph ratio
9.7-19.0 against 19.8 at p = 1e-3); three are withheld now, the fourth (variance 1.4x, ratio
9.7) looks steady in its 16 frames and stays warm (57/58). No hot pixel near the warm/hot boundary (those are in
either truth set), no good pixel in the dark-shot-noise tail, no cluster. On the quiet sensors
(0.3 DN) the false warm members were RTS traps mostly high, of 1-2.5 DN, on two or three codes:
a mean 1.4-3.5 DN high without the shot noise such a dark signal carries (their variance
0.2-1.4 DN^2 against 0.7-1.9 expected) -- with K the lower variance side withholds them,
without K their telegraph ratio cannot be computed (too few codes), which no longer clears them.

Which false members made noisy (with K) imprecise on the quiet 0.5 DN sensor at 256 frames
(held-out seeds 249/266 = 94 %, tuning seeds 241/254 = 94.9 %), on the held-out seeds: 17
pixels with a dark rate of 0.41-2.8 e-/s (0.3-1.4 DN in 1 s, 2.0-2.4 DN in 10 s) whose
negative FPN offset hid part of it -- measured excess -0.4 to +1.6 DN -- so that their own
shot noise stood 1.5-2.2x above the noisy test's expectation (the population's plus K x the
measured excess). 15 of them have a rate within 3 SE of the warm threshold (right as warm,
which a 1 s dark cannot find), 2 a sub-threshold rate (good).
"""

TAIL = """### What stays below 95 %

Every class on the tuning and the held-out seeds, at every frame count, with and without K
and t, off the grid (8-128 frames at 0.3 and 5 % density), and on the quiet sensors (0.3 and
0.5 DN, tuning and held-out seeds): >= 95 % wherever it is reported (the studies
test_family_held_out_seeds_every_reported_class_precise and
test_family_quiet_sensor_every_reported_class_precise hold them to it). Strict noisy without
K at 256 frames (89-92 %): hot/warm pixels below the z-warm limit whose dark shot noise makes
them noisy -- noisy as defined (their temporal noise is raised), not as injected.

Noisy with K on the quiet sensor (0.5 DN, 256 frames) was below: 94 % on the held-out seeds,
94.9 % on the tuning seeds (the false members above). A pixel's measured dark excess is its
dark signal plus its own FPN offset; the noisy test allowed for the shot noise of the measured
excess, too little where the offset is negative. Now (ares.analysis.defects.steady.
shot_noise_could_explain) a noisy claim with K also needs a variance above the shot noise of
the largest dark signal its excess does not rule out: the population's variance plus K x the
excess, plus two margins at P_VARIANCE_SIDE (1/300, the steady-rate check's) added in
quadrature -- the variance's chi-square margin, and K x z x the averaged dark's pixel-to-pixel
noise (how far an offset can hide a signal) -- everything measured from the data, no new
constant. Below it a weak noisy pixel and a dark signal under the averaged dark's noise give
the same mean and variance, which nothing in one dark level tells apart: the pixel is
"unclassified" (in the mask, listed and counted, in the total a limit sees) and the reason is on
noisy's and unclassified's detection sentences (the window's criteria, the report's
detection-limits table, JSON) and in the notes (terminal). It binds only where K x z x that
noise is not small against the population's variance (0.66 DN^2 against 0.33 on the 0.5 DN
sensor; 1.35 against 4 on the 2 DN one, inside the noisy test's own margin): on the 2 DN
family (tuning, held-out, off grid), on the quiet 0.3 DN sensor (noisy not available) and on
the simulator's held-out stacks (benchmarks/defect_classes.md) no count changed. Applied
after the RTS test, so RTS candidates and RTS recall are untouched.

Its cost, on the quiet 0.5 DN sensor only (noisy recall over the injected noisy pixels,
before -> after): held-out 64 frames 214 -> 211 of 223, 256 frames 219 -> 212 of 221; tuning
64 frames 219 -> 216 of 226, 256 frames 213 -> 202 of 216 (1.3-5.1 points) -- noisy pixels of
1.5-2.3x the temporal noise, where the data cannot tell them from a hidden dark signal (of
noisy pixels without a dark signal at 0.5 DN, drawn as in tests/test_defect_steady.py: 1.5x
93 % withheld, 2x 40-45 %, 2.5x 2-7 %, 3x <= 0.4 %, at 64 and 256 frames; one of them the hard
noisy pixel in a bad column, tuning seeds, 64 frames). Precision after: 218/219, 221/221,
219/219, 211/213. Tried first: the union bound (the two margins added, not in quadrature):
also 100 % at 256 frames held-out, recall 219 -> 204; and (an earlier session) an allowance
from the excess's upper bound for every pixel (measured excess + 2.7 x the averaged dark's
pixel-to-pixel noise in the expected variance): 198/198, but noisy recall 219 -> 198 and RTS
recall -4 to -9 % everywhere with K (its candidates are noisy pixels) -- not kept. Not usable
on this family: the pixel's third moment (dark shot noise is Poisson, skewed by K x its
excess variance; read noise is not): tests/defect_family.py draws the dark shot noise
Gaussian, so a third-moment test at the same p would have given back 8 of the 37 withheld
pixels not of the noisy set with 17 of the 66 of it (256 frames, both seed sets) -- untestable
here, left.

What the steady-rate check costs (recall, at 930db50 against before it): with K hot and warm
lose 0-2.2 % of their injected pixels (1 % of the steady ones by design); without K hot-or-warm
0-0.4 %, on the quiet 0.3 DN sensor 4-5 % (z-warm pixels on too few codes for the telegraph
ratio). The hard "RTS trap on a hot pixel" (right as rts, hot, warm or noisy) is in no class
more often with K -- its telegraph raises its variance beyond the shot noise without reaching
rts (p = 1e-3) or noisy (p = 1e-7): tuning seeds 16 frames 3 -> 9 of 18, 64 frames 1 -> 7 of
35; held-out 256 frames 1 -> 6 of 36 (in the defect mask as "unclassified", in no class; the
hard-pixel tables name them so).
A quiet sensor (integer codes, 0.3 and 0.5 DN of temporal noise): the two-
level split's within-level noise is floored at the quantization noise and the telegraph ratio
not run on a series on too few codes (RTS 99-100 % precise); at 0.3 DN (0.42 DN measured) noisy
is "not available" (a pixel's variance depends on where its mean sits between two codes).
"""


if __name__ == "__main__":
    main()
