"""The EMVA 1288 Release 4.0 Linear parameter set of Table 2 and the graph data of the
datasheet (Linear Section 10.2): photon transfer (``emva4``), spatial nonuniformity
(``emva_spatial``), spectrograms, profiles and defect histograms (``emva_graphs``) and dark
current (Section 7), from one ``EmvaInput`` -- whatever recorded it (a descriptor file, a
scan on the simulator or on hardware).

Quantity names are the standard's symbols in ASCII (``mu_e_sat`` for mu_e.sat,
``DSNU1288_col`` for DSNU1288.col); ``SYMBOLS`` gives the printed form and ``TABLE2`` the
order and units of the datasheet's one-column table. Pure numpy: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ares.analysis.emva import graphs
from ares.analysis.emva.gain_term import GainTerm, attribute
from ares.analysis.emva.linear import Emva4Result, emva4_linear
from ares.analysis.spatial.nonuniformity import Split, dsnu, prnu, snr_model, snr_total_model, split
from ares.analysis.emva.sanity import judge
from ares.analysis.stats.estimate import Estimate
from ares.analysis.ptc.levels import LevelStats, LineTemporal

# Table 2 of the Linear document: (key, printed symbol, unit)
TABLE2 = (
    ("QE", "η", "%"), ("K", "K", "DN/e-"), ("K_inv", "1/K", "e-/DN"),
    ("sigma_y_dark", "σy.dark", "DN"), ("sigma_d", "σd", "e-"),
    ("SNR_max", "SNRmax", ""), ("SNR_max_db", "SNRmax", "dB"), ("SNR_max_inv", "1/SNRmax", "%"),
    ("mu_e_min", "µe.min", "e-"), ("mu_e_min_area", "µe.min.area", "e-/µm²"),
    ("mu_e_sat", "µe.sat", "e-"), ("mu_e_sat_area", "µe.sat.area", "e-/µm²"),
    ("DR", "DR", ""), ("DR_db", "DR", "dB"),
    ("DSNU1288", "DSNU1288", "e-"), ("DSNU1288_col", "DSNU1288.col", "e-"),
    ("DSNU1288_row", "DSNU1288.row", "e-"), ("DSNU1288_pix", "DSNU1288.pix", "e-"),
    ("PRNU1288", "PRNU1288", "%"), ("PRNU1288_col", "PRNU1288.col", "%"),
    ("PRNU1288_row", "PRNU1288.row", "%"), ("PRNU1288_pix", "PRNU1288.pix", "%"),
    ("LE", "LE", "%"), ("mu_I_mean", "µI.mean", "e-/s"), ("mu_I_var", "µI.var", "e-/s"),
)
EXTRA = (("R", "R", "DN/photon"), ("mu_p_min", "µp.min", "photons"), ("mu_p_sat", "µp.sat", "photons"),
         ("mu_y_sat", "µy.sat - µy.dark", "DN"), ("DSNU1288_DN", "DSNU1288", "DN"),
         ("sigma_y_stack_dark", "σy.stack.dark", "DN"), ("sigma_y_stack_50", "σy.stack.50", "DN"))
SYMBOLS = {k: s for k, s, _ in TABLE2 + EXTRA}


def symbol(key: str, general: bool = False) -> str:
    """A Table 2 key's printed symbol, the one name of the figure on every surface (terminal,
    key_figures.csv, PDF, datasheet, window); ``general``: the General document's Table 2
    (``µp.sat.area``, ``SNRp.max``), its other figures as the Linear sheet names them."""
    from ares.analysis.emva.general_table import GENERAL_TABLE2

    own = {k: s for k, s, _ in GENERAL_TABLE2} if general else {}
    return own.get(key) or SYMBOLS.get(key, key)


def _stack_sigma(st: "StackImage", note: str) -> Estimate:
    """Eq. 65's temporal noise of a stack with its SE: the mean of N pixels' variances over L
    frames has N (L - 1) degrees of freedom (white noise: the variance's relative SE is
    sqrt(2 / (N (L - 1))), the noise's half of it)."""
    var = max(st.temporal_var, 0.0)
    dof = st.mean_image.size * (st.L - 1)
    sig = math.sqrt(var)
    return Estimate(sig, sig / math.sqrt(2 * dof) if dof > 0 else math.nan, "DN", note)


@dataclass
class StackImage:
    """An averaged image of L frames (Eq. 33) and its mean per-pixel temporal variance (Eq. 65)."""

    mean_image: np.ndarray
    temporal_var: float  # Eq. 65 (the mean per-pixel temporal variance)
    L: int
    photons: float = 0.0
    exposure_s: float = math.nan
    line: "LineTemporal | None" = None  # offset-free pixel, row-mean and column-mean temporal variances
    total: "np.ndarray | None" = field(default=None, repr=False)  # exact integer sum of the L frames
    _memo: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def _filtered(self, release: str) -> tuple[np.ndarray, float]:
        """(image, scale): what the high-pass of ``release`` reads -- the exact integer sum
        times 1/L when there is one (filtered in integers: 2x faster, half the memory), else
        the averaged image."""
        if self.total is not None and release != "none":
            return self.total, 1.0 / self.L
        return self.mean_image, 1.0

    def highpassed(self, release: str) -> np.ndarray:
        """The averaged image after the high-pass of ``release`` (Section 8.1; "none": as it
        is)."""
        from ares.analysis.spatial.nonuniformity import highpass

        img, scale = self._filtered(release)
        return highpass(img, release, scale)

    def split(self, release: str) -> Split:
        """``emva_spatial.split`` of the averaged image, computed once."""
        if ("split", release) not in self._memo:
            t, rows, cols = ((self.temporal_var, None, None) if self.line is None else
                             (self.line.pixel, self.line.rows, self.line.cols))
            img, scale = self._filtered(release)
            # sigma^2 of Eq. 57 as written: the stack's temporal variance (the extension keeps
            # the offset-free pixel variance of the line model)
            self._memo["split", release] = split(img, t, self.L, release, rows, cols, scale=scale,
                                                  temporal_var_text=self.temporal_var)
        return self._memo["split", release]

    def highpassed_var(self, release: str) -> float:
        """The variance of the high-passed averaged image (Release 3.1's Eq. 86 reads only
        it), computed once."""
        if ("var", release) not in self._memo:
            self._memo["var", release] = float(np.var(self.highpassed(release)))
        return self._memo["var", release]

    def prepare(self) -> "StackImage":
        """Compute the figures every release reads (the 4.0 split, or the unfiltered split for
        an image smaller than the filter, and the 3.1 high-passed variance) -- in a worker
        thread while other images are still read. The images are not kept (memory)."""
        try:
            self.split("4.0")
            self.highpassed_var("3.1")
        except ValueError:  # smaller than a filter: evaluate_linear and release31 say so
            self.split("none")
        return self


@dataclass
class EmvaInput:
    photons: np.ndarray  # mu_p per exposure step
    exposure_s: np.ndarray
    bright: list[LevelStats]  # two-image statistics (Eq. 18) per step
    dark: list[LevelStats]
    step_split: list[tuple[Split, Split]] | None = None  # per-step (bright, dark) spatial variances
    mean_diff: np.ndarray | None = None  # mu[0] - mu[1] of each bright pair (stability, General 6.7)
    stack_dark: StackImage | None = None
    stack_bright: StackImage | None = None  # ~50 % of saturation
    dark_series: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # (t, mu_dark, s2_dark), Section 7.1
    temperatures: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] | None = None  # Section 7.2
    pixel_area_um2: float | None = None
    meta: dict = field(default_factory=dict)  # vendor, model, date, wavelength_nm, operating point ...
    notes: list[str] = field(default_factory=list)  # what the reader of the input noticed


@dataclass
class EmvaSheet:
    release: str
    values: dict[str, Estimate]
    photon_transfer: Emva4Result
    curves: dict  # graph data (numpy arrays) by graph name
    notes: list[str]
    meta: dict

    def to_json(self) -> dict:
        out = {"release": self.release, "values": {}, "notes": self.notes, "meta": self.meta,
               "saturation": self.photon_transfer.saturation, "linear_model_holds": self.photon_transfer.linear}
        for k, v in self.values.items():
            out["values"][k] = {"symbol": SYMBOLS.get(k, k), **v.to_dict()}
        return out


def exposure_control(exposures_s, photons=None) -> str:
    """How the exposure steps were made, read from the data (Section 6.3): exposure time
    varied (method I) or the light varied at one exposure time (method II)."""
    t = np.asarray(exposures_s, float)
    t = t[np.isfinite(t)]
    if t.size == 0:
        return "not given"
    r = np.round(t, 12)
    if r.max() > r.min():  # (not np.unique: it loads numpy.ma, which ares emva does without)
        return "exposure time varied (method I)"
    return f"light varied at {1e3 * float(t[0]):.4g} ms exposure (method II)"


def _scaled(e: Estimate, f: float, unit: str, note: str) -> Estimate:
    if not e.available:
        return Estimate.na(e.note, unit)
    if e.bound:
        return Estimate.limit(e.value * f, e.bound, unit, note)
    return Estimate(e.value * f, e.se * abs(f), unit, note)


def dark_current_4(t, mu, s2, K: Estimate, min_exposures: int = 6) -> dict[str, Estimate]:
    """Section 7.1 (``ares.analysis.ptc.dark_current``): slopes of the dark mean (DN/s, / K) and
    of the dark temporal variance (DN^2/s, / K^2), each as value +- its one-sigma error, and
    where it is not above that error also the upper limit mu_I + sigma_I beside it
    (``mu_I_mean_upper``, ``mu_I_var_upper``: ``dark_current.with_upper_limit``)."""
    from ares.analysis.ptc.dark_current import dark_current, with_upper_limit

    dc = dark_current(t, mu, K, s2, min_exposures=min_exposures)
    out: dict[str, Estimate] = {}
    for key, e in (("mu_I_mean", dc.rate_e_per_s), ("mu_I_var", dc.rate_from_variance_e_per_s)):
        out.update(with_upper_limit(key, e))
    return out


def dark_current_rates(rates: dict[str, Estimate], gt: "GainTerm | None") -> dict[str, Estimate]:
    """The Section 7.1 rates keep the regression's one-sigma error the text prescribes (with
    Eq. 50's K's own SE); where K as the zero-signal gain is less certain (``gain_term``), each
    rate's note says how large that term is against its SE (mu_I.mean ~ 1/K, mu_I.var ~ 1/K^2)."""
    if gt is None or not gt.widens:
        return rates
    out = dict(rates)
    for key, power in (("mu_I_mean", 1), ("mu_I_var", 2)):
        e = rates.get(key)
        if e is None or not e.available or e.bound or not (math.isfinite(e.se) and e.se > 0):
            continue
        extra = abs(e.value) * power * math.sqrt(gt.se ** 2 - gt.k_se ** 2) / abs(gt.k0.value + gt.diff)  # (K_0 + D = Eq. 50 K)
        out[key] = Estimate(e.value, e.se, e.unit, f"{e.note}; not in this SE (Section 7.1: the regression's one "
                                                   f"sigma): K as the zero-signal gain would add {extra:.2g} {e.unit} "
                                                   f"({extra / e.se:.2g} SE) in quadrature (ares.analysis.emva.gain_term)",
                            e.bound, e.exact)
    return out


def _stack_graphs(sd: StackImage, sb: StackImage | None, hp: str, v: dict) -> dict:
    g: dict = {}
    dark_hp = sd.highpassed(hp)
    s_dark = v["DSNU1288_DN"].value if v["DSNU1288_DN"].available else math.nan
    g["dark_lines"] = {"DSNU1288": s_dark, "sigma_y_stack": math.sqrt(max(sd.temporal_var, 0.0))}
    g["spectrogram_dsnu_h"] = graphs.spectrogram(dark_hp, "horizontal")
    g["spectrogram_dsnu_v"] = graphs.spectrogram(dark_hp, "vertical")
    g["profile_dsnu_h"] = graphs.profiles(sd.mean_image, "horizontal")
    g["profile_dsnu_v"] = graphs.profiles(sd.mean_image, "vertical")
    g["hist_dsnu"] = graphs.log_histogram(dark_hp, sd.L)
    g["acc_dsnu"] = graphs.accumulated_histogram(dark_hp, sd.L)
    if sb is not None:  # (one image-sized temporary at a time besides the two high-passed ones)
        prnu_hp = sb.highpassed(hp)
        prnu_hp -= dark_hp  # the high-pass is linear
        del dark_hp
        prnu_img = sb.mean_image - sd.mean_image
        mean = float(prnu_img.mean())
        rel = 100.0 / mean if mean > 0 else math.nan
        g["prnu_lines"] = {"PRNU1288": v["PRNU1288"].value, "sigma_y_stack": math.sqrt(max(sb.temporal_var, 0)) * rel}
        g["profile_prnu_h"] = graphs.profiles(prnu_img, "horizontal")
        g["profile_prnu_v"] = graphs.profiles(prnu_img, "vertical")
        del prnu_img
        g["spectrogram_prnu_h"] = graphs.spectrogram(prnu_hp, "horizontal", rel)
        g["spectrogram_prnu_v"] = graphs.spectrogram(prnu_hp, "vertical", rel)
        g["hist_prnu"] = graphs.log_histogram(prnu_hp, sb.L)
        g["acc_prnu"] = graphs.accumulated_histogram(prnu_hp, sb.L)
    return g


def evaluate_linear(inp: EmvaInput, highpass_release: str = "4.0") -> EmvaSheet:
    """Every Release 4.0 Linear figure of Table 2 with its SE or verdict, and the graph data."""
    pt = emva4_linear(inp.bright, inp.dark, inp.photons, dark_exposure_s=inp.exposure_s)
    v = dict(pt.values)
    notes = list(inp.notes) + list(pt.notes)
    K = v["K"]
    if K.available:
        v["K_inv"] = Estimate(1 / K.value, K.se / K.value**2, "e-/DN", "1 / K")
    else:
        v["K_inv"] = Estimate.na(K.note, "e-/DN")
    snr = v.get("SNR_max", Estimate.na("", ""))

    def via(base: str) -> str:  # a figure scaled from one whose SE holds the gain term (gain_term) says so
        return f" (its SE {SYMBOLS[base]}'s, the gain term included)" if "the gain term" in v[base].note else ""

    v["SNR_max_inv"] = (Estimate.limit(100 / snr.value, "upper" if snr.bound == "lower" else "lower", "%",
                                       "1 / SNR_max") if snr.bound else
                        Estimate(100 / snr.value, 100 * snr.se / snr.value**2, "%", "1 / SNR_max" + via("SNR_max"))) \
        if snr.available else Estimate.na(snr.note, "%")
    area = inp.pixel_area_um2
    for key, base in (("mu_e_min_area", "mu_e_min"), ("mu_e_sat_area", "mu_e_sat")):
        e = v.get(base, Estimate.na("", "e-"))
        v[key] = (_scaled(e, 1 / area, "e-/µm²", f"{SYMBOLS[base]} / pixel area ({area:g} µm²)" + via(base)) if area
                  else Estimate.na("pixel size not given", "e-/µm²"))
    # spatial nonuniformity from the stacks (Sections 8.2, 8.3)
    sd, sb = inp.stack_dark, inp.stack_bright
    if sd is not None:
        try:
            sd.split(highpass_release)
        except ValueError as exc:  # smaller than the filter: the variances without it, said
            notes.append(f"{exc}: DSNU1288/PRNU1288 are computed without the high-pass of Section 8.1")
            highpass_release = "none"
    gt = pt.gain_term
    if sd is not None and K.available:
        dsplit = sd.split(highpass_release)
        ds = dsnu(dsplit, K.value, gt.se if gt is not None else K.se)  # in e-: K as the zero-signal gain
        v.update(attribute(ds, dsnu(dsplit, K.value, K.se), gt) if gt is not None else ds)
        v["sigma_y_stack_dark"] = _stack_sigma(sd, "temporal noise of the dark stack (Eq. 65)")
        if sb is not None:
            bsplit = sb.split(highpass_release)
            v.update(prnu(bsplit, dsplit))
            v["sigma_y_stack_50"] = _stack_sigma(sb, "temporal noise of the bright stack (Eq. 65)")
            if pt.index_sat is not None and bsplit.mean - dsplit.mean > 0:
                frac = (bsplit.mean - dsplit.mean) / v["mu_y_sat"].value
                if not 0.3 <= frac <= 0.7:
                    notes.append(f"the bright stack is at {100 * frac:.0f} % of saturation; Section 8 asks for ~50 %")
        else:
            for _, suffix in (("", ""), ("", "_col"), ("", "_row"), ("", "_pix")):
                v["PRNU1288" + suffix] = Estimate.na("no bright stack (averaged images at ~50 % saturation)", "%")
    else:
        why = "no dark stack (averaged dark images, Section 8)" if sd is None else "K not available"
        for suffix in ("", "_col", "_row", "_pix"):
            v["DSNU1288" + suffix] = Estimate.na(why, "e-")
            v["PRNU1288" + suffix] = Estimate.na(why, "%")
    # dark current (Section 7.1): a dedicated series, else the photon-transfer darks
    if inp.dark_series is not None:
        t, mu, s2 = inp.dark_series
    else:
        t = np.asarray(inp.exposure_s, float)
        mu = np.array([d.mean for d in inp.dark])
        s2 = np.array([d.var for d in inp.dark])
    v.update(dark_current_rates(dark_current_4(t, mu, s2, K), gt))
    v = judge(v, saturation=v.get("mu_e_sat"), longest_exposure_s=float(np.max(t)) if np.size(t) else None)
    curves = _curves(inp, pt, v, t, mu, s2)
    if sd is not None and "DSNU1288_DN" in v:
        curves.update(_stack_graphs(sd, sb, highpass_release, v))
    if inp.temperatures:
        curves["dark_vs_temperature"] = [(T, dark_current_4(tt, m, s, K)["mu_I_mean"])
                                         for T, tt, m, s in inp.temperatures]
    meta = dict(inp.meta)
    meta.setdefault("exposure_control", exposure_control(inp.exposure_s))  # read from the steps themselves
    return EmvaSheet("EMVA 1288 Release 4.0 Linear", v, pt, curves, notes, meta)


def _curves(inp: EmvaInput, pt: Emva4Result, v: dict, t, mu, s2) -> dict:
    order = np.argsort(np.asarray(inp.photons, float), kind="stable")
    up = np.asarray(inp.photons, float)[order]
    b = [inp.bright[i] for i in order]
    d = [inp.dark[i] for i in order]
    sig = np.array([x.mean for x in b]) - np.array([x.mean for x in d])
    var_b = np.array([x.var for x in b])
    c = {"photons": up, "signal": sig, "var": var_b - np.array([x.var for x in d]), "var_bright": var_b,
         "fit_levels": pt.fit_levels, "le_levels": pt.le_levels, "index_sat": pt.index_sat,
         "deviation_pct": pt.deviation_pct, "dark_t": np.asarray(t, float), "dark_mu": np.asarray(mu, float),
         "dark_s2": np.asarray(s2, float)}
    if inp.mean_diff is not None:  # mu[0] - mu[1] of each pair: the stability graph (Fig. 6)
        c["mean_diff"] = np.asarray(inp.mean_diff, float)[order]
    c["snr"] = np.where(var_b > 0, sig / np.sqrt(np.maximum(var_b, 1e-300)), np.nan)
    if inp.step_split is not None:
        ss = [inp.step_split[i] for i in order]
        s2_b = np.array([x[0].total for x in ss])
        c["snr_total"] = np.where(var_b + s2_b > 0, sig / np.sqrt(np.maximum(var_b + s2_b, 1e-300)), np.nan)
        for part in ("total", "col", "row", "pix"):
            c[f"step_s2_bright_{part}"] = np.array([getattr(x[0], part) for x in ss])
            c[f"step_s2_dark_{part}"] = np.array([getattr(x[1], part) for x in ss])
    K, qe = v["K"], v["QE"]
    if K.available and qe.available and v["sigma_d"].available:
        eta, k = qe.value / 100, K.value
        grid = np.geomspace(max(up[up > 0].min() / 3, 1e-3), up.max() * 1.5, 200) if np.any(up > 0) else up
        c["model_photons"] = grid
        c["snr_model"] = snr_model(grid, eta, v["sigma_d"].value, k)
        c["snr_ideal"] = np.sqrt(grid)
        ds = v.get("DSNU1288", Estimate.na(""))
        pr = v.get("PRNU1288", Estimate.na(""))
        if ds.available and pr.available:
            c["snr_total_model"] = snr_total_model(grid, eta, v["sigma_d"].value, ds.value, pr.value / 100, k)
    return c
