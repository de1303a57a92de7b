"""Real data: the EMVA 1288 reference CCD (Basler, CC BY-SA 3.0, ../shared/data).

The final 50-image bright and dark stacks of EMVA1288_ReferenceSet_001_CCD_12Bit are
decomposed with the three-way ANOVA. Checks: every component is reported with an error;
the dark stack has real row-temporal noise (which the EMVA row/column split would book as
row DSNU), the bright stack a frame-global term; the per-pixel temporal variance equals
Pt + Rt + Ct + frame_global (an algebraic identity of the ANOVA, checked here on the
streamed sums) and the pair-difference temporal variance (EMVA 4.0) equals
Pt + Rt + Ct within its error; the single-level gain and the total PRNU agree with the
published reference results.
"""

from __future__ import annotations

import math
from pathlib import Path, PureWindowsPath

import numpy as np
import pytest

from ares.analysis import StackAccumulator, decompose_dark
from ares.analysis.noise.flat import decompose_flat
from ares.hardware.imagefile import read_image

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit"
PUBLISHED_K = 0.280769  # DN/e-, origin fit up to 70 % of saturation
PUBLISHED_PRNU = 0.4327  # %, EMVA 1288 Release 3 (no high-pass)


def _levels(root: Path):
    levels = []
    for line in (root / "EMVA1288_Data.txt").read_text().splitlines():
        t = line.split()
        if not t or t[0].startswith("#"):
            continue
        if t[0] in ("b", "d"):
            levels.append((t[0], [float(v) for v in t[1:]], []))
        elif t[0] == "i":
            levels[-1][2].append(root / PureWindowsPath(t[1]).as_posix())
    return levels


@pytest.fixture(scope="module")
def stacks():
    if not (DATA / "EMVA1288_Data.txt").is_file():
        pytest.skip(f"EMVA reference data not found at {DATA}")
    big = [lv for lv in _levels(DATA) if len(lv[2]) > 2]
    out = {}
    for kind, meta, files in big[-2:]:
        acc = StackAccumulator((480, 640))
        frames = []
        for f in files:
            a = read_image(f)
            acc.add(a)
            frames.append(a)
        out[kind] = (acc, np.stack(frames))
    assert set(out) == {"b", "d"}
    return out


def _pair_variance(x):
    """EMVA 4.0 temporal variance from consecutive pairs, averaged, with its SE."""
    v = []
    for a, b in zip(x[0::2].astype(float), x[1::2].astype(float)):
        d = a - b
        v.append(np.mean(d * d) / 2 - (d.mean()) ** 2 / 2)
    v = np.array(v)
    return v.mean(), v.std(ddof=1) / math.sqrt(len(v))


@pytest.mark.parametrize("kind", ["d", "b"])
def test_components_and_consistency(stacks, kind, report):
    acc, x = stacks[kind]
    d = decompose_dark(acc)
    name = {"d": "dark", "b": "bright"}[kind]
    report.append(f"\n[EMVA reference CCD, {name} stack, {acc.n_frames} frames of 480x640] (data: Basler AG, CC BY-SA 3.0)")
    for k, e in d.items():
        report.append(f"  {k:13s} {e.value:12.6g} ± {e.se:.3g} {e.unit}")
        assert e.available and e.se > 0
    tvar = acc.temporal_var_map().mean()
    temporal = ("Pt", "Rt", "Ct", "frame_global")
    s = sum(d[k].value for k in temporal)
    se = math.sqrt(sum(d[k].se ** 2 for k in temporal))
    report.append(f"  mean per-pixel temporal variance {tvar:.6g} = Pt+Rt+Ct+frame_global {s:.6g} ± {se:.2g}")
    assert abs(tvar - s) < max(se, 1e-9 * tvar)
    pv, pse = _pair_variance(x)
    s3 = d["Pt"].value + d["Rt"].value + d["Ct"].value
    se3 = math.sqrt(pse**2 + sum(d[k].se ** 2 for k in ("Pt", "Rt", "Ct")))
    report.append(f"  pair-difference variance (EMVA 4.0) {pv:.6g} ± {pse:.2g} vs Pt+Rt+Ct {s3:.6g}")
    assert abs(pv - s3) < 3 * se3
    # naive: EMVA-style row variance of the mean image minus white temporal/F
    mean_img = x.astype(float).mean(0)
    naive_rows = mean_img.mean(1).var(ddof=1) - tvar / (acc.n_frames * 640)
    report.append(f"  EMVA-style row DSNU {naive_rows:.4g} DN^2 vs ANOVA Rs {d['Rs'].value:.4g} "
                  f"(row-temporal leak Rt/F = {d['Rt'].value / acc.n_frames:.3g})")
    # real row-temporal noise, well above its error
    assert d["Rt"].value > 10 * d["Rt"].se
    if kind == "d":
        assert naive_rows > 5 * max(d["Rs"].value, d["Rs"].se)  # the EMVA split leaks Rt into Rs
    else:
        assert d["frame_global"].value > 3 * d["frame_global"].se


def test_gain_and_prnu_against_published(stacks, report):
    (fa, _), (da, _) = stacks["b"], stacks["d"]
    res = decompose_flat(fa, da, illumination="none")
    g = res["G"]
    prnu = 100 * math.sqrt(res["Pg"].value + res["Cg"].value + res["Rg"].value)
    hp = decompose_flat(fa, da, illumination="highpass")
    prnu_hp = 100 * math.sqrt(hp["Pg"].value + max(hp["Cg"].value, 0) + max(hp["Rg"].value, 0))
    report.append(f"\n[EMVA reference CCD, gain part] G = {g} DN/e- (published K {PUBLISHED_K}, PTC origin fit); "
                  f"q = {res['q']} e-")
    report.append(f"  total PRNU sqrt(Pg+Cg+Rg) = {prnu:.4f} % without high-pass (published PRNU1288 {PUBLISHED_PRNU} %), "
                  f"{prnu_hp:.4f} % after the EMVA 4.0 high-pass; Pg alone {100 * math.sqrt(hp['Pg'].value):.4f} %")
    assert abs(g.value / PUBLISHED_K - 1) < 0.03
    assert abs(prnu / PUBLISHED_PRNU - 1) < 0.05
    assert prnu_hp < prnu
