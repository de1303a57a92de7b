"""The result of a defect classification for one region/channel."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ares.analysis.defects.params import DefectThresholds

#: bit of each class in the integer class mask (uint16, one per pixel); "unclassified": a
#: significant dark excess that is no steady dark rate, or (with K) a raised temporal noise the
#: shot noise of a dark signal its offset hides could give (steady.py), and clears no other class's
#: test -- defective (out of the noise statistics: a hot pixel left in would bias DSNU), in no
#: class, but listed, counted as "unclassified" and in "total" (so a limit on the total sees it)
BITS: dict[str, int] = {
    "hot": 1 << 0, "warm": 1 << 1, "dead": 1 << 2, "low_response": 1 << 3,
    "high_response": 1 << 4, "stuck": 1 << 5, "noisy": 1 << 6, "rts": 1 << 7,
    "bad_column": 1 << 8, "bad_row": 1 << 9, "unclassified": 1 << 10,
}
#: pixel classes in order of precedence: a pixel's primary class is the first it has
PIXEL_CLASSES: tuple[str, ...] = ("stuck", "rts", "hot", "warm", "noisy", "dead", "low_response", "high_response")
PIXEL_BITS = sum(BITS[c] for c in PIXEL_CLASSES) | BITS["unclassified"]
LINE_BITS = BITS["bad_column"] | BITS["bad_row"]

DEFECT_DTYPE = np.dtype([("x", np.int32), ("y", np.int32), ("cls", "U13"), ("statistic", np.float64)])


def primary_class(mask: np.ndarray) -> np.ndarray:
    """Index into PIXEL_CLASSES of each pixel's primary class, -1 for a good pixel."""
    out = np.full(mask.shape, -1, dtype=np.int8)
    for i in range(len(PIXEL_CLASSES) - 1, -1, -1):
        out[(mask & BITS[PIXEL_CLASSES[i]]) != 0] = i
    return out


@dataclass(frozen=True)
class DefectResult:
    """Counts, list, mask, lines, clusters and histograms of one region/channel.

    ``counts`` are exclusive (each defective pixel once, under its primary class, see
    PIXEL_CLASSES) plus ``bad_columns``, ``bad_rows``, ``clusters`` and ``total``
    (defective pixels, lines excluded); ``flag_counts`` count every bit (an RTS pixel is
    also noisy). ``defects`` lists x, y (full-frame coordinates), primary class and the
    statistic that flagged it (see ``statistics``). ``mask`` is the uint16 bitmask (BITS).
    """

    shape: tuple[int, int]
    origin: tuple[int, int]
    step: tuple[int, int]
    mask: np.ndarray
    counts: dict[str, int]
    flag_counts: dict[str, int]
    defects: np.ndarray
    statistics: dict[str, str]
    bad_columns: list[dict]
    bad_rows: list[dict]
    clusters: dict
    histograms: dict
    rts_available: bool
    rts_note: str
    rts_candidates: tuple[np.ndarray, np.ndarray]
    limits: list[dict]
    thresholds: DefectThresholds
    notes: tuple[str, ...] = field(default=())
    unavailable: dict = field(default_factory=dict)  # class -> why it is not available
    detection: dict = field(default_factory=dict)  # class -> what it finds (99 %)
    warnings: tuple[str, ...] = field(default=())

    @property
    def passed(self) -> bool:
        return all(lim["passed"] for lim in self.limits)

    def defective(self, include_lines: bool = True) -> np.ndarray:
        """Boolean map of pixels to exclude from noise statistics."""
        bits = PIXEL_BITS | (LINE_BITS if include_lines else 0)
        return (self.mask & bits) != 0

    def class_map(self, name: str) -> np.ndarray:
        return (self.mask & BITS[name]) != 0

    def to_dict(self, histograms: bool = True) -> dict:
        d = {
            "shape": list(self.shape), "origin": list(self.origin), "step": list(self.step),
            "counts": dict(self.counts), "flag_counts": dict(self.flag_counts),
            "defects": [{"x": int(r["x"]), "y": int(r["y"]), "class": str(r["cls"]),
                         "statistic": float(r["statistic"])} for r in self.defects],
            "statistics": dict(self.statistics),
            "bad_columns": self.bad_columns, "bad_rows": self.bad_rows,
            "cluster_size_histogram": {str(k): v for k, v in self.clusters["size_histogram"].items()},
            "clusters": self.clusters["clusters"],
            "rts": {"available": self.rts_available, "note": self.rts_note,
                    "candidates": int(self.rts_candidates[0].size)},
            "limits": self.limits, "passed": self.passed,
            "thresholds": self.thresholds.to_dict(), "notes": list(self.notes),
            "unavailable": dict(self.unavailable), "detection": dict(self.detection),
            "warnings": list(self.warnings),
            "mask_bits": dict(BITS),
        }
        if histograms:
            d["histograms"] = {k: {kk: (vv.tolist() if isinstance(vv, np.ndarray) else vv) for kk, vv in h.items()}
                               for k, h in self.histograms.items()}
        return d
