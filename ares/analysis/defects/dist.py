"""Chi-square and normal quantiles and a trimmed mean from ``scipy.special`` alone.

``scipy.stats`` costs ~0.9 s to import (its whole distribution zoo); the defect
classifier needs three functions of it, which are these closed forms.
"""

from __future__ import annotations

import numpy as np
from scipy import special


def chi2_ppf(p, dof):
    """Lower quantile of the chi-square distribution (= scipy.stats.chi2.ppf)."""
    return 2.0 * special.gammaincinv(np.asarray(dof, float) / 2.0, p)


def chi2_isf(p, dof):
    """Upper quantile of the chi-square distribution (= scipy.stats.chi2.isf)."""
    return 2.0 * special.gammainccinv(np.asarray(dof, float) / 2.0, p)


def norm_cdf(x):
    return special.ndtr(x)


def trim_mean(a, proportion: float, axis: int):
    """Mean after cutting ``int(proportion * n)`` values off each end along ``axis``
    (= scipy.stats.trim_mean)."""
    a = np.asarray(a)
    n = a.shape[axis]
    cut = int(proportion * n)
    if cut == 0:
        return a.mean(axis=axis)
    part = np.partition(a, (cut, n - cut - 1), axis=axis)
    return np.take(part, np.arange(cut, n - cut), axis=axis).mean(axis=axis)
