"""A slanted-edge illumination pattern with a closed-form MTF (for ISO 12233 e-SFR tests).

The scene is a straight edge through the array centre, tilted ``angle_deg`` from the
vertical (bright side on the right), blurred by a Gaussian optical PSF of width ``sigma``
(pixels) and integrated over each square pixel (fill factor 1). Its pixel values are exact:
with ``d`` the signed distance of a point to the edge, the blurred step is ``Phi(d/sigma)``,
and over a pixel ``d`` is the sum of two uniform variables of widths ``cos(theta)`` and
``sin(theta)``, so the pixel mean is a second difference of the twice-integrated normal CDF.

Its true MTF along the edge normal (cycles per pixel) is the product of the optics'
``exp(-2 pi^2 sigma^2 f^2)``, the square aperture's ``sinc(f cos theta) sinc(f sin theta)``
and, when the sensor spreads charge to its 4 neighbours (``crosstalk_pct``), that kernel's
transfer ``1 - k + k/2 (cos(2 pi f cos theta) + cos(2 pi f sin theta))``.
"""

from __future__ import annotations

import math

import numpy as np

_SQ2PI = math.sqrt(2.0 * math.pi)


def _f2(x: np.ndarray) -> np.ndarray:
    """Second antiderivative of the standard normal CDF: ((x^2+1) Phi(x) + x phi(x)) / 2."""
    from scipy.special import ndtr

    return 0.5 * ((x * x + 1.0) * ndtr(x) + x * np.exp(-0.5 * x * x) / _SQ2PI)


def edge_map(rows: int, cols: int, angle_deg: float, sigma: float, low: float = 0.25) -> np.ndarray:
    """Relative illumination (``low`` .. 1) of each pixel, float64 (rows, cols)."""
    from scipy.special import ndtr

    th = math.radians(angle_deg)
    a, b = abs(math.cos(th)), abs(math.sin(th))
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    d0 = (x - (cols - 1) / 2.0) * math.cos(th) - (y - (rows - 1) / 2.0) * math.sin(th)
    e = (d0 > 0).astype(np.float64)
    near = np.abs(d0) < (a + b) / 2 + 10.0 * sigma
    dn = d0[near]
    if b < 1e-9:  # vertical edge: a first difference (the pixel is one uniform variable)
        f1 = lambda t: t * ndtr(t) + np.exp(-0.5 * t * t) / _SQ2PI  # noqa: E731
        e[near] = sigma / a * (f1((dn + a / 2) / sigma) - f1((dn - a / 2) / sigma))
    else:
        s = sigma * sigma / (a * b)
        e[near] = s * (_f2((dn + (a + b) / 2) / sigma) - _f2((dn + (a - b) / 2) / sigma)
                       - _f2((dn - (a - b) / 2) / sigma) + _f2((dn - (a + b) / 2) / sigma))
    return low + (1.0 - low) * np.clip(e, 0.0, 1.0)


def true_mtf(f, angle_deg: float, sigma: float, crosstalk_pct: float = 0.0) -> np.ndarray:
    """The closed-form MTF along the edge normal at ``f`` cycles/pixel."""
    f = np.asarray(f, dtype=np.float64)
    th = math.radians(angle_deg)
    c, s = abs(math.cos(th)), abs(math.sin(th))
    k = crosstalk_pct / 100.0
    h = np.exp(-2.0 * math.pi ** 2 * sigma ** 2 * f ** 2) * np.sinc(f * c) * np.sinc(f * s)
    h = h * (1.0 - k + k / 2.0 * (np.cos(2 * math.pi * f * c) + np.cos(2 * math.pi * f * s)))
    return np.abs(h)


def true_mtf50(angle_deg: float, sigma: float, crosstalk_pct: float = 0.0) -> float:
    """The frequency (cycles/pixel) where the closed-form MTF falls to 0.5."""
    from scipy.optimize import brentq

    return float(brentq(lambda f: true_mtf(f, angle_deg, sigma, crosstalk_pct) - 0.5, 1e-6, 0.9))
