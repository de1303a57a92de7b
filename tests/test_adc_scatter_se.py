"""INL/DNL SEs from the ramp's own scatter, against the simulated ADC's truth.

A ramp's code density is nearly deterministic: the counting (Poisson) SE the analysis gave
overstated its error 5-200x (benchmarks/adc_se.md), so its extremes were "ok" with an SE that
could never fail. The sub-histograms' scatter (frame i in group i mod 16, as the ramp stage
keeps them) must follow the error the data actually make: per code, and for the extremes
over a handful of seeds, with the selection bias of an extreme of many codes corrected."""

from __future__ import annotations

import numpy as np
import pytest

from ares.analysis.ptc.adc import from_histogram
from ares.sim import SensorParams
from ares.sim.adc import Adc

TRUTH = {"inl_max": lambda i, d: i.max(), "inl_min": lambda i, d: i.min(),
         "dnl_max": lambda i, d: np.nanmax(d), "dnl_min": lambda i, d: np.nanmin(d)}


class _InStep:
    """A ramp in step with the sampling: the same phase every frame (``Adc.ramp``'s rng)."""

    def __init__(self, seed):
        self.phase = np.random.default_rng(seed).random()

    def random(self):
        return self.phase


def ramp(seed: int, frames: int = 16, noise: float = 0.0, dnl: float = 0.2, in_step: bool = False):
    """A 10-bit ADC (bow 0.5 LSB, random code widths) and the (group, code) histograms of
    channel 0 of a 64x128 ramp (4 samples per code and channel a frame)."""
    adc = Adc(SensorParams(rows=64, cols=128, adc_bits=10, adc_inl_lsb=0.5, adc_dnl_lsb=dnl),
              np.random.default_rng(100 + seed))
    g = np.zeros((min(frames, 16), adc.max_code + 1), np.int64)
    rng = _InStep(seed) if in_step else np.random.default_rng(seed)
    for i in range(frames):
        f = adc.ramp(1, (64, 128), rng, noise_lsb=noise)[0][:, 0::2]
        g[i % g.shape[0]] += np.bincount(f.ravel(), minlength=adc.max_code + 1)
    return adc, g


def test_per_code_se_follows_the_error_of_every_code():
    adc, g = ramp(1)
    r = from_histogram(g.sum(axis=0), groups=g)
    old = from_histogram(g.sum(axis=0))  # the counting SE (one histogram)
    for est, se, old_se, truth in ((r.dnl, r.dnl_se(), old.dnl_se(), adc.dnl_lsb()),
                                   (r.inl, r.inl_se(), old.inl_se(), adc.inl_lsb())):
        ok = np.isfinite(est) & (se > 0)
        z = (est - truth)[ok] / se[ok]
        # ~1000 codes: the SD of z is known to a few %; Student's t (x 1.24 for 15 dof) and one
        # count's resolution make it < 1 (DNL 0.63, INL 0.44), the counting SE ~0.17 (INL: 0.01)
        assert 0.35 < z.std() < 1.2
        assert np.mean(np.abs(z) > 3) < 0.01
        assert (est - truth)[ok].std() / old_se[ok].mean() < 0.3  # (what the counting SE did)


@pytest.mark.parametrize("noise", [0.0, 1.0])
def test_extremes_cover_the_truth_over_seeds(noise):
    zs, errs, ses = [], [], []
    for seed in range(1, 5):
        adc, g = ramp(seed, noise=noise)
        ext = from_histogram(g.sum(axis=0), groups=g).extremes()
        for key, truth in TRUTH.items():
            e, t = ext[key], truth(adc.inl_lsb(), adc.dnl_lsb())
            if e.bound:  # a limit must hold the truth
                assert (t <= e.value) if e.bound == "upper" else (t >= e.value), (key, seed)
                continue
            zs.append((e.value - t) / e.se)
            errs.append(e.value - t)
            ses.append(e.se)
    zs = np.array(zs)
    assert zs.size >= 12 and np.abs(zs).max() < 3
    # the SE is the error's size: within a factor 3 of its rms either way
    assert 1 / 3 < np.mean(ses) / np.sqrt(np.mean(np.square(errs))) < 3


def test_a_ramp_in_step_with_the_sampling_is_known_to_one_sample_a_frame():
    """Every frame the same (a synchronous ramp): the sub-histograms agree, their scatter is 0
    and averaging resolves nothing; the SE is one sample of a frame's count (the error of such a
    ramp), not of the total (16x smaller: its extremes up to ~15 SE off)."""
    adc, g = ramp(2, in_step=True)
    r = from_histogram(g.sum(axis=0), groups=g)
    assert "not dithered" in r.se_note()
    for key, truth in TRUTH.items():
        e, t = r.extremes()[key], truth(adc.inl_lsb(), adc.dnl_lsb())
        assert ((t <= e.value) if e.bound == "upper" else (t >= e.value)) if e.bound else abs(e.value - t) < 3 * e.se


def test_an_extreme_of_noise_is_corrected_for_its_selection_bias():
    """Codes of equal width (a bow only: the true DNL max is 0.0015 LSB) and input noise: the
    DNL max of the curve is the largest of ~1000 noisy codes, several of its SEs above the
    truth; reported less its selection bias, with the bias in its SE, it covers the truth
    (or is only a limit that holds it)."""
    adc, g = ramp(5, noise=0.5, dnl=0.0)
    r = from_histogram(g.sum(axis=0), groups=g)
    raw, se = r.at_extremes()["dnl_max"]
    truth = np.nanmax(adc.dnl_lsb())
    assert (raw - truth) / se > 3  # the selection bias, uncorrected
    e = r.extremes()["dnl_max"]
    assert "selection bias" in e.note
    assert e.value >= truth if e.bound else abs(e.value - truth) < 3 * e.se


def test_one_histogram_falls_back_to_counting_and_says_so():
    adc, g = ramp(2, frames=4)
    r = from_histogram(g.sum(axis=0))
    assert r.groups == 0 and "counting statistics" in r.se_note()
    e = r.extremes()
    assert all("one histogram only" in x.note for x in e.values())
    # the counting SE of a ramp is far above its extremes' error: none of them "ok" by it
    assert {x.verdict for x in e.values()} <= {"upper limit", "lower limit", "ok"}
    with pytest.raises(ValueError, match="add up"):
        from_histogram(g.sum(axis=0) + 1, groups=g)


class _Run:
    """A run record of one ramp stage (``ares.rundir.record.RunRecord``'s two members read)."""

    def __init__(self, arrays):
        self.stages = [{"index": 0, "name": "ramp", "scene": "dark", "settings": {"reg:test_mode": 2}}]
        self._arrays = arrays

    def arrays(self, index):
        return self._arrays


def test_the_analysis_uses_the_sub_histograms_and_reads_a_run_without_them():
    """A ramp stage's ``histgroups_<view>`` give the scatter SEs; a run directory written before
    them (``hist_<view>`` only) is still analysed, with the counting SE, its notes saying so."""
    from ares.results.adc import adc_linearity

    _, g = ramp(4, frames=6)
    new = adc_linearity(_Run({"hist_full": g.sum(axis=0), "histgroups_full": g}))["channels"]["full"]
    old = adc_linearity(_Run({"hist_full": g.sum(axis=0)}))["channels"]["full"]
    assert new["sub_histograms"] == 6 and old["sub_histograms"] == 0
    assert "6 independent sub-histograms" in new["inl_max_lsb"]["note"]
    assert "one histogram only" in old["inl_max_lsb"]["note"]
    assert new["inl_max_lsb"]["verdict"] == "ok"  # the 0.5 LSB bow, resolved by the ramp's own scatter


def test_a_report_of_an_old_run_judges_its_recorded_extremes_again():
    """The PDF table of a run recorded before the sub-histograms: its "ok" extremes with SEs far
    above their values (INL max 0.50 +- 0.92 LSB) are shown as the analysis judges them now."""
    from ares.report.series_tables import adc_channels_now
    from ares.results.adc import ramp_curves

    _, g = ramp(4, frames=6, dnl=0.0)  # the shipped sensor's ADC: a 0.5 LSB bow only
    run = _Run({"hist_full": g.sum(axis=0)})
    old = {"stages": ["ramp"], "channels": {"full": {"inl_max_lsb": {"value": 0.5, "se": 0.92, "unit": "LSB",
                                                                     "verdict": "ok"}, "samples": 1}}}
    chans, again = adc_channels_now(old, ramp_curves(run, ["ramp"]))
    assert again == ["full"] and chans["full"]["inl_max_lsb"]["verdict"] == "upper limit"
    assert chans["full"]["samples"] == 1
