"""Fixed patterns: everything drawn once per sensor instance from its seed.

Each component has its own child random stream (``SeedSequence(seed).spawn``), so
switching one component on or off does not change the others' realizations.

Offset terms (ARTEMIS ``d``): column FPN ``Cs`` and row FPN ``Rs`` in DN; pixel FPN
``Ps = Ps1 + Ps2 + Ps3``: Ps1 "minimal" Gaussian offset in e-, Ps2 Gaussian DSNU and Ps3
a zero-centred exponential tail of the dark current in e-/s (at the reference
temperature; the pixel dark rate is clipped at 0). Gain terms: ``Cg``, ``Rg`` and the
per-Bayer-phase ``Pg``, all ``1 + sigma * N(0,1)``, then scaled so that each realized map
has mean exactly 1 (``Cg`` over the columns, ``Rg`` over the rows, ``Pg`` per Bayer phase
on the ``Cg Rg`` it multiplies): the array's mean conversion gain is then the system gain G
itself, not G times this seed's sampling error of the mean (~1e-4 on VGA), and the spreads
stay as drawn.
"""

from __future__ import annotations

import numpy as np

from ares.sim.adc import Adc
from ares.sim.defects import Defects, draw_defects
from ares.sim.lowlight import activation_map, rts_switch_probs
from ares.sim.params import SensorParams

_STREAMS = ("col", "row", "pix_offset", "dark", "col_gain", "row_gain", "pix_gain", "defects", "adc", "lowlight")


class FixedPatterns:
    """The realized fixed patterns of one sensor instance (arrays, float32 maps)."""

    def __init__(self, p: SensorParams, seed: int):
        seq = np.random.SeedSequence(seed)
        rng = dict(zip(_STREAMS, (np.random.Generator(np.random.PCG64(s)) for s in seq.spawn(len(_STREAMS)))))
        R, C = p.rows, p.cols
        f32 = np.float32
        self.col_fpn_dn = (p.col_fpn_dn * rng["col"].standard_normal(C)).astype(f32)
        self.row_fpn_dn = (p.row_fpn_dn * rng["row"].standard_normal(R)).astype(f32)
        self.pixel_offset_e = (p.pixel_fpn_e * rng["pix_offset"].standard_normal((R, C))).astype(f32)
        g = rng["dark"]
        dark = p.dark_current_e_per_s + p.dsnu_e_per_s * g.standard_normal((R, C))
        dark += p.dark_tail_e_per_s * (g.exponential(1.0, (R, C)) - 1.0)
        #: clean pixel dark current at the reference temperature, e-/s (no hot/warm pixels)
        self.dark_ref_e_per_s = np.clip(dark, 0.0, None).astype(f32)
        self.col_gain = (1.0 + p.col_gain_pct / 100 * rng["col_gain"].standard_normal(C)).astype(f32)
        self.row_gain = (1.0 + p.row_gain_pct / 100 * rng["row_gain"].standard_normal(R)).astype(f32)
        self.phase = ((np.arange(R)[:, None] % 2) * 2 + (np.arange(C)[None, :] % 2)).astype(np.uint8)  # 0..3
        prnu = np.asarray(p.prnu_pct) / 100
        pg = 1.0 + prnu[self.phase] * rng["pix_gain"].standard_normal((R, C))
        self.col_gain, self.row_gain, self.pixel_gain = _unit_mean_gains(self.col_gain, self.row_gain, pg)
        self.defects: Defects = draw_defects(p, rng["defects"])
        self.adc = Adc(p, rng["adc"])

        # Defect maps folded into per-pixel arrays the renderer uses.
        d = self.defects
        extra = np.zeros(R * C, f32)
        extra[d.index["hot"]] += d.hot_e_per_s
        extra[d.index["warm"]] += d.warm_e_per_s
        #: total pixel dark current at T_ref including hot and warm pixels, e-/s
        self.dark_all_ref_e_per_s = self.dark_ref_e_per_s + extra.reshape(R, C)
        resp = np.ones(R * C, f32)
        resp[d.index["dead"]] = p.dead_response
        #: photo-response of a pixel beyond PRNU (dead pixels < 1), 0 in OB columns
        self.response = resp.reshape(R, C)
        self.response[:, :p.ob_columns] = 0.0
        rn = np.ones(R * C, f32)
        rn[d.index["noisy"]] = p.noisy_factor
        self.read_noise_factor = rn.reshape(R, C)
        self.bad_column_offset_dn = np.zeros(C, f32)
        self.bad_column_offset_dn[d.bad_columns] = p.bad_column_offset_dn
        #: initial RTS trap state (0/1) per RTS pixel (the sensor evolves its own copy)
        self.rts_state0 = rng["defects"].integers(0, 2, len(d.index["rts"])).astype(np.float32)
        #: per RTS pixel: probability per frame of leaving the low / the high level (ares.sim.lowlight)
        self.rts_p_up, self.rts_p_down = rts_switch_probs(p, len(d.index["rts"]), rng["lowlight"])
        #: per-pixel activation energy of the dark current (eV), None under the doubling law
        self.activation_ev = activation_map(p, d, (R, C), rng["lowlight"])


def _unit_mean_gains(cg: np.ndarray, rg: np.ndarray, pg: np.ndarray):
    """The relative gain maps scaled to realized mean 1: ``Cg`` and ``Rg`` by their means,
    ``Pg`` per Bayer phase (rows and columns of one parity) so that mean(Cg Rg Pg) over the
    phase's pixels is 1 -- the whole array's mean gain factor is then 1 exactly (up to
    float32 rounding) whatever the cross terms of the three draws. ``pg`` (float64) is
    scaled in place, a row parity at a time (no full-size temporary); float32 maps out."""
    cg = cg.astype(np.float64) / float(np.mean(cg, dtype=np.float64))
    rg = rg.astype(np.float64) / float(np.mean(rg, dtype=np.float64))
    odd = np.arange(cg.size) % 2 == 1
    for r0 in (0, 1):
        rows = pg[r0::2]
        if not rows.size:
            continue
        w = (rg[r0::2] @ rows) * cg  # per column: sum over this parity's rows of Cg Rg Pg
        mean = [float(w[odd == c].sum()) / (rows.shape[0] * int(np.count_nonzero(odd == c))) if np.any(odd == c)
                else 1.0 for c in (False, True)]
        rows *= np.where(odd, 1.0 / mean[1], 1.0 / mean[0])[None, :]
    f32 = np.float32
    return cg.astype(f32), rg.astype(f32), pg.astype(f32)
