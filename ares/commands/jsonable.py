"""A command's result as JSON, one way for every command: an Estimate as its dict (value,
SE, unit, verdict, note), a non-finite float as null (JSON has no NaN), a tuple as a list;
arrays (per-pixel maps go to --hdf5/--csv, not to the terminal) and private keys (``_``,
the analysis's own working objects) are left out."""

from __future__ import annotations

import math


def jsonable(x):
    import numpy as np

    from ares.analysis.stats.estimate import Estimate

    if isinstance(x, Estimate):
        return x.to_dict()
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()
                if not (isinstance(k, str) and k.startswith("_")) and not isinstance(v, np.ndarray)}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x
