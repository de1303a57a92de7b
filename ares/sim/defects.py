"""Defective pixels and columns, drawn once per sensor instance.

Each class gets ``round(rate_ppm * 1e-6 * pixels)`` pixels at distinct random locations
(classes never overlap; optically black columns are excluded). Properties:

* hot / warm: extra dark current (e-/s at the reference temperature), uniform in
  [0.5, 1.5] x the class mean; it follows the same temperature doubling as the dark current.
* rts: a bistable trap adding ``amplitude_e`` (uniform in [0.5, 1.5] x rts_amplitude_e)
  when in its high state; each frame it flips state with probability rts_switch_prob.
* dead: photo-response multiplied by ``dead_response``.
* stuck: output code fixed (``stuck_code_dn`` or a random code per pixel).
* noisy: read noise multiplied by ``noisy_factor``.
* bad columns: ``bad_column_offset_dn`` added to the whole column.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ares.sim.params import SensorParams

CLASSES = ("hot", "warm", "rts", "dead", "stuck", "noisy")


@dataclass
class Defects:
    """Flat pixel indices (row-major) per class, plus their per-pixel properties."""

    index: dict  # class -> int64 array of flat indices
    hot_e_per_s: np.ndarray  # extra dark current at T_ref of the hot pixels
    warm_e_per_s: np.ndarray
    rts_amplitude_e: np.ndarray
    stuck_code: np.ndarray  # uint16
    bad_columns: np.ndarray  # int64 column indices
    cols: int

    def locations(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(row indices, column indices) of one class."""
        idx = self.index[name]
        return idx // self.cols, idx % self.cols

    @property
    def any_pixel(self) -> bool:
        return any(len(v) for v in self.index.values())


def draw_defects(p: SensorParams, rng: np.random.Generator) -> Defects:
    n_pix = p.rows * p.cols
    active = np.arange(n_pix).reshape(p.rows, p.cols)[:, p.ob_columns:].ravel()
    counts = {name: int(round(getattr(p, f"{name}_rate_ppm") * 1e-6 * n_pix)) for name in CLASSES}
    total = sum(counts.values())
    chosen = rng.choice(active, size=min(total, active.size), replace=False) if total else np.empty(0, np.int64)
    index, start = {}, 0
    for name in CLASSES:
        index[name] = np.sort(chosen[start:start + counts[name]]).astype(np.int64)
        start += counts[name]
    n_hot, n_warm, n_rts, n_stuck = (len(index[k]) for k in ("hot", "warm", "rts", "stuck"))
    hot = p.hot_mean_e_per_s * rng.uniform(0.5, 1.5, n_hot)
    warm = p.warm_mean_e_per_s * rng.uniform(0.5, 1.5, n_warm)
    rts = p.rts_amplitude_e * rng.uniform(0.5, 1.5, n_rts)
    if p.stuck_code_dn is None:
        stuck = rng.integers(0, p.max_code + 1, n_stuck).astype(np.uint16)
    else:
        stuck = np.full(n_stuck, p.stuck_code_dn, np.uint16)
    bad = np.sort(rng.choice(np.arange(p.ob_columns, p.cols), size=p.bad_columns, replace=False)).astype(np.int64)
    return Defects(index=index, hot_e_per_s=hot, warm_e_per_s=warm, rts_amplitude_e=rts,
                   stuck_code=stuck, bad_columns=bad, cols=p.cols)
