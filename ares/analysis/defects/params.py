"""Every defect threshold and pass/fail limit, as one frozen dataclass.

Defaults follow ``SCIENCE.md`` (section Defects) and EMVA 1288 4.0 practice; each one is a
named field so a scan XML ``<defects hot_e_per_s="5" max_hot="100" .../>`` can set it
through :meth:`DefectThresholds.from_attrs`.

Class definitions (a pixel is compared with the robust statistics of its own region and
channel; "z" is a robust z-score, sigma = 1.4826 * MAD):

* hot / warm -- with gain K and exposure t: the pixel's dark signal in excess of its
  row and column (medians) divided by K*t, i.e. its dark rate above the typical pixel's,
  above ``hot_e_per_s`` (5 e-/s, SCIENCE.md) / ``warm_e_per_s`` (1 e-/s), AND significant
  (robust z > ``warm_z``); without K or t: robust z of the averaged dark above ``hot_z``
  (20) / ``warm_z`` (4.8). ``warm_z`` = 4.8 is the detectability floor (a Gaussian
  population gives < 1 false alarm per megapixel there); a pixel is reliably (99 %)
  found when its excess is ~2.3 sigma above max(threshold rate * K * t, 4.8 sigma).
  With several dark levels a pixel is confirmed when flagged in >= ``confirm_fraction``
  (70 %) of them (hot in too few levels but hot-or-warm in enough -> warm). A hot/warm
  claim also needs a series a steady dark rate shows (``steady.py``, 1 % of true ones lost):
  with K its temporal variance neither above nor below the population's plus its own shot
  noise, and no telegraph; a pixel that fails it and takes no other class is
  "unclassified" -- in the defect mask, in no class.
* dead / low-response / high-response -- dark-subtracted flat response divided by the
  local response (medians of ``background_block_px``-square tiles, bilinearly
  interpolated): below ``dead_fraction`` (0.5) is dead, below ``low_response_fraction``
  (0.8, SCIENCE.md) low-response, above ``high_response_fraction`` (1.2) high-response
  ("bright"); the deviation must also exceed ``warm_z`` times the noise of the averaged
  flat and dark, so a weak flat cannot create defects. 0.5 splits "barely responds"
  from "responds noticeably less", the two cases a user corrects differently.
* stuck -- no temporal variation: per-pixel temporal variance below ``stuck_var_dn2``
  (1/12 DN^2, the quantization floor) and below the chi-square lower limit of the
  population in the darks, or below ``stuck_var_dn2`` in a flat while responding less
  than ``stuck_response_dn`` to the light (identical codes at every level); with a flat
  whose shot noise makes equal codes improbable, stuck needs the flat's evidence too (a
  quiet pixel repeating its dark code that follows the light is not stuck). A pixel with
  no response but ordinary temporal noise is dead, not stuck.
* noisy -- per-pixel temporal variance s2 fails a chi-square test with F-1 degrees of
  freedom against the robust population variance (median / chi2 median) at false-alarm
  probability ``noisy_p_fa`` per pixel (1e-7: 0.1 false alarms per megapixel, leaving
  room in a 1-per-megapixel budget); with K known the expected variance of a pixel
  includes the shot noise of its excess dark signal (K * excess DN), so hot pixels are
  not also noisy. What "noisy" asserts: the pixel's temporal noise is significantly above
  the population's -- white excess noise, or a telegraph these frames do not resolve (an
  RTS trap raises the temporal noise too; where the time order shows the telegraph the
  pixel is rts instead). With K, a hot/warm pixel that is noisy beyond its own shot noise
  and no telegraph is noisy, not hot/warm (no steady rate). Without K a pixel's dark shot
  noise cannot be told from excess read noise, so a warm pixel may be noisy too. With K a
  noisy claim also needs a variance above the shot noise of the largest dark signal its
  measured excess does not rule out (a negative offset hides part of one: ``steady.py``);
  below it -- a quiet sensor's weak noisy pixel, or a dark signal under the averaged dark's
  noise -- the data cannot tell the two and the pixel is "unclassified".
* rts -- multi-level temporal behaviour: a candidate (hot, warm, noisy, or a temporal
  variance above the chi-square limit at p = ``rts_p_fa``) whose time series splits into
  two levels separated by at least ``rts_min_separation`` (4) times the within-level noise
  AND by more than a single-level Gaussian series of that many frames shows with
  probability ``rts_p_fa`` (1e-3; ``rts.null_separation``: 5.9 at 16 frames, 3.4 at 100),
  each level holding at least ``rts_min_occupancy`` (3 %) of the frames; needs >=
  ``rts_min_frames`` (12) frames, else RTS is "not available, needs >= 12 frames"; or a
  noisy, hot or warm pixel whose series is a telegraph by the likelihood ratio of a
  two-state hidden Markov model against one Gaussian beyond a white series at p = 1e-3
  (``rts.telegraph_lr``, its null measured: ``benchmarks/defect_hmm_null.md``) -- levels
  that overlap, or a trap mostly in one level. A noisy pixel is one whose variance is high
  WITHOUT such a telegraph, a hot pixel one whose mean dark rate is high: RTS takes
  precedence over both.
* bad columns / rows -- >= ``line_hot_count`` (20) hot/warm or >= ``line_dead_count``
  (100) dead/low-response/stuck pixels in the line, or a line's median dark offset or
  median response more than ``line_z`` (6) robust sigmas from its neighbours, or its
  median temporal variance both ``line_z`` sigmas and ``line_noise_factor`` (1.5x) above
  the expected (see ``lines.py``; the noise test needs ``line_noise_min_frames`` (16)
  dark frames: over fewer a line's own row/column temporal noise swings its variance). Pixel classes inside a bad line are judged against
  the line's own level, so a bad column is one bad column, not 480 bad pixels.
* detection limits -- ``max_false_alarm`` (1e-5 per pixel), ``noisy_detect_ratio`` (10x
  the population variance), ``rate_detect_factor`` (hot/warm: a pixel at 2x the class's
  rate threshold is found with 99 %, else the class is not available and the exposure it
  needs is named; with several dark exposures the rate is the slope over them --
  between that and ``rate_partial_factor`` (10x the threshold) the class keeps the pixels it
  finds, its count "incomplete", a lower bound; beyond, what a single exposure finds is the
  far tail, where offsets that are no rate (a trap held high) outnumber dark current) and
  ``max_plausible_fraction`` (1 %): see ``limits.py``; a
  class that cannot meet them at the data's frame count is not available, with the reason.
* clusters -- 8-connected groups of >= ``cluster_min_size`` defective pixels.
* pass/fail -- ``max_<class>`` (and ``max_bad_columns``, ``max_clusters``,
  ``max_cluster_size``, ``max_total``) fail when the count exceeds them; a limit on
  ``rts`` fails when RTS is not available (the count is unknown, not zero).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Mapping

from ares.errors import InputError

#: pass/fail limit fields (max count per class); None = no limit
LIMIT_FIELDS = (
    "max_hot", "max_warm", "max_dead", "max_low_response", "max_high_response",
    "max_stuck", "max_noisy", "max_rts", "max_bad_columns", "max_bad_rows",
    "max_clusters", "max_cluster_size", "max_total",
)


@dataclass(frozen=True)
class DefectThresholds:
    # hot / warm (dark signal)
    hot_e_per_s: float = 5.0
    warm_e_per_s: float = 1.0
    hot_z: float = 20.0
    warm_z: float = 4.8
    confirm_fraction: float = 0.7
    # response (flat minus dark) relative to the local median response
    dead_fraction: float = 0.5
    low_response_fraction: float = 0.8
    high_response_fraction: float = 1.2
    background_block_px: int = 16
    # stuck
    stuck_var_dn2: float = 1.0 / 12.0
    stuck_response_dn: float = 0.5
    # noisy (chi-square, F-1 dof)
    noisy_p_fa: float = 1e-7
    # detection limits (limits.py): a class is not available where a normal pixel is
    # flagged with probability > max_false_alarm, or a noisy_detect_ratio-times noisy
    # pixel is missed; a class holding > max_plausible_fraction of the array is warned of
    max_false_alarm: float = 1e-5
    noisy_detect_ratio: float = 10.0
    rate_detect_factor: float = 2.0
    rate_partial_factor: float = 10.0
    max_plausible_fraction: float = 0.01
    # random telegraph signal
    rts_min_frames: int = 12
    rts_min_separation: float = 4.0
    rts_min_occupancy: float = 0.03
    rts_p_fa: float = 1e-3
    # lines
    line_hot_count: int = 20
    line_dead_count: int = 100
    line_z: float = 6.0
    line_noise_factor: float = 1.5
    line_noise_min_frames: int = 16
    # clusters
    cluster_min_size: int = 2
    # pass/fail limits (max counts); None means "no limit"
    max_hot: int | None = None
    max_warm: int | None = None
    max_dead: int | None = None
    max_low_response: int | None = None
    max_high_response: int | None = None
    max_stuck: int | None = None
    max_noisy: int | None = None
    max_rts: int | None = None
    max_bad_columns: int | None = None
    max_bad_rows: int | None = None
    max_clusters: int | None = None
    max_cluster_size: int | None = None
    max_total: int | None = None

    def rules(self) -> dict[str, str]:
        """The rule that puts a pixel in each class, with these thresholds (the criterion a
        defect table shows next to each count)."""
        return {
            "hot": f"dark rate (the slope over the exposures when there are several) > {self.hot_e_per_s:g} e-/s, "
                   f"> {self.warm_z:g} sigma above the local background (without K: > {self.hot_z:g} sigma)",
            "warm": f"dark rate > {self.warm_e_per_s:g} e-/s and > {self.warm_z:g} sigma (not hot)",
            "dead": f"flat response < {self.dead_fraction:g} x the local median",
            "low_response": f"flat response < {self.low_response_fraction:g} x the local median (not dead)",
            "high_response": f"flat response > {self.high_response_fraction:g} x the local median",
            "stuck": f"temporal variance < {self.stuck_var_dn2:.3g} DN^2 and response < {self.stuck_response_dn:g} DN",
            "noisy": f"temporal variance above the chi-square limit at p = {self.noisy_p_fa:g}",
            "rts": f"two or more levels >= {self.rts_min_separation:g} sigma apart, each >= "
                   f"{100 * self.rts_min_occupancy:g} % of >= {self.rts_min_frames} frames",
            "bad_columns": f">= {self.line_hot_count} hot or {self.line_dead_count} dead pixels, or a mean "
                           f"> {self.line_z:g} sigma off, or noise > {self.line_noise_factor:g} x",
            "bad_rows": f">= {self.line_hot_count} hot or {self.line_dead_count} dead pixels, or a mean "
                        f"> {self.line_z:g} sigma off, or noise > {self.line_noise_factor:g} x",
            "unclassified": "a significant dark excess that is no steady dark rate, or a raised temporal noise a "
                            "hidden dark signal's shot noise could give; clears no other class's test",
            "clusters": f">= {self.cluster_min_size} defective pixels touching",
            "total": "every defective pixel, each counted once",
        }

    def __post_init__(self) -> None:
        def bad(name: str, why: str) -> InputError:
            return InputError(f"defect parameter {name}={getattr(self, name)!r} {why}")

        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is None and f.name in LIMIT_FIELDS:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise bad(f.name, "is not a finite number")
            if v < 0:
                raise bad(f.name, "must not be negative")
            if _is_int_field(f) and not isinstance(v, int):
                if not float(v).is_integer():
                    raise bad(f.name, "must be a whole number")
                object.__setattr__(self, f.name, int(v))  # 20.0 from an XML float -> 20
        if self.rate_detect_factor < 1:
            raise bad("rate_detect_factor", "must be at least 1")
        if self.noisy_detect_ratio < 1:
            raise bad("noisy_detect_ratio", "must be at least 1")
        for name in ("confirm_fraction", "noisy_p_fa", "rts_p_fa", "rts_min_occupancy", "max_false_alarm",
                     "max_plausible_fraction"):
            if not 0 < getattr(self, name) <= 1:
                raise bad(name, "must be in (0, 1]")
        if not 0 <= self.dead_fraction <= self.low_response_fraction <= 1 <= self.high_response_fraction:
            raise InputError(
                "defect parameters must satisfy 0 <= dead_fraction <= low_response_fraction <= 1 "
                f"<= high_response_fraction (got {self.dead_fraction}, {self.low_response_fraction}, "
                f"{self.high_response_fraction})")
        if self.warm_e_per_s > self.hot_e_per_s or self.warm_z > self.hot_z:
            raise InputError("defect parameters warm_e_per_s and warm_z must not exceed hot_e_per_s and hot_z")
        if self.rts_min_frames < 3:
            raise bad("rts_min_frames", "must be at least 3")
        if self.line_noise_factor < 1:
            raise bad("line_noise_factor", "must be at least 1")
        if self.background_block_px < 3:
            raise bad("background_block_px", "must be at least 3")

    @classmethod
    def from_attrs(cls, attrs: Mapping[str, object], where: str = "defects") -> "DefectThresholds":
        """Build from XML attribute values (strings or numbers); unknown names are an error."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        kwargs: dict[str, object] = {}
        for name, raw in attrs.items():
            if name not in fields:
                known = ", ".join(sorted(fields))
                raise InputError(f"{where}: unknown defect parameter {name!r} (known: {known})")
            kwargs[name] = _convert(name, raw, where, integer=_is_int_field(fields[name]))
        return cls(**kwargs)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    def limits(self) -> dict[str, int]:
        """The set pass/fail limits, keyed by the counted class (``max_hot`` -> ``hot``)."""
        return {n.removeprefix("max_"): getattr(self, n) for n in LIMIT_FIELDS if getattr(self, n) is not None}


def _is_int_field(f: dataclasses.Field) -> bool:
    return str(f.type).startswith("int")


def _convert(name: str, raw: object, where: str, integer: bool) -> float | int | None:
    if isinstance(raw, str):
        text = raw.strip()
        if name in LIMIT_FIELDS and text.lower() in ("", "none"):
            return None
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"{where}: defect parameter {name}={raw!r} is not a number") from None
    elif isinstance(raw, (int, float)) and not isinstance(raw, bool):
        value = float(raw)
    elif raw is None and name in LIMIT_FIELDS:
        return None
    else:
        raise InputError(f"{where}: defect parameter {name}={raw!r} is not a number")
    if integer:
        if not value.is_integer():
            raise InputError(f"{where}: defect parameter {name}={raw!r} must be a whole number")
        return int(value)
    return value
