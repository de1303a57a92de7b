"""``SimSensor``: the ARTEMIS Monte Carlo sensor (seed 001).

Per pixel (column c, row r, frame f), before the ADC::

    v = o + Cs[c] + Ct[c,f] + Rs[r] + Rt[r,f] + Ps[c,r] + Pt[c,r,f] + g[f]
        + G * Cg[c] * Rg[r] * Pg[c,r] * (q[c,r] + delta[c,r,f])

``o`` holds the black level, the ADC channel offsets' mean and the mean dark charge;
``Ps`` the pixel offset FPN and dark-current non-uniformity; ``Pt`` read noise, chain
noise and dark shot noise; ``g`` a frame-global offset. The pixel charge (photo
``Pg*(q+delta)`` plus dark) clips at the full well; the ADC adds its channel
offsets/gains, quantizes (with INL/DNL if set) and clips to ``[0, 2**bits-1]``.
Defects, lag and crosstalk are described in ``defects.py`` and ``scene.py``.

Two paths, chosen per call: when no pixel needs exact Poisson, there is no lag and no
pixel can reach the full well, all per-pixel temporal terms are combined into one
Gaussian draw of per-pixel sigma (fast path); otherwise photo and dark charge are drawn
separately (exact Poisson where needed), lag and full-well clipping are applied.
"""

from __future__ import annotations

import numpy as np

from ares.errors import InputError
from ares.sim import cost, fused, lowlight, noise
from ares.sim.params import SensorParams
from ares.sim.patterns import FixedPatterns
from ares.sim.scene import Scene, resolve_scene

_F32 = np.float32


def _check_n(n) -> None:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise InputError(f"simulator: the number of frames must be a non-negative integer, not {n!r}")


class SimSensor:
    """A simulated sensor; fixed patterns drawn once from ``seed``."""

    def __init__(self, params: SensorParams | None = None, seed: int = 0):
        if params is None:
            params = SensorParams()
        if not isinstance(params, SensorParams):
            raise InputError("simulator: params must be a SensorParams (use SensorParams.from_dict for a dict)")
        self.params = params
        self.seed = int(seed)
        self._patterns: FixedPatterns | None = FixedPatterns(params, self.seed)
        self.frame_index = 0  # index of the next frame
        self._lag_e: np.ndarray | None = None  # photo-charge (e-) left behind by the last frame
        self._rts_state = self.patterns.rts_state0.copy()  # RTS trap states, carried frame to frame
        self._cache_key = None
        self._cache = None

    @property
    def shape(self) -> tuple[int, int]:
        return (self.params.rows, self.params.cols)

    @property
    def rts_state(self) -> np.ndarray:
        """The RTS pixels' trap states (0 low, 1 high; order of ``truth()['defects']['rts']``)
        in the last frame rendered: the per-frame truth of which RTS pixels switched."""
        return self._rts_state.astype(np.int8)

    @property
    def patterns(self) -> FixedPatterns:
        """The fixed patterns (drawn from ``seed``: after ``drop_patterns`` the same ones
        are drawn again when next needed)."""
        if self._patterns is None:
            self._patterns = FixedPatterns(self.params, self.seed)
        return self._patterns

    def drop_patterns(self) -> None:
        """Forget the fixed patterns, the operating point and the lag state (a closed
        grabber: ~8 float32 frames); ``truth()`` or a later render draws the same
        patterns again from the seed."""
        self.drop_plan()
        self._patterns = None
        self._lag_e = None

    def drop_plan(self) -> None:
        """Forget the cached operating point (its per-pixel maps: ~10 float32 frames); the
        next render builds it again. Called by the frame source's ``release()`` (the runner,
        between large stages) and by ``drop_patterns`` (its ``close()``)."""
        self._cache_key = self._cache = None

    def reset_state(self) -> None:
        """Forget image lag (as after a long dark pause); RTS states stay."""
        self._lag_e = None

    # ------------------------------------------------------------------------------
    def scene(self, *, exposure_s=0.01, photon_flux=0.0, temperature_c=25.0, analog_gain=1.0,
              black_level_dn=64, dark=False, shot_noise="auto", read_noise_scale=1.0,
              dark_current_scale=1.0, lag_scale=1.0) -> Scene:
        return resolve_scene(self.params, self.patterns, exposure_s=exposure_s, photon_flux=photon_flux,
                             temperature_c=temperature_c, analog_gain=analog_gain,
                             black_level_dn=black_level_dn, dark=dark, shot_noise=shot_noise,
                             read_noise_scale=read_noise_scale, dark_current_scale=dark_current_scale,
                             lag_scale=lag_scale)

    def render(self, n: int, *, exposure_s=0.01, photon_flux=0.0, temperature_c=25.0, analog_gain=1.0,
               black_level_dn=64, dark=False, shot_noise="auto", start_frame=None, read_noise_scale=1.0,
               dark_current_scale=1.0, lag_scale=1.0, offset_dn=0.0) -> np.ndarray:
        """``n`` frames (uint16, shape (n, rows, cols)).

        exposure_s: integration time; photon_flux: photons/pixel/s at the sensor, a number
        or a (rows, cols) map; temperature_c: die temperature (dark current); analog_gain:
        gain after the pixel; black_level_dn: digital pedestal; dark: no photons at all;
        shot_noise: "auto" (exact Poisson only where it is distinguishable), "exact",
        "gaussian"; start_frame: frame index of the first frame (default: continue);
        read_noise_scale / dark_current_scale / lag_scale: bias-dependent factors (the
        register bench derives them from sf_bias and tx_low); offset_dn: a whole-frame offset (DN at
        the ADC input) on these frames -- the black level's drift at their readout (``ares.sim.drift``,
        the bench gives it by its clock).
        """
        _check_n(n)
        kw = dict(exposure_s=exposure_s, temperature_c=temperature_c, analog_gain=analog_gain,
                  black_level_dn=black_level_dn, dark=dark, shot_noise=shot_noise,
                  read_noise_scale=read_noise_scale, dark_current_scale=dark_current_scale, lag_scale=lag_scale)
        try:  # a scalar operating point is cached; maps are resolved on every call
            key = None if np.ndim(photon_flux) else (float(photon_flux), tuple(sorted(kw.items())))
        except (TypeError, ValueError):
            key = None  # resolve_scene reports the bad value
        if key is not None and key == self._cache_key:
            sc, plan = self._cache
        else:
            self._cache_key = self._cache = None  # the previous point's maps go before this one's are made
            sc = self.scene(photon_flux=photon_flux, **kw)
            plan = self._plan(sc)
            self._cache_key, self._cache = key, (sc, plan)
        self._seek(start_frame)
        if sc.lag == 0:
            self._lag_e = None
        out = np.empty((n, *self.shape), np.uint16)
        for i in range(n):
            rng = noise.frame_rng(self.seed, self.frame_index)
            self._frame(sc, plan, rng, out[i], float(offset_dn))
            self.frame_index += 1
        return out

    def render_ramp(self, n: int, *, start_frame=None) -> np.ndarray:
        """ADC test frames (test_mode 2): a linear ramp over the ADC range, see ``Adc.ramp``."""
        _check_n(n)
        self._seek(start_frame)
        out = np.empty((n, *self.shape), np.uint16)
        for i in range(n):
            out[i] = self.patterns.adc.ramp(1, self.shape, noise.frame_rng(self.seed, self.frame_index))[0]
            self.frame_index += 1
        return out

    def _seek(self, start_frame) -> None:
        if start_frame is None:
            return
        if isinstance(start_frame, bool) or not isinstance(start_frame, (int, np.integer)) or start_frame < 0:
            raise InputError(f"simulator: start_frame must be a non-negative integer, not {start_frame!r}")
        self.frame_index = int(start_frame)

    def offset_drift_dn(self, t_s: float) -> float:
        """The black level's drift (DN at the ADC input) at bench time ``t_s`` (``ares.sim.drift``): a
        frame read out then carries it on top of ``truth()['o']``."""
        from ares.sim.drift import offset_dn

        return offset_dn(self.params, t_s)

    def truth(self, **kw) -> dict:
        """Ground truth at an operating point (same keywords as ``render``); see ``ares.sim.truth``."""
        from ares.sim.truth import build_truth

        kw.pop("start_frame", None)
        return build_truth(self, self.scene(**kw))

    def frame_cost(self, **kw) -> float:
        """Relative cost of computing a frame at an operating point (``render``'s
        keywords), by the path ``render`` takes for it (``ares.sim.cost``); draws nothing."""
        fast, modes, numpy_path, exact = self.frame_path(**kw)
        return cost.frame_cost(fast, modes, self.patterns.adc.thresholds is not None, numpy_path, exact)

    def frame_path(self, **kw) -> tuple[bool, tuple, bool, float]:
        """The path ``render`` takes at an operating point: (the fast path, the photo and dark
        charges' ``fused`` modes, the fused kernel does not apply, the fraction of pixels
        whose charge is drawn exactly per pixel, summed over both charges)."""
        sc = self.scene(**kw)
        has_q, mask_q, mask_d, fast = self._route(sc)
        if fast:
            return True, (), False, 0.0
        modes = fused.modes(sc, has_q, mask_q, mask_d)
        p = self.params
        temporal = p.chain_noise_dn != 0 or (sc.G * sc.read_noise_e != 0 and bool(np.any(self.patterns.read_noise_factor)))
        numpy_path = not fused.covers(modes, sc.shot_noise != "exact", temporal, has_q and p.flutter_pct > 0)
        exact = sum(1.0 if mask is True else float(np.mean(mask))
                    for m, mask in zip(modes, (mask_q, mask_d)) if m is None)
        return False, modes, numpy_path, exact

    # ------------------------------------------------------------------------------
    def _route(self, sc: Scene) -> tuple:
        """(photo charge present, where photo / dark shot noise is drawn exactly, the fast
        path applies): the per-operating-point choices that decide a frame's path."""
        p = self.params
        has_q = bool(np.any(np.asarray(sc.q) > 0))
        s2_e = sc.read_noise_e**2 + (p.chain_noise_dn**2 + 1 / 12) / sc.G**2
        mask_q = noise.exact_mask(sc.q, s2_e, sc.shot_noise) if has_q else False
        mask_d = noise.exact_mask(sc.dark_e, s2_e, sc.shot_noise) if sc.dark_e is not None else False
        if np.any(mask_q) or np.any(mask_d) or sc.lag != 0:
            return has_q, mask_q, mask_d, False
        fp = self.patterns
        pg_max = float(np.max(fp.pixel_gain * fp.response))
        q_max = float(np.max(sc.q))
        d_max = float(np.max(sc.dark_e)) if sc.dark_e is not None else 0.0
        hi = pg_max * q_max + d_max + 6 * np.sqrt(pg_max**2 * q_max + d_max) + 6 * sc.read_noise_e
        return has_q, mask_q, mask_d, bool(hi < p.full_well_e)

    def _plan(self, sc: Scene) -> dict:
        """Per-call precomputation: fixed DN maps, per-pixel sigmas, path choice."""
        p, fp = self.params, self.patterns
        G = sc.G
        adc = fp.adc
        # Offsets in DN before the ADC channels: Cs + bad columns + Rs + G * Ps1.
        # (the full maps are made in place, in the order the expressions had: the same float32
        # values, with one 12 Mpx temporary at a time instead of three)
        offs = (fp.col_fpn_dn + fp.bad_column_offset_dn)[None, :] + fp.row_fpn_dn[:, None]
        if p.pixel_fpn_e > 0:
            offs += _F32(G) * fp.pixel_offset_e
        if offs.shape != self.shape or offs.dtype != _F32:
            offs = np.broadcast_to(offs, self.shape).astype(_F32)
        half = adc.unit_gain and adc.thresholds is None
        if adc.unit_gain:  # fold channel offsets, black level (and the rounding half LSB) into the map
            offs += adc.offset_col + _F32(sc.black_level_dn + (0.5 if half else 0.0))
        var_rc = _F32(G * sc.read_noise_e) * fp.read_noise_factor
        var_rc *= var_rc
        var_rc += _F32(p.chain_noise_dn**2)  # read + chain noise, DN^2 (map)
        has_q, mask_q, mask_d, fast = self._route(sc)
        plan = dict(fast=fast, gauss_fast=sc.shot_noise != "exact", offs=offs, half=half)
        if fast:
            gmap = _F32(G) * fp.col_gain[None, :] * fp.row_gain[:, None]
            gmap *= fp.pixel_gain
            gmap *= fp.response
            base = offs
            var = var_rc
            if sc.dark_e is not None:
                base = base + _F32(G) * sc.dark_e
                var = var + _F32(G * G) * sc.dark_e
            if has_q:
                signal = gmap * _F32(sc.q) if np.ndim(sc.q) == 0 else gmap * sc.q
                base = base + signal
                var = var + gmap * gmap * sc.q
                if p.flutter_pct > 0:
                    plan["signal"] = signal.astype(_F32)
            sigma = np.sqrt(var).astype(_F32)
            plan.update(base=base.astype(_F32), sigma=sigma if np.any(sigma) else None)
        else:
            sigma_rc = np.sqrt(var_rc).astype(_F32)
            plan.update(base=offs, has_q=has_q, mask_q=mask_q, mask_d=mask_d, fw=p.full_well_e,
                        sigma=sigma_rc if np.any(sigma_rc) else None,
                        pgr=fp.pixel_gain * fp.response, cgrg=_F32(G) * fp.col_gain[None, :] * fp.row_gain[:, None])
        return plan

    def _frame(self, sc: Scene, plan: dict, rng: np.random.Generator, out: np.ndarray,
               offset_dn: float = 0.0) -> np.ndarray:
        p, fp = self.params, self.patterns
        shape = self.shape
        fastz = plan["gauss_fast"]
        flutter = 1.0
        if p.flutter_pct > 0:
            flutter = max(0.0, 1.0 + p.flutter_pct / 100 * rng.standard_normal())
        if not plan["fast"] and fused.applies(sc, plan, flutter):  # the same codes, one pass (ares.sim.fused)
            x, self._lag_e = fused.charge_frame(rng, sc, plan, shape, self._lag_e, noise.table())
        else:
            if plan["sigma"] is None:  # no per-pixel temporal noise at all
                x = plan["base"].copy()
            else:
                x = noise.normal(rng, shape, fastz)
                x *= plan["sigma"]
            if plan["fast"]:
                if plan["sigma"] is not None:
                    x += plan["base"]
                if "signal" in plan:
                    x += _F32(flutter - 1.0) * plan["signal"]
            else:
                if plan["sigma"] is not None:
                    x += plan["offs"]
                self._add_charge(x, sc, plan, rng, fastz, flutter)
        row = None  # per-row terms: Rt + frame-global
        if p.row_temporal_dn > 0:
            row = p.row_temporal_dn * noise.normal(rng, (shape[0],), fastz)
        if p.frame_global_dn > 0:
            g = _F32(p.frame_global_dn * rng.standard_normal())
            row = np.full(shape[0], g, _F32) if row is None else row + g
        if offset_dn:  # the drifting black level (after the frame's own draws: the same noise with or without it)
            row = np.full(shape[0], _F32(offset_dn), _F32) if row is None else row + _F32(offset_dn)
        col = p.col_temporal_dn * noise.normal(rng, (shape[1],), fastz) if p.col_temporal_dn > 0 else None
        rts = fp.defects.index["rts"]
        bump = None
        if len(rts):
            st = self._rts_state
            flip = rng.random(len(rts)) < np.where(st == 0, fp.rts_p_up, fp.rts_p_down)
            st[flip] = 1.0 - st[flip]
            bump = _F32(sc.G) * fp.defects.rts_amplitude_e * st
        if p.xray_events_per_frame > 0:  # RTS and X-ray charge: one sparse set of pixels (ares.sim.lowlight)
            sparse = lowlight.sparse_bumps([(rts, bump if bump is not None else ()),
                                            lowlight.xray_deposits(rng, p, sc.G, sc.temperature_c, shape)])
            rts, bump = sparse if sparse is not None else (rts, None)
        adc = fp.adc
        if adc.unit_gain and fused.adc_lookup(x, adc, out, row, col):  # the line terms added in its pass
            codes = out
            if bump is not None:  # the RTS pixels again, with their bump, as the numpy path adds it
                v = x.ravel()[rts]
                if row is not None:
                    v += row[rts // shape[1]]
                if col is not None:
                    v += col[rts % shape[1]]
                codes.ravel()[rts] = adc.quantize((v + bump).astype(_F32))
        else:
            if row is not None:
                x += row[:, None]
            if col is not None:
                x += col
            if bump is not None:
                x.ravel()[rts] += bump
            if not adc.unit_gain:
                adc.apply_channels(x, sc.black_level_dn)
            codes = adc.quantize(x, out=out, half_added=plan["half"])
        stuck = fp.defects.index["stuck"]
        if len(stuck):
            codes.ravel()[stuck] = fp.defects.stuck_code
        return codes

    def _add_charge(self, x, sc: Scene, plan: dict, rng, fastz: bool, flutter: float) -> None:
        """General path: photo and dark charge drawn separately, lag, full-well clip."""
        p = self.params
        shape = self.shape
        photo = None
        if plan["has_q"]:
            q = sc.q if flutter == 1.0 else (sc.q * flutter if np.ndim(sc.q) == 0 else sc.q * _F32(flutter))
            photo = noise.shot(rng, q, plan["mask_q"], shape, fastz, alias=flutter == 1.0)
        if sc.lag > 0:
            left = self._lag_e
            if photo is None:
                photo = left
                self._lag_e = None
            else:
                self._lag_e = _F32(sc.lag) * photo
                photo = photo - self._lag_e
                if left is not None:
                    photo += left
        else:
            self._lag_e = None
        fw = _F32(p.full_well_e)
        dark = None
        if sc.dark_e is not None:
            dark = noise.shot(rng, sc.dark_e, plan["mask_d"], shape, fastz)
            np.minimum(dark, fw, out=dark)
            x += _F32(sc.G) * dark
        if photo is not None:
            pix = plan["pgr"] * photo
            np.minimum(pix, fw - dark if dark is not None else fw, out=pix)
            x += plan["cgrg"] * pix
