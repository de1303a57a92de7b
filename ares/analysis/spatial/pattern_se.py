"""The measurement error of a spatial variance (EMVA 1288 4.0 Linear Section 8, Eqs. 35 - 44):
how far the variances of THIS sensor's pattern, measured from averaged images, are from
the pattern's own, given the temporal noise the stack's temporal variances say is left in
the average. ``nonuniformity`` (Release 4.0, after the high-pass, split into column, row and
pixel parts) and ``emva.release3`` (the unfiltered stack variance) take their SEs here;
``temporal_parts`` splits a measured temporal variance into its white, row and column
parts. Pure numpy; imports nothing of ARES."""

from __future__ import annotations

import math

import numpy as np


def temporal_parts(temporal_var: float, rows: int, cols: int, row_var: float | None = None,
                   col_var: float | None = None) -> tuple[float, float, float]:
    """(white pixel, row, column) temporal variances per image from the pixel temporal
    variance and, when measured, the temporal variances of the row and column means (each
    with the frame-global offset removed). Without them the temporal noise is taken as white
    (the assumption behind Eqs. 39 - 41): row_var = var / N, col_var = var / M."""
    t = float(temporal_var) if math.isfinite(temporal_var) else 0.0
    if row_var is None or col_var is None or not (math.isfinite(row_var) and math.isfinite(col_var)):
        return t, 0.0, 0.0
    w = (t - row_var - col_var) / (1.0 - 1.0 / cols - 1.0 / rows)
    return w, row_var - w / cols, col_var - w / rows


def part_variance(v_meas: float, t: float, n: int, dof: int) -> float:
    """var of a measured variance v_meas = (1/n) sum (p_k + e_k)^2 over n values (``dof`` of
    them free) whose noise e has variance ``t``, the pattern p held fixed: 4 t v_p / n (the
    cross term 2/n sum p e) + 2 t^2 dof / n^2 (the noise's chi-square), v_p = v_meas - t dof
    / n its pattern's share (never below 0)."""
    n = max(n, 1)
    return 4 * t * max(v_meas - t * dof / n, 0.0) / n + 2 * t * t * dof / n**2


def stack_variance_se(s2_spatial: float, s2_temporal: float, L: int, n: int) -> float:
    """SE (DN^2) of an L-image average's spatial variance over n pixels with s2_temporal / L
    removed (no high-pass, no split: Release 3.0): ``part_variance`` of its n pixels and
    the measured t = s2_temporal / L's own error, 2 t^2 / (n (L - 1))."""
    n, L = max(n, 1), max(L, 1)
    t = max(s2_temporal, 0.0) / L
    return math.sqrt(part_variance(max(s2_spatial, 0.0) + t, t, n, n) + 2 * t * t / (n * max(L - 1, 1)))


def measurement_se(A: np.ndarray, wcoef: tuple[float, float, float], w_sub: float, cav: float, rav: float,
                   s2_meas: float, M: int, N: int, w: float, tr: float, tc: float, w_dof: float,
                   gains: tuple[float, float] = (1.0, 1.0)) -> tuple[float, float, float, float]:
    """SEs (total, col, row, pix; DN^2) of the spatial variances of THIS sensor's pattern: the
    error the temporal noise left in the averaged image (and the measured temporal variance
    subtracted for it) makes, the pattern held fixed. Not the spread another sensor of the
    same pattern statistics would show (the population's sampling SE, sqrt(2 / n) times the
    variance: 5 - 20x larger on emva_4, benchmarks/truth_z.md) -- a datasheet figure is a
    measurement of this camera.

    The averaged image y = p + e splits exactly into orthogonal parts -- column means (N - 1
    dof), row means (M - 1) and the residual ((M - 1)(N - 1)): cav, rav and res = s2 - cav -
    rav. With white Gaussian e the three parts of e are independent, and a part's measured
    variance v = (1/n) sum (p_k + e_k)^2 over its n values of noise variance t is t/n times a
    non-central chi-square of dof degrees and non-centrality n v_p / t, whose variance
    2 (dof + 2 lambda) (Johnson, Kotz & Balakrishnan, Continuous Univariate Distributions
    Vol. 2, 2nd ed., Ch. 29) gives ``part_variance``: var(v) = 4 t v_p / n + 2 t^2 dof / n^2.
    (EMVA 1288 4.0 Linear Eq. 19's sqrt(2 / NM) is the central case, lambda = 0 -- for a
    temporal variance; applied to the pattern, it is the population's spread.) t per part:
    the column mean's temporal variance h1 (tc + w / M), the row mean's h1 (tr + w / N), a
    pixel's h2 w (the 4.0 high-pass keeps h of white noise, ``white_gains``); the subtracted
    ``w_sub`` is itself measured, var 2 w_sub^2 / w_dof. These carry through the solve of
    Eq. 42 (``A``; ``wcoef`` = how w_sub enters its right side: the col and row rows' g1/M,
    g1/N and the total's g2) by the Jacobian. Row- or column-correlated temporal noise, when
    measured, is in tr, tc; without them the white assumption of Eqs. 39 - 41 is the SE's too.
    (``nonuniformity._solve`` adds, in quadrature, what that noise biases the text's
    figures by: Eqs. 39 - 41 take row/column temporal noise for a pattern.)
    """
    h1, h2 = gains
    vc, vr, vp = h1 * (tc + w / M), h1 * (tr + w / N), h2 * w
    Vc = part_variance(cav, vc, N, N - 1)
    Vr = part_variance(rav, vr, M, M - 1)
    Vp = part_variance(s2_meas - cav - rav, vp, M * N, (M - 1) * (N - 1))
    Vw = 2 * w_sub * w_sub / max(w_dof, 1.0)
    c1, c2, c3 = wcoef  # b = (cav - c1 w, rav - c2 w, s2 - c3 w) + terms without w
    J = np.array([[1.0, 0.0, 0.0, -c1], [0.0, 1.0, 0.0, -c2], [1.0, 1.0, 1.0, -c3]])  # d b / d(cav, rav, res, w)
    Ai = np.linalg.inv(A)
    G = Ai @ J
    cov = G @ np.diag([Vc, Vr, Vp, Vw]) @ G.T  # (col, row, pix)
    one = np.ones(3)
    tot = float(one @ cov @ one)
    return (math.sqrt(max(tot, 0.0)), math.sqrt(max(cov[0, 0], 0.0)), math.sqrt(max(cov[1, 1], 0.0)),
            math.sqrt(max(cov[2, 2], 0.0)))
