"""Ground truth of a ``SimSensor`` at one operating point (``SimSensor.truth(...)``).

Returned as a plain dict. All offsets/noise in DN at the ADC input (before quantization),
variances in DN^2, for the *clean* sensor: defect pixels/columns are listed under
``defects`` and are not part of any component. Keys:

Parameter values (expectations of the model):
  ``o``            mean offset, DN: black level + mean ADC channel offset + G * mean dark charge
  ``Cs``, ``Rs``   column / row offset FPN variance, DN^2 (``Cs`` includes the even/odd ADC
                   channel offset pattern, whose population variance is ((o1-o0)/2)^2)
  ``Ps``           pixel offset FPN variance, DN^2: G^2 * (pixel_fpn_e^2 + (t*k)^2 (dsnu^2 + tail^2)),
                   k the temperature/bias dark scale (dark-rate clipping at 0 ignored)
  ``Ct``, ``Rt``   column / row temporal variance, DN^2
  ``Pt``           pixel temporal variance, DN^2: (G*read_noise_e)^2 + chain_noise_dn^2
                   + G^2 * mean dark charge (dark shot noise); excludes photo shot noise
  ``frame_global`` variance of the frame-global offset, DN^2
  ``G``            system gain, DN/e-
  ``Cg``, ``Rg``, ``Pg``  variances of the relative gain factors (realized mean exactly 1:
                   Cg over the columns, Rg over the rows, Cg Rg Pg per Bayer phase, so the
                   array's mean gain is G); ``Pg`` averaged over the Bayer phases (per
                   phase: ``Pg_by_phase``)
  ``q``            mean photo-charge per pixel, e- (over all pixels; OB columns hold 0;
                   includes added_photocharge_e); ``q_by_phase``: per Bayer phase
                   (r%2, c%2) = (0,0), (0,1), (1,0), (1,1)
  ``delta``        shot-noise variance, e^2 (= q, mean over pixels; before lag)
  ``quantization_dn2``  1/12, the ADC quantization variance (not in ``Pt``)

``realized``: the same fixed-pattern keys computed from this instance's draws
(``o`` = mean of the noise-free clean dark image; ``Cs``, ``Rs``, ``Ps``, ``Cg``, ``Rg``,
``Pg``: sample variances, ddof=1, of the maps below; ``Pt`` with the realized mean dark
charge; temporal keys equal the parameter values).

``maps``: realized arrays. ``Cs`` (cols,), ``Rs`` (rows,), ``Ps`` (rows, cols) in DN,
centred (so clean expected dark pixel = realized o + Cs[c] + Rs[r] + Ps[r, c]);
``Cg`` (cols,), ``Rg`` (rows,), ``Pg`` (rows, cols) relative gains; ``q`` (rows, cols)
mean e-; ``dark_e_per_s`` (rows, cols) pixel dark current at this temperature incl.
hot/warm pixels; ``gain_dn_per_e`` (rows, cols) = G*Cg*Rg*Pg*response (0 in OB, dead < 1).

Also: ``dark_current_e_per_s``, ``dsnu_e_per_s``, ``dark_tail_e_per_s`` (at this
temperature and bias), ``dark_charge_e`` (mean clean dark charge), ``read_noise_e``,
``read_noise_dn``, ``full_well_e``, ``full_well_dn`` (= G*full_well_e, signal above the
offset), ``max_code``, ``lag_fraction``, ``flutter_pct`` (per-frame relative sigma of q, %), ``adc`` (bits, max_code, offset_dn, gain,
inl_lsb per transition k=1..max, dnl_lsb per code), ``defects`` (per class a (rows,
cols) tuple of index arrays; ``bad_columns`` an array; ``properties`` with per-pixel
values in the same order), ``lowlight`` (``ares.sim.lowlight.truth``: the RTS pixels' amplitudes in DN and
mean dwell times in frames, the per-pixel activation-energy and ln-prefactor maps under Arrhenius, the
Fe-55 K-alpha electrons and gain), ``scene`` (the operating point).
"""

from __future__ import annotations

import numpy as np

from ares.sim.lowlight import dark_rate_map
from ares.sim.lowlight import truth as lowlight_truth
from ares.sim.scene import Scene


def _var(a) -> float:
    a = np.asarray(a, np.float64).ravel()
    return float(a.var(ddof=1)) if a.size > 1 else 0.0


def build_truth(sensor, sc: Scene) -> dict:
    p, fp = sensor.params, sensor.patterns
    G, t, k = sc.G, sc.exposure_s, sc.dark_scale
    adc_off = fp.adc.offset_col.astype(np.float64)
    adc_mean = float(np.mean(p.adc_offset_dn))
    dark_mean_e = t * k * p.dark_current_e_per_s
    prnu_var = (np.asarray(p.prnu_pct) / 100) ** 2
    read_dn2 = (G * sc.read_noise_e) ** 2 + p.chain_noise_dn**2
    param = {
        "o": sc.black_level_dn + adc_mean + G * dark_mean_e,
        "Cs": p.col_fpn_dn**2 + ((p.adc_offset_dn[1] - p.adc_offset_dn[0]) / 2) ** 2,
        "Ct": p.col_temporal_dn**2,
        "Rs": p.row_fpn_dn**2,
        "Rt": p.row_temporal_dn**2,
        "Ps": G**2 * (p.pixel_fpn_e**2 + (t * k) ** 2 * (p.dsnu_e_per_s**2 + p.dark_tail_e_per_s**2)),
        "Pt": read_dn2 + G**2 * dark_mean_e,
        "frame_global": p.frame_global_dn**2,
        "G": G,
        "Cg": (p.col_gain_pct / 100) ** 2,
        "Rg": (p.row_gain_pct / 100) ** 2,
        "Pg": float(np.mean(prnu_var)),
        "Pg_by_phase": [float(v) for v in prnu_var],
        "q": float(np.mean(sc.q)),
        "delta": float(np.mean(sc.q)),
        "q_by_phase": [float(np.mean(np.broadcast_to(sc.q, sensor.shape)[fp.phase == i])) for i in range(4)],
        "quantization_dn2": 1.0 / 12.0,
    }

    cs_raw = fp.col_fpn_dn.astype(np.float64) + adc_off
    rs_raw = fp.row_fpn_dn.astype(np.float64)
    dark_clean = sc.dark_clean_e.astype(np.float64) if sc.dark_clean_e is not None else 0.0
    ps_raw = G * (fp.pixel_offset_e.astype(np.float64) + dark_clean)
    ps_raw = np.broadcast_to(ps_raw, sensor.shape)
    q_map = np.broadcast_to(np.asarray(sc.q, np.float64), sensor.shape).copy()
    maps = {
        "Cs": cs_raw - cs_raw.mean(),
        "Rs": rs_raw - rs_raw.mean(),
        "Ps": ps_raw - ps_raw.mean(),
        "Cg": fp.col_gain.astype(np.float64),
        "Rg": fp.row_gain.astype(np.float64),
        "Pg": fp.pixel_gain.astype(np.float64),
        "q": q_map,
        "dark_e_per_s": dark_rate_map(p, fp, sc),
        "gain_dn_per_e": G * fp.col_gain[None, :].astype(np.float64) * fp.row_gain[:, None]
        * fp.pixel_gain * fp.response,
    }
    realized = dict(param)
    realized.update(
        o=float(sc.black_level_dn + cs_raw.mean() + rs_raw.mean() + ps_raw.mean()),
        Cs=_var(maps["Cs"]), Rs=_var(maps["Rs"]), Ps=_var(maps["Ps"]),
        Cg=_var(maps["Cg"]), Rg=_var(maps["Rg"]), Pg=_var(maps["Pg"]),
        Pg_by_phase=[_var(maps["Pg"][fp.phase == i]) for i in range(4)],
        Pt=read_dn2 + G**2 * float(np.mean(dark_clean)),
    )

    d = fp.defects
    defects = {name: d.locations(name) for name in d.index}
    defects["bad_columns"] = d.bad_columns.copy()
    defects["properties"] = {
        "hot_e_per_s": d.hot_e_per_s * k,
        "warm_e_per_s": d.warm_e_per_s * k,
        "rts_amplitude_e": d.rts_amplitude_e.copy(),
        "stuck_code": d.stuck_code.copy(),
        "dead_response": p.dead_response,
        "noisy_factor": p.noisy_factor,
        "bad_column_offset_dn": p.bad_column_offset_dn,
    }
    adc = fp.adc
    return {
        **param,
        "realized": realized,
        "maps": maps,
        "dark_current_e_per_s": p.dark_current_e_per_s * k,
        "dsnu_e_per_s": p.dsnu_e_per_s * k,
        "dark_tail_e_per_s": p.dark_tail_e_per_s * k,
        "dark_charge_e": dark_mean_e,
        "read_noise_e": sc.read_noise_e,
        "read_noise_dn": G * sc.read_noise_e,
        "full_well_e": p.full_well_e,
        "full_well_dn": G * p.full_well_e,
        "max_code": p.max_code,
        "lag_fraction": sc.lag,
        "flutter_pct": p.flutter_pct,
        "adc": {"bits": p.adc_bits, "max_code": p.max_code, "offset_dn": list(p.adc_offset_dn),
                "gain": list(p.adc_gain), "inl_lsb": adc.inl_lsb(), "dnl_lsb": adc.dnl_lsb()},
        "defects": defects,
        "lowlight": lowlight_truth(sensor, sc),
        "scene": {"exposure_s": t, "temperature_c": sc.temperature_c, "analog_gain": sc.analog_gain,
                  "black_level_dn": sc.black_level_dn, "shot_noise": sc.shot_noise},
    }
