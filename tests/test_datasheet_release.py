"""The EMVA 1288 Release 4.0 datasheets, one per release, read back as text (pypdf): each its
own footer, summary sheet, Section 10.1 block and operating point ("not given" where nobody
stated it, never a "[vendor]" placeholder); the Linear page 1 warns, naming Release 4.0
General, exactly when the Eq. 51 check fails; the photon-transfer note's var(dark) is the
square of the sigma_y.dark beside it. And the spectrogram peak table against sinusoidal
patterns of known amplitude and against pure noise (no peak listed).

The photon-transfer sets are computed, not simulated pixel by pixel (seconds, not minutes):
mean and temporal variance of a camera with K = 0.25 DN/e-, eta = 0.5, sigma_d = 10 e-,
saturating at 10 000 e-, each variance with its chi-square scatter; a "bow" term makes the
characteristic curve nonlinear, so that the local slope of Eq. 51 wanders."""

from __future__ import annotations

import re

import numpy as np
import pytest

from ares.analysis.emva import graphs
from ares.analysis.emva.sheet import EmvaInput, evaluate_linear, exposure_control
from ares.analysis.emva.general import emva_general
from ares.analysis.ptc.levels import LevelStats
from ares.report import datasheet
from ares.report.datasheet_pages import peak_rows
from pdftext import page_texts

K, ETA, SIGMA_D, Q_SAT, NPX = 0.25, 0.5, 10.0, 10000.0, 100_000


def synth(bow: float = 0.0, seed: int = 0, n: int = 44, constant_exposure: bool = False) -> EmvaInput:
    rng = np.random.default_rng(seed)
    up = np.linspace(40, 1.15 * Q_SAT / ETA, n)
    bright, dark = [], []
    for p in up:
        q = ETA * p
        x = min(q, Q_SAT) / Q_SAT
        mean = 100 + K * Q_SAT * (x + bow * x * (1 - x))
        var = (K * K * (SIGMA_D**2 + q) if q < Q_SAT else 2.0) * rng.chisquare(NPX) / NPX
        bright.append(LevelStats(mean, var, NPX, 2, frac_at_max=0.0 if q < 0.98 * Q_SAT else 0.6))
        dark.append(LevelStats(100 + rng.normal(0, 0.01), K * K * SIGMA_D**2 * rng.chisquare(NPX) / NPX, NPX, 2))
    t = np.full(n, 0.01) if constant_exposure else up / 1e6
    return EmvaInput(up, t, bright, dark, mean_diff=rng.normal(0, 0.1, n), meta={})


def _write(tmp_path, inp, release, **meta):
    sheet = evaluate_linear(inp)
    sheet.meta.update(meta)
    general = emva_general(inp.bright, inp.dark, inp.photons, mean_diff=inp.mean_diff)
    out = tmp_path / f"{release}.pdf"
    datasheet.write_datasheet(sheet, out, general, release)
    return sheet, general, page_texts(out)


def _first_page(tmp_path, inp) -> str:
    """Page 1 of the Linear datasheet alone (the full PDF takes seconds more)."""
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    from ares.report.plots import RC

    out = tmp_path / "page1.pdf"
    with matplotlib.rc_context(RC), PdfPages(out) as pdf:
        pdf.savefig(datasheet.summary_page(evaluate_linear(inp)))
    return page_texts(out)[0]


@pytest.fixture(scope="module")
def linear_pdf(tmp_path_factory):
    return _write(tmp_path_factory.mktemp("lin"), synth(), "4.0-linear", vendor="ACME")


@pytest.fixture(scope="module")
def general_pdf(tmp_path_factory):
    return _write(tmp_path_factory.mktemp("gen"), synth(), "4.0-general")


def test_linear_datasheet_footer_summary_and_basic_information(linear_pdf):
    sheet, _, pages = linear_pdf
    assert sheet.photon_transfer.linear is True
    for i, p in enumerate(pages):
        assert "EMVA 1288 Release 4.0 Linear ·" in p, i
        assert "Release 4.0 General ·" not in p, i
        for ph in ("[vendor]", "[model]", "[serial]", "[date]"):
            assert ph not in p, (i, ph)
    first = pages[0]
    for text in ("Summary Sheet for Operation Point 1", "Quantum efficiency", "Overall system gain", "DN/e-",
                 "vendor: ACME", "model: not given", "serial: not given",
                 "Exposure control exposure time varied (method I)", "Frame rate not given"):
        assert text in first, text
    assert "WARNING" not in first  # Eq. 51 holds: no warning
    assert any("Basic information (Section 10.1)" in p and "Sensor type not given" in p for p in pages)
    body = " ".join(pages)
    for graph in ("Characteristic curve (Fig. 5)", "Stability check (Fig. 6)", "R fit: steps", "LE fit: steps",
                  "Linearity (Section 6.9)", "regression (Eqs. 59 - 60)"):
        assert graph in body, graph
    assert "5 - 95 % sat." not in body  # the actual fit range, not a fixed label


def test_photon_transfer_note_dark_variance_is_sigma_y_dark_squared(linear_pdf):
    sheet, _, pages = linear_pdf
    m = re.search(r"σ²y\.dark = ([0-9.]+) DN² \(σy\.dark = ([0-9.]+) ±", pages[0])
    assert m, pages[0][:400]
    var, sig = float(m.group(1)), float(m.group(2))
    assert var == pytest.approx(sig**2, rel=2e-3)  # the same figure, rounded to 4 digits
    assert sig == pytest.approx(sheet.values["sigma_y_dark"].value, rel=1e-3)
    assert sig == pytest.approx(K * SIGMA_D, rel=0.01)  # 2.5 DN, the model's dark noise


def test_general_datasheet_has_its_own_summary_and_footer(general_pdf):
    _, general, pages = general_pdf
    for i, p in enumerate(pages):
        assert "EMVA 1288 Release 4.0 General ·" in p, i
        assert "Release 4.0 Linear" not in p, i
        assert "[vendor]" not in p and "[model]" not in p, i
    first = pages[0]
    assert "Summary Sheet (Release 4.0 General)" in first
    for absent in ("Quantum efficiency", "Overall system gain", "DN/e-", "e-/DN"):  # not measured by General
        assert absent not in first, absent
    from ares.analysis.emva.sheet import symbol

    for k in general.values:  # every entry of the General result, whatever it holds, under its symbol
        assert symbol(k, True)[:18] in first, k
    assert "vendor: not given" in first
    assert any("Basic information (Section 10.1)" in p for p in pages)
    assert any("Stability check (Fig. 6)" in p for p in pages)


def test_cannot_be_measured_rows_are_shown_as_such():
    from ares.analysis.stats.estimate import Estimate

    e = Estimate.na("cannot be measured with the general model (General Section 6.7)", "DN/e-")
    assert datasheet.cell(e) == "cannot be measured"
    assert datasheet.cell(Estimate.na("no dark stack", "e-")) == "n/a"


def test_page_one_warns_when_eq51_fails(tmp_path):
    inp = synth(bow=0.15)
    assert evaluate_linear(inp).photon_transfer.linear is False
    first = _first_page(tmp_path, inp)
    assert "WARNING: the linear model does not hold" in first
    assert "Release 4.0 General" in first and "Eq. 51" in first


def test_exposure_control_is_read_from_the_data(tmp_path):
    assert exposure_control([0.01, 0.02, 0.03]) == "exposure time varied (method I)"
    assert exposure_control([0.01] * 5) == "light varied at 10 ms exposure (method II)"
    assert "light varied at 10 ms exposure (method II)" in _first_page(tmp_path, synth(constant_exposure=True))


# ---------------------------------------------------------------- spectrogram peaks

M, N = 240, 320


def _image(seed, amp=0.0, cycles=0.0, vertical=False, sigma=0.5):
    rng = np.random.default_rng(seed)
    img = rng.normal(0, sigma, (M, N))
    if amp:
        if vertical:  # a pattern along the columns: rows vary
            img += amp * np.sin(2 * np.pi * cycles * np.arange(M) + 0.4)[:, None]
        else:
            img += amp * np.sin(2 * np.pi * cycles * np.arange(N) + 0.4)[None, :]
    return img


@pytest.mark.parametrize("bin_offset", [0.0, 0.5, 0.3])
@pytest.mark.parametrize("vertical", [False, True])
def test_peak_amplitude_is_the_whole_peak(bin_offset, vertical):
    """A 1.5 DN sinusoid, on a bin or between bins: the whole peak gives 1.5 DN. Tolerance
    0.05 DN: the noise in the ~50 summed bins (noise_amplitude ~0.1 DN of power, whose
    scatter is 1/sqrt(M) of it) and the leaked power beyond the bins the walk reaches (< 2 %
    of the power for a pattern half-way between bins)."""
    n = M if vertical else N
    cycles = (40 + bin_offset) / n
    s = graphs.spectrogram(_image(7, 1.5, cycles, vertical), "vertical" if vertical else "horizontal")
    peaks = graphs.spectrum_peaks(s)
    assert len(peaks) == 1, peaks
    pk = peaks[0]
    assert pk.amplitude == pytest.approx(1.5, abs=0.05)
    assert abs(pk.freq - cycles) <= 1 / n
    assert pk.p_false < 1e-12
    # one bin alone (the old table) falls short between bins: the whole peak is needed
    if bin_offset == 0.5:
        v = int(round(pk.freq * n))
        assert graphs.pattern_amplitude(s.sqrt_power**2, n, v, v) < 1.3


def test_pure_noise_lists_no_peak():
    """40 spectra of white noise: with a 1 % false-alarm rate per spectrum, ~0.4 false peaks
    are expected; more than 2 would mean the noise level or the threshold is wrong."""
    found = sum(len(graphs.spectrum_peaks(graphs.spectrogram(_image(seed), d)))
                for seed in range(20) for d in ("horizontal", "vertical"))
    assert found <= 2


def test_weak_pattern_significance():
    """0.1 DN on 0.5 DN noise, on a bin: bin power over noise (sigma^2 + A^2 N / 4) / sigma^2
    = 6.12; its scatter 1/sqrt(M) of the noise part."""
    s = graphs.spectrogram(_image(3, 0.1, 80 / N), "horizontal")
    pk = graphs.spectrum_peaks(s)
    assert len(pk) == 1
    expected = (0.25 + 0.01 * N / 4) / 0.25
    assert pk[0].ratio == pytest.approx(expected, abs=4 * expected / np.sqrt(M))
    assert pk[0].p_false < 1e-6


def test_peak_table_rows():
    c = {"spectrogram_dsnu_h": graphs.spectrogram(_image(1, 1.5, 50 / N), "horizontal"),
         "spectrogram_dsnu_v": graphs.spectrogram(_image(2), "vertical")}
    specs = [("spectrogram_dsnu_h", "DSNU, horizontal", "dark_lines", "DN"),
             ("spectrogram_dsnu_v", "DSNU, vertical", "dark_lines", "DN")]
    rows = peak_rows(c, specs)
    assert len(rows) == 1 and rows[0][0] == "DSNU, horizontal"
    assert float(rows[0][3]) == pytest.approx(1.5, abs=0.05)


def test_pattern_at_nyquist():
    """An alternating +-A pattern (0.5 cycles/pixel): the Nyquist bin holds A^2 N, not A^2 N / 4."""
    rng = np.random.default_rng(5)
    img = rng.normal(0, 0.5, (M, N)) + 1.5 * np.where(np.arange(N) % 2, 1.0, -1.0)[None, :]
    pk = graphs.spectrum_peaks(graphs.spectrogram(img, "horizontal"))
    assert len(pk) == 1 and pk[0].freq == 0.5
    assert pk[0].amplitude == pytest.approx(1.5, abs=0.05)
