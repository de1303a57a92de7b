"""Per-pixel defect truth of the simulator for scoring a classification against it.

``SimSensor.truth()['defects']`` lists the pixels of each injected class; this module turns
that into a label map and records, frame by frame, which RTS pixels actually showed two
levels in the frames a classifier saw -- an RTS trap that never switched during a stack is
a constant offset there, and no classifier can call it RTS from those frames.
"""

from __future__ import annotations

import numpy as np

CLASSES = ("hot", "warm", "rts", "dead", "stuck", "noisy")


def truth_labels(truth: dict, shape: tuple[int, int]) -> np.ndarray:
    """(rows, cols) array of class names ("" for a good pixel) from ``truth()``."""
    lab = np.full(shape, "", "U8")
    for c in CLASSES:
        lab[truth["defects"][c]] = c
    return lab


def render_with_rts_states(sensor, n: int, **kw) -> tuple[np.ndarray, np.ndarray]:
    """``n`` frames rendered one at a time, and the RTS trap states in each (n, n_rts)."""
    frames, states = [], []
    for _ in range(n):
        frames.append(sensor.render(1, **kw)[0])
        states.append(sensor.rts_state)
    return np.stack(frames), np.stack(states) if states else np.empty((0, 0), np.int8)


def rts_levels_seen(states: np.ndarray, min_frames: int) -> np.ndarray:
    """Per RTS pixel: both trap states held in at least ``min_frames`` of the frames."""
    high = states.sum(axis=0)
    return np.minimum(high, states.shape[0] - high) >= min_frames
