"""The error-vs-time figure of ``ares bench``: one panel per key figure, every setting a
point, the Pareto front drawn, the recommended setting marked. PNG and a one-page PDF."""

from __future__ import annotations

from pathlib import Path

from ares.tuning.measure import FIGURES
from ares.tuning.tradeoff import accuracy, pareto


def plot(labels, summaries, recommended: int | None, out_png: Path, out_pdf: Path, *, title: str,
         truth: bool = True) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    keys = [k for k in FIGURES if any(accuracy(s, k) is not None for s in summaries)]
    fig, axes = plt.subplots(1, max(1, len(keys)), figsize=(4.2 * max(1, len(keys)), 4.4), squeeze=False)
    for ax, key in zip(axes[0], keys):
        idx = [i for i, s in enumerate(summaries) if accuracy(s, key) is not None]
        pts = [(summaries[i]["time_s"], 100 * accuracy(summaries[i], key)) for i in idx]
        ax.scatter([p[0] for p in pts], [p[1] for p in pts], s=14, color="0.55", label="setting")
        front = [idx[j] for j in pareto(pts)]
        fx = [summaries[i]["time_s"] for i in front]
        fy = [100 * accuracy(summaries[i], key) for i in front]
        ax.plot(fx, fy, "-o", color="tab:blue", ms=4, label="Pareto front")
        for i in front:
            ax.annotate(labels[i], (summaries[i]["time_s"], 100 * accuracy(summaries[i], key)), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
        if recommended is not None and recommended in idx:
            ax.plot([summaries[recommended]["time_s"]], [100 * accuracy(summaries[recommended], key)], "*",
                    color="tab:red", ms=14, label="recommended")
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
            axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("time per run (s)")
        ax.set_ylabel("error: max(RMS vs truth, SE) (%)" if truth else "standard error (%)")
        ax.set_title(FIGURES[key][1], fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)
    fig.savefig(out_pdf)
    plt.close(fig)
