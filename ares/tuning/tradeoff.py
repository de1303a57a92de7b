"""Per-setting summaries of ``ares bench`` runs, the Pareto front and the recommendation
(pure: no I/O).

Per setting and figure, over the seeds: the bias (mean error) and spread (SD of the error)
against the truth, both relative to it, the RMS error, and the mean reported SE -- so the
table shows whether the SE a user would see matches the error the setting really has. On
a real bench (no truth) only the SEs exist; ``predict_from_pilot`` extends one pilot run to
other frame counts with the 1/sqrt(n - 1) law.
"""

from __future__ import annotations

import math
from statistics import mean, stdev


def summarize(runs: list[dict]) -> dict:
    """``runs``: ``measure.run_once`` results of one setting (several seeds)."""
    out = {"seeds": len(runs), "acquisition_s": mean(r["acquisition_s"] for r in runs),
           "analysis_s": mean(r["analysis_s"] for r in runs), "frames": runs[0]["frames"]}
    out["time_s"] = out["acquisition_s"] + out["analysis_s"]
    figs = {}
    for key in runs[0]["figures"]:
        fs = [r["figures"][key] for r in runs]
        ok = [f for f in fs if f["value"] is not None]
        d = {"available": len(ok), "reason": next((f["reason"] for f in fs if f["value"] is None and f["reason"]), None)}
        ses = [f["se"] / abs(f["value"]) for f in ok if f["se"] is not None and f["value"]]
        d["se_rel"] = mean(ses) if ses else None
        errs = [(f["value"] - f["truth"]) / f["truth"] for f in ok if f["truth"]]
        if errs:
            d["bias_rel"] = mean(errs)
            d["spread_rel"] = stdev(errs) if len(errs) > 1 else None
            d["rms_rel"] = math.sqrt(mean(e * e for e in errs))
        figs[key] = d
    out["figures"] = figs
    return out


def accuracy(summary: dict, key: str) -> float | None:
    """The relative error a setting has for a figure: the larger of the RMS error against
    the truth and the mean reported SE (with a few seeds the RMS is itself noisy; an SE
    above the real error is what a user would see), or the SE alone on a real bench. None
    when the figure was not available in every run."""
    f = summary["figures"][key]
    if f["available"] < summary["seeds"]:
        return None
    vals = [v for v in (f.get("rms_rel"), f.get("se_rel")) if v is not None]
    return max(vals) if vals else None


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points (time, error) no other point beats in both, by time."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def recommend(labels: list[str], summaries: list[dict], targets: dict[str, float]) -> tuple[int | None, str]:
    """The fastest setting whose accuracy meets every target (relative errors), and one
    sentence saying so -- or why none does."""
    ok = [i for i, s in enumerate(summaries)
          if all((a := accuracy(s, k)) is not None and a <= t for k, t in targets.items())]
    want = ", ".join(f"{k} <= {100 * t:g} %" for k, t in targets.items())
    if not ok:
        best = min(range(len(summaries)), key=lambda i: max((accuracy(summaries[i], k) or math.inf) / t
                                                            for k, t in targets.items()))
        worst = {k: accuracy(summaries[best], k) for k in targets}
        got = ", ".join(f"{k} {'n/a' if v is None else f'{100 * v:.3g} %'}" for k, v in worst.items())
        return None, f"no setting reaches {want}; the closest is {labels[best]} ({got})"
    i = min(ok, key=lambda i: summaries[i]["time_s"])
    got = ", ".join(f"{k} {100 * accuracy(summaries[i], k):.3g} %" for k in targets)
    return i, f"{labels[i]}: {summaries[i]['time_s']:.2f} s a run, {got} (target {want})"


def predict_from_pilot(run: dict, pilot_frames: int, frames: list[int], stages: int) -> list[dict]:
    """A real bench: the pilot run's SEs and times carried to other frame counts (SE as
    1/sqrt(n - 1), acquisition time in proportion to the frames, analysis unchanged)."""
    out = []
    for n in frames:
        k = math.sqrt((pilot_frames - 1) / (n - 1))
        figs = {key: {"available": 1 if f["value"] is not None else 0, "reason": f["reason"],
                      "se_rel": (f["se"] / abs(f["value"]) * k) if f["se"] is not None and f["value"] else None}
                for key, f in run["figures"].items()}
        acq = run["acquisition_s"] * n / pilot_frames
        out.append({"seeds": 1, "frames": n * stages, "acquisition_s": acq, "analysis_s": run["analysis_s"],
                    "time_s": acq + run["analysis_s"], "figures": figs, "predicted": n != pilot_frames})
    return out
