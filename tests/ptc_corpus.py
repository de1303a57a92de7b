"""A validation corpus of photon-transfer tables with known truth (issue 48), and its judge.

``case(i)`` draws curve ``i`` of a family (deterministic in ``i``): 8-400 levels (log or
linear spacing), per-level noise from exact to 10 % (chi-square-like, relative), 2-256
frames, brighter-fatter a00 from 0 to -3e-6 /e- (the Astier 2019 C00 curve, exact), gain
0.1-10 DN/e-, read noise 2-20 e-, and one of six shapes beyond the turnoff:

- ``clip``: hard clip -- the levels beyond are at the full-well plateau, variance collapsed;
- ``rolloff``: soft roll-off -- the variance falls by 30-100 % of itself per 10 % of signal;
- ``upturn``: drop-then-upturn -- it falls for two levels, then one level rises above the peak;
- ``dip``: a single level well below the turnoff dips 4-10 % (a sensor's local dip), then
  the curve continues to a roll-off;
- ``hump``: after the turnover the variance climbs to a second, higher hump, then falls;
- ``wild``: one row after the turnover with 2-4x the trend's variance.

Some tables repeat rows, shuffle them, or carry NaN rows; some have dark columns (mean
offset, read variance) and some pixel/frame counts -- a few of those counts claim 3x more,
or less, precision than the rows show, so the measured scatter must win.

Truth: ``K`` (DN/e-, the zero-signal slope), ``turnoff_dn`` (the signal of the last level
on the curve, every level at or below the physical turnoff ``S_t`` follows it exactly),
``sat_e`` (= turnoff_dn / K) and, for ``clip``, the plateau full well ``fw_e``.

``judge(result_json, truth)`` says which targets a result meets: gain within max(1 %,
3 SE); turnoff and saturation capacity within 3 % (and the turnoff within max(3 %, 3 SE),
its SE the interval it is located in); and "absurd ok" -- a figure marked "ok" that is
off by more than 50 % or whose SE is larger than its value.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SHAPES = ("clip", "rolloff", "upturn", "dip", "hump", "wild")


@dataclass
class Case:
    i: int
    params: dict
    header: list[str]
    rows: list[list[float]]
    truth: dict = field(default_factory=dict)
    levels: dict = field(default_factory=dict)

    def write(self, path: Path) -> Path:
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(self.header)
            w.writerows([[repr(float(x)) for x in r] for r in self.rows])
        return path

    def stratum(self) -> str:
        p = self.params
        return f"{p['shape']}/{'counts' if p['counts'] else 'nocounts'}/{'dense' if p['levels'] >= 40 else 'sparse'}"


def _curve_e(mu_e, a00):
    """Shot-noise variance (e-^2) of a mean charge, Astier 2019 C00 (g = 1)."""
    mu_e = np.asarray(mu_e, float)
    return mu_e.copy() if a00 == 0 else np.expm1(2 * a00 * mu_e) / (2 * a00)


def _k0(rel: np.ndarray, rate: float) -> int:
    """Where an upturn or a second hump starts among the levels beyond the turnoff: after
    the second level whose variance fell >= 15 % (the drop before it is a real one)."""
    fell = np.flatnonzero(np.maximum(1 - rate * rel, 0.03) <= 0.85)
    return int(fell[1]) + 1 if fell.size >= 2 else rel.size


def shape_draws(rng, shape: str, x: np.ndarray, fw: float) -> dict:
    """The random parameters of the shape beyond the turnoff, drawn from ``rng`` in the
    corpus's order (``x``: each level's charge without saturation, e-; ``fw``: the physical
    turnoff, e-). Which draws are made depends on ``x / fw`` only."""
    beyond = np.flatnonzero(x > fw)
    sp: dict = {}
    if shape == "clip":
        sp["clip_jitter"] = rng.random(beyond.size)
        sp["clip_v"] = rng.uniform(0.001, 0.03, beyond.size)
        return sp
    sp["rate"] = rate = rng.uniform(3, 10)  # relative variance loss per unit of relative signal
    k0 = _k0((x[beyond] - fw) / fw, rate)
    if shape == "upturn" and k0 < beyond.size:
        sp["upturn"] = rng.uniform(1.05, 1.3)
    elif shape == "wild":
        sp["wild"] = rng.uniform(2, 4)
    elif shape == "dip":
        cand = np.flatnonzero((x > 0.3 * fw) & (x < 0.7 * fw))
        if cand.size:
            sp["dip_at"] = int(rng.choice(cand))
            sp["dip"] = rng.uniform(0.04, 0.10)
    return sp


def model_e(x, fw: float, a00: float, shape: str, sp: dict) -> tuple[np.ndarray, np.ndarray]:
    """The noiseless curve: (mean charge, shot-noise variance) in e- and e-^2 of levels that
    would collect ``x`` e- without saturation, for a physical turnoff ``fw`` e-, the
    brighter-fatter ``a00`` and the shape ``shape`` with its draws ``sp`` (``shape_draws``;
    the clip's per-level draws may be scalars). Every level at or below ``fw`` is on the
    curve; ``case`` and the oracle (``benchmarks/bench_ptc_oracle.py``) both call this."""
    x = np.asarray(x, float)
    on = x <= fw
    mu = np.minimum(x, fw)
    v = _curve_e(mu, a00)  # e-^2 on the curve
    last = int(np.flatnonzero(on)[-1])
    v_peak = float(_curve_e(x[last], a00))
    beyond = np.flatnonzero(~on)
    if shape == "clip":
        mu[beyond] = max(fw, 1.005 * x[last]) * (1 + 0.002 * np.asarray(sp["clip_jitter"]))
        v[beyond] = v_peak * np.asarray(sp["clip_v"])
        return mu, v
    rate = sp["rate"]
    rel = (x[beyond] - fw) / fw
    mu[beyond] = fw * (1 + 0.6 * rel)  # the mean still rises, compressed
    v[beyond] = v_peak * np.maximum(1 - rate * rel, 0.03)
    k0 = _k0(rel, rate)  # the drop before an upturn or a second hump is a real one
    if shape == "upturn" and k0 < beyond.size and "upturn" in sp:
        v[beyond[k0]] = v_peak * sp["upturn"]
    elif shape == "hump" and k0 + 2 < beyond.size:  # it falls, climbs a second, higher hump, falls
        k = beyond[k0:]
        v[k] = v_peak * np.linspace(1.05, 1.25, k.size)
        v[k[-1]] = v_peak * 0.3
    elif shape == "wild" and beyond.size:
        k = beyond[min(1, beyond.size - 1)]
        v[k] = _curve_e(x[k], a00) * sp["wild"]
    elif shape == "dip" and "dip_at" in sp:
        v[sp["dip_at"]] *= 1 - sp["dip"]
    return mu, v


TAILS = ("gauss", "t3", "laplace")


def _deviates(rng, n: int, tails: str) -> np.ndarray:
    """``n`` unit-variance deviates: Gaussian, Student's t with 3 dof (an outlier row now
    and then: a cosmic ray in a flat pair, a flicker), or Laplace."""
    if tails == "t3":
        return rng.standard_t(3, n) / math.sqrt(3.0)
    if tails == "laplace":
        return rng.laplace(0.0, 1.0 / math.sqrt(2.0), n)
    return rng.standard_normal(n)


def case(i: int, seed: int = 0, tails: str = "gauss") -> Case:
    """Curve ``i`` of the corpus ``seed`` (0: the corpus the analysis was developed on;
    any other: a held-out corpus of the same family). ``tails``: the per-level noise's
    distribution (``TAILS``; "gauss" is the corpus the rules were developed on, the
    heavy-tailed ones a family they were not: the same curves, other deviates)."""
    rng = np.random.default_rng(1_000_003 * (i + 1) if seed == 0 else [seed, i])
    shape = SHAPES[i % len(SHAPES)]
    n = int(round(math.exp(rng.uniform(math.log(8), math.log(400)))))
    K = math.exp(rng.uniform(math.log(0.1), math.log(10)))
    a00 = -rng.uniform(0, 3e-6) if rng.random() < 0.7 else 0.0
    fw = math.exp(rng.uniform(math.log(5e3), math.log(1.5e5)))
    if a00 and 2 * a00 * fw < -1.0:  # keep the curve rising to the turnoff (dV/dmu = exp(2 a00 mu) > 0.37)
        fw = -1.0 / (2 * a00)
    rn = rng.uniform(2, 20)
    noise = 0.0 if rng.random() < 0.1 else math.exp(rng.uniform(math.log(0.002), math.log(0.10)))
    frames = int(round(math.exp(rng.uniform(math.log(2), math.log(256)))))
    counts = rng.random() < 0.5
    misstate = rng.choice([1.0, 1.0, 1.0, 1.0, 1 / 3, 3.0]) if counts else 1.0
    dark = rng.random() < 0.5
    log_spacing = rng.random() < 0.6
    # the illumination: levels from ~1 % of the turnoff to beyond it (1.15-1.6x)
    top = rng.uniform(1.15, 1.6)
    lo = rng.uniform(0.005, 0.03)
    x = np.geomspace(lo, top, n) if log_spacing else np.linspace(lo, top, n)
    x *= fw  # the charge each level would collect without saturation (e-)
    on = x <= fw
    if on.sum() < 5 or (~on).sum() < 4:  # a curve needs levels on it and beyond its turnoff
        x = np.concatenate([np.linspace(lo * fw, fw, max(int(on.sum()), 5)), fw * np.array([1.05, 1.12, 1.2, 1.3, 1.4])])
        x[:-5] *= 0.98  # (the last level on the curve below the plateau)
        n = x.size
        on = x <= fw
    sp = shape_draws(rng, shape, x, fw)
    mu, v = model_e(x, fw, a00, shape, sp)
    last = int(np.flatnonzero(on)[-1])
    S = K * mu
    V = K * K * v
    rd = K * K * rn * rn
    scatter = noise * _deviates(rng, n, tails)
    Vb = (V + rd) * (1 + scatter)  # the bright level's variance, measured
    Sm = S * (1 + 0.2 * noise * _deviates(rng, n, tails) / math.sqrt(max(frames, 1)))
    offset = rng.uniform(50, 2000) if dark else 0.0
    header = ["mean", "var"]
    cols = [Sm + offset, Vb]
    if dark:
        header += ["dark_mean", "dark_var"]
        cols += [np.full(n, offset), np.full(n, rd)]
    if counts:  # counts whose chi-square precision matches the noise, x misstate
        claimed = max(noise * misstate, 1e-4)
        npix = max(int(round(2.0 / (claimed * claimed * max(frames - 1, 1)))), 1)
        header += ["n_pixels", "n_frames"]
        cols += [np.full(n, npix), np.full(n, frames)]
        if dark:
            header.append("dark_n_frames")
            cols.append(np.full(n, frames))
    rows = [list(r) for r in np.array(cols).T]
    truth = {"K": K, "turnoff_dn": float(S[last]), "sat_e": float(S[last]) / K, "rn_e": rn,
             "fw_e": fw if shape == "clip" else None}
    if rng.random() < 0.15:  # duplicated rows
        for j in rng.choice(len(rows), size=max(1, len(rows) // 10), replace=False):
            rows.append(list(rows[j]))
    if rng.random() < 0.15:  # NaN rows
        for _ in range(int(rng.integers(1, 3))):
            r = list(rows[int(rng.integers(len(rows)))])
            r[1] = math.nan
            rows.append(r)
    if rng.random() < 0.3:
        rows = [rows[j] for j in rng.permutation(len(rows))]
    params = dict(shape=shape, levels=n, K=K, a00=a00, fw_e=fw, rn_e=rn, noise=noise, frames=frames,
                  counts=counts, misstate=float(misstate), dark=dark, log_spacing=log_spacing, seed=seed,
                  tails=tails)
    # the levels in illumination order before rows were repeated, dropped or shuffled (the
    # oracle's input: benchmarks/bench_ptc_oracle.py), and the shape's own draws
    levels = dict(x=x, S=Sm, V=Vb, offset=offset, last=last, shape_draws=sp)
    return Case(i, params, header, rows, truth, levels)


def _val(d):
    return d["value"] if isinstance(d, dict) and d.get("verdict") == "ok" else None


def judge(d: dict, truth: dict) -> dict:
    """Which targets the JSON result ``d`` of ``ares ptc`` meets for ``truth``."""
    k = d["gain_dn_per_e"]
    kv, kse = _val(k), (k.get("se") or 0.0)
    gain_ok = kv is not None and abs(kv - truth["K"]) <= max(0.01 * truth["K"], 3 * kse)
    to = _val(d["turnoff_dn"])
    turnoff_ok = to is not None and abs(to - truth["turnoff_dn"]) <= 0.03 * truth["turnoff_dn"]
    to_se = d["turnoff_dn"].get("se") or 0.0
    turnoff_se_ok = to is not None and abs(to - truth["turnoff_dn"]) <= max(0.03 * truth["turnoff_dn"], 3 * to_se)
    sat = _val(d["saturation_capacity_e"])
    sat_ok = sat is not None and abs(sat - truth["sat_e"]) <= 0.03 * truth["sat_e"]
    absurd = []
    for name, val, ref in (("K", kv, truth["K"]), ("turnoff", to, truth["turnoff_dn"]),
                           ("saturation capacity", sat, truth["sat_e"]),
                           ("read noise", _val(d["read_noise_e"]), truth["rn_e"])):
        if val is not None and not (ref / 1.5 <= val <= ref * 1.5):
            absurd.append(f"{name} {val:.4g} vs truth {ref:.4g}")
    fw = _val(d["full_well_e"])
    if fw is not None and truth.get("fw_e") and not (truth["fw_e"] / 1.5 <= fw <= truth["fw_e"] * 1.5):
        absurd.append(f"full well {fw:.4g} vs truth {truth['fw_e']:.4g}")
    for key in ("gain_dn_per_e", "turnoff_dn", "saturation_capacity_e", "full_well_e", "read_noise_e"):
        e = d[key]
        if e.get("verdict") == "ok" and e.get("se") is not None and e["se"] > abs(e["value"]):
            absurd.append(f"{key}: SE larger than the value, 'ok'")
    return {"gain": gain_ok, "k_off_pct": 100 * (kv / truth["K"] - 1) if kv is not None else None,
            "k_se_pct": 100 * kse / kv if kv else None, "turnoff": turnoff_ok, "turnoff_se": turnoff_se_ok, "sat": sat_ok, "absurd": absurd}


def run_case(c: Case, tmp: Path) -> tuple[dict, dict]:
    """(JSON result of ``ares ptc`` on the case's table, judgement)."""
    from ares.commands.ptc import analyse_table

    path = c.write(tmp / f"corpus_{c.i}.csv")
    _, d, _ = analyse_table(path)
    path.unlink()
    return d, judge(d, c.truth)


def stratified(n_total: int, n_pick: int) -> list[int]:
    """``n_pick`` case numbers spread over every shape and every stratum of the first
    ``n_total`` (deterministic)."""
    by: dict[str, list[int]] = {}
    for i in range(n_total):
        by.setdefault(case(i).stratum(), []).append(i)
    out: list[int] = []
    k = 0
    while len(out) < n_pick:
        for key in sorted(by):
            if k < len(by[key]) and len(out) < n_pick:
                out.append(by[key][k])
        k += 1
    return sorted(out)
