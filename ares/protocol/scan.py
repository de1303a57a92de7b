"""Scan definition (``scans/*.xml``) as frozen dataclasses.

``load_scan(path, system=None)`` validates the scan against ``schemas/scan.xsd``, loads
the system XML it names (or the one given), and checks every setting and sweep point
against that system's register fields and instruments before any hardware is touched.
Setting keys: the quantities ``exposure`` (s), ``light`` (photons/pixel/s or the light
source's unit), ``temperature`` (deg C), ``analog_gain`` (x), ``wavelength`` (nm, the
monochromator's), or ``reg:<field>`` for a
register field in its physical unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ares.errors import InputError
from ares.protocol import xmlsafe
from ares.protocol.quantities import unknown_limit
from ares.protocol.system import Region, System, _check_region, _region, load_system
from ares.protocol.xmlsafe import fail

QUANTITIES = ("exposure", "light", "temperature", "analog_gain", "wavelength")
MAX_STAGES = 10000
MAX_REGIONS = 256
# named options an <analysis> element may carry (attribute -> smallest value); each is an
# option beside the analysis's standard result, never a replacement (ares/protocol/FORMAT.md)
ANALYSIS_OPTIONS = {"mtf": {"esf_half_width": 4.0}}


@dataclass(frozen=True)
class Setting:
    key: str  # a quantity name or "reg:<field>"
    value: float

    @property
    def is_field(self) -> bool:
        return self.key.startswith("reg:")

    @property
    def field_name(self) -> str:
        return self.key[4:]


@dataclass(frozen=True)
class Axis:
    key: str
    kind: str  # "values", "linear" or "log"
    values: tuple[float, ...] = ()
    start: float | None = None
    stop: float | None = None
    points: int | None = None
    order: str = "given"  # "shuffled": the points taken in a fixed random order (``seed``), not as written
    seed: int = 1

    def grid(self) -> tuple[float, ...]:
        if self.kind == "values":
            g = self.values
        elif self.kind == "linear":
            g = tuple(float(v) for v in np.linspace(self.start, self.stop, self.points))
        else:
            g = tuple(float(v) for v in np.geomspace(self.start, self.stop, self.points))
        if self.order == "shuffled":  # a drift on the bench's clock then no longer follows the axis
            g = tuple(g[i] for i in shuffled_order(g, self.seed))
        return g


SHUFFLE_DRAWS = 200


def shuffled_order(values, seed: int) -> np.ndarray:
    """A fixed random order of ``values`` (``seed``) that a drift in time does not follow: of
    ``SHUFFLE_DRAWS`` seeded permutations, the one whose values' ranks correlate least with their
    position in the run, linearly and quadratically (a straight or a curved drift: a warm-up).
    A plain random order can follow the clock by chance (8 points: r^2 0.6 for 1 seed in 5)."""
    n = len(values)
    rng = np.random.default_rng(seed)
    if n < 3:
        return rng.permutation(n)
    pos = np.arange(n) - (n - 1) / 2
    basis = [pos / np.linalg.norm(pos)]
    q = pos**2 - np.mean(pos**2)
    basis.append(q / np.linalg.norm(q))
    rank = np.argsort(np.argsort(np.asarray(values, float), kind="stable"), kind="stable") - (n - 1) / 2
    best, score = None, math.inf
    for _ in range(SHUFFLE_DRAWS):
        p = rng.permutation(n)
        r = rank[p] / np.linalg.norm(rank)
        c = max(abs(float(r @ b)) for b in basis)
        if c < score:
            best, score = p, c
    return best


@dataclass(frozen=True)
class StageSpec:
    name: str
    scene: str  # "dark" or "flat"
    frames: int | None = None  # None: the scan's <frames>
    dark: str = "none"  # "matched": also grab a dark stack at the same settings (before the flat); "after": after it
    dark_frames: int | None = None
    settings: tuple[Setting, ...] = ()
    axes: tuple[Axis, ...] = ()  # empty: one stage; 1 or 2 axes: a sweep (first axis outermost)
    sweep: bool = False


@dataclass(frozen=True)
class Limit:
    quantity: str
    min: float | None = None
    max: float | None = None

    def check(self, value: float) -> bool:
        if value is None or not math.isfinite(value):
            return False
        return (self.min is None or value >= self.min) and (self.max is None or value <= self.max)

    def bounds(self) -> str:
        """``>= 0.25 and <= 0.31``: the limit's range in words (messages, table headers)."""
        return " and ".join(x for x in (f">= {self.min:g}" if self.min is not None else "",
                                        f"<= {self.max:g}" if self.max is not None else "") if x)


def _precision(el, path, analyses) -> Precision | None:
    if el is None:
        return None
    targets = []
    for t in el.iterfind("target"):
        rel, ab = t.get("rel"), t.get("abs")
        if (rel is None) == (ab is None):
            raise fail(path, t.sourceline, f"target for '{t.get('quantity')}' needs exactly one of rel= or abs=")
        why = unknown_limit(t.get("quantity"), analyses)
        if why:
            raise fail(path, t.sourceline, why.replace("limit", "precision target", 1))
        targets.append(Target(t.get("quantity"), None if rel is None else float(rel), None if ab is None else float(ab)))
    p = Precision(tuple(targets), int(el.get("budget")), int(el.get("pilot", 3)), float(el.get("confidence", 0.95)),
                  float(el.get("se_cv", 0.1)))
    if p.pilot > p.budget:
        raise fail(path, el.sourceline, f"<precision pilot='{p.pilot}'> is above its budget of {p.budget} frames")
    return p


def parse_limit(el, path) -> Limit:
    """A ``<limit quantity= min= max=>`` element (scan and lot files), checked: at least one
    bound, min not above max; errors name the file and line."""
    lo, hi = el.get("min"), el.get("max")
    if lo is None and hi is None:
        raise fail(path, el.sourceline, f"limit on '{el.get('quantity')}' needs min= or max=")
    lim = Limit(el.get("quantity"), None if lo is None else float(lo), None if hi is None else float(hi))
    if lim.min is not None and lim.max is not None and lim.min > lim.max:
        raise fail(path, el.sourceline, f"limit on '{lim.quantity}': min {lim.min:g} is above max {lim.max:g}")
    return lim


@dataclass(frozen=True)
class Target:
    """``<target quantity rel|abs>``: the SE a figure must reach (relative or absolute)."""

    quantity: str
    rel: float | None = None
    abs: float | None = None

    def wanted(self, value: float) -> float:
        """The SE this target asks for at an estimate ``value``."""
        return self.abs if self.abs is not None else self.rel * abs(value)

    def text(self) -> str:
        return f"{100 * self.rel:g} %" if self.rel is not None else f"{self.abs:g}"


@dataclass(frozen=True)
class Precision:
    """``<precision budget pilot confidence se_cv>``: frames per stage from the targets
    (``ares.scan.precision``) instead of fixed counts."""

    targets: tuple[Target, ...]
    budget: int
    pilot: int = 3
    confidence: float = 0.95
    se_cv: float = 0.1  # relative spread of an estimated SE (sets the safety margin)


@dataclass(frozen=True)
class Suspend:
    """``<suspend>``: conditions that pause acquisition (ares.scan.suspend)."""
    conditions: tuple[tuple[str, float], ...]  # (quantity, tolerance): temperature in C, light as a fraction
    poll_s: float = 1.0
    hold_s: float = 0.0
    timeout_s: float = 600.0
    max_recoveries: int = 5  # pauses of one stage before the run fails (a device that keeps failing)


@dataclass(frozen=True)
class Output:
    raw_frames: bool = False
    hdf5: bool = True
    csv: bool = True
    pdf: bool = True  # every run writes its report unless the scan turns it off


@dataclass(frozen=True)
class Scan:
    name: str
    system_href: str
    frames: int
    stages: tuple[StageSpec, ...]
    system: System = field(compare=False, repr=False, default=None)
    version: int = 1
    description: str = ""
    settings: tuple[Setting, ...] = ()
    regions: tuple[Region, ...] = ()
    on_loss: str = "fail"  # <frames on_loss>: "regrab" re-acquires a stage that lost frames
    max_regrabs: int = 2
    precision: Precision | None = None
    analyses: tuple[str, ...] = ()
    analysis_options: tuple[tuple[str, str, float], ...] = ()  # (analysis, option, value), ANALYSIS_OPTIONS
    defects: tuple[tuple[str, float], ...] = ()
    limits: tuple[Limit, ...] = ()
    defect_mask: str | None = None  # <defects mask=...>: a file relative to the scan
    output: Output = Output()
    suspend: Suspend | None = None
    source: Path | None = field(default=None, compare=False)
    system_path: Path | None = field(default=None, compare=False)

    def option(self, analysis: str, name: str, default=None):
        """The value of ``<analysis name=analysis name=value>``, or ``default``."""
        return next((v for a, k, v in self.analysis_options if a == analysis and k == name), default)


# ---------------------------------------------------------------- loading

def _setting_key(path, el) -> str:
    q, f = el.get("quantity"), el.get("field")
    if (q is None) == (f is None):
        raise fail(path, el.sourceline, f"<{el.tag}> needs exactly one of quantity= or field=")
    return q if q is not None else f"reg:{f}"


def _settings(path, parent) -> tuple[Setting, ...]:
    out, seen = [], set()
    for el in parent.iterfind("set"):
        key = _setting_key(path, el)
        if key in seen:
            raise fail(path, el.sourceline, f"'{key.removeprefix('reg:')}' is set twice")
        seen.add(key)
        out.append(Setting(key, float(el.get("value"))))
    return tuple(out)


def _axis(path, el) -> Axis:
    key = _setting_key(path, el)
    order = dict(order=el.get("order", "given"), seed=int(el.get("seed", 1)))
    if el.get("seed") is not None and order["order"] != "shuffled":
        raise fail(path, el.sourceline, f"sweep axis '{key.removeprefix('reg:')}': seed= orders the points only "
                                        "with order=\"shuffled\"")
    v = el.find("values")
    if v is not None:
        vals = tuple(float(x) for x in (v.text or "").split())
        if not vals:
            raise fail(path, v.sourceline, f"sweep axis '{key.removeprefix('reg:')}' has no points")
        return Axis(key, "values", vals, **order)
    r = el.find("linear")
    kind = "linear" if r is not None else "log"
    r = r if r is not None else el.find("log")
    a = Axis(key, kind, (), float(r.get("start")), float(r.get("stop")), int(r.get("points")), **order)
    if kind == "log" and (a.start <= 0 or a.stop <= 0):
        raise fail(path, r.sourceline, f"<log> sweep of '{key.removeprefix('reg:')}' needs start and stop > 0, "
                                       f"got {a.start:g} and {a.stop:g}")
    return a


class _Checker:
    """Checks setting values against the system (fields, limits, instruments)."""

    def __init__(self, path, system: System):
        self.path, self.system = path, system
        self._params = None

    def sim_range(self, key: str, value: float) -> str | None:
        """The simulator's physical range of ``key`` (``ares.sim.ranges``), from its parameters."""
        from ares.sim.from_system import sim_params
        from ares.sim.ranges import setting_problem

        if self._params is None:
            self._params = sim_params(self.system)
        return setting_problem(key, value, self._params.full_well_e, self._params.qe)

    def __call__(self, el, key: str, value: float) -> None:
        sy, line = self.system, el.sourceline
        if not math.isfinite(value):
            raise fail(self.path, line, f"'{key}' must be a finite number, got {value}")
        if key.startswith("reg:"):
            name = key[4:]
            if name not in sy.registers.names():
                raise fail(self.path, line, f"unknown register field '{name}' (system '{sy.name}' has: "
                                            f"{', '.join(sy.registers.names())})")
            f = sy.registers.field(name)
            if f.access == "ro":
                raise fail(self.path, line, f"register field '{name}' is read-only and cannot be set")
        elif key in ("exposure", "analog_gain"):
            f = sy.control_field(key)
            if f is None:
                raise fail(self.path, line, f"system '{sy.name}' declares no register field for {key} "
                                            f"(add <controls {key}=...>)")
        elif key == "light":
            f = None
            if value < 0:
                raise fail(self.path, line, f"light level must be >= 0, got {value:g}")
            ls = sy.light_source
            if ls is None and sy.simulator is None:
                raise fail(self.path, line, f"system '{sy.name}' has no light source")
            if ls is not None and ls.max is not None and value > ls.max:
                raise fail(self.path, line, f"light level {value:g} is above the light source's maximum {ls.max:g}")
        elif key == "wavelength":
            f = None
            mo = sy.monochromator
            if mo is None:
                raise fail(self.path, line, f"system '{sy.name}' has no monochromator to set {value:g} nm")
            if (mo.min is not None and value < mo.min) or (mo.max is not None and value > mo.max) or value <= 0:
                from ares.hardware.serial_instruments import range_text

                raise fail(self.path, line, f"wavelength {value:g} nm is outside the monochromator's range "
                                            f"{range_text(mo.min, mo.max, 'nm')}")
        else:  # temperature
            f = None
            ch = sy.chamber
            if ch is None and sy.simulator is None:
                raise fail(self.path, line, f"system '{sy.name}' has no thermal chamber")
            if ch is not None and ((ch.min is not None and value < ch.min) or (ch.max is not None and value > ch.max)):
                from ares.hardware.serial_instruments import range_text

                raise fail(self.path, line, f"temperature {value:g} C is outside the chamber's range "
                                            f"{range_text(ch.min, ch.max, 'C')}")
        if sy.simulator is not None and key in ("light", "temperature"):
            why = self.sim_range(key, value)
            if why:
                raise fail(self.path, line, why)
        if f is not None:
            try:
                f.to_raw(value)
            except InputError as exc:
                raise fail(self.path, line, str(exc)) from None


def scan_from_tree(tree, path, system: System | None = None, system_path=None) -> Scan:
    root = tree.getroot()
    sys_el = root.find("system")
    href = sys_el.get("href")
    if system is None:
        from_href = system_path is None
        if from_href:
            system_path = Path(path).parent / href
        if not Path(system_path).is_file():
            raise fail(path, sys_el.sourceline, f"system file '{href}' not found (looked for {system_path})")
        try:
            system = load_system(system_path)
        except xmlsafe.WrongRoot as exc:  # (a scan named as its own or another scan's system)
            if not from_href:
                raise
            what = xmlsafe.KINDS.get(exc.found, "a file")
            raise fail(path, sys_el.sourceline, f"<system href='{href}'> names {what} (root element <{exc.found}>), "
                                                "not a system file (root element <system>)") from None
    check = _Checker(path, system)
    settings = _settings(path, root.find("settings")) if root.find("settings") is not None else ()
    for el, s in zip(root.iterfind("settings/set"), settings):
        check(el, s.key, s.value)
    stages, total = [], 0
    for el in root.find("stages"):
        if not isinstance(el.tag, str):
            continue
        st_settings = _settings(path, el)
        for sel, s in zip(el.iterfind("set"), st_settings):
            check(sel, s.key, s.value)
        axes = tuple(_axis(path, a) for a in el.iterfind("axis"))
        if len(axes) == 2 and axes[0].key == axes[1].key:
            raise fail(path, el.sourceline, f"sweep '{el.get('name')}' sweeps '{axes[0].key.removeprefix('reg:')}' on both axes")
        n = 1
        for a_el, a in zip(el.iterfind("axis"), axes):
            if a.key in {s.key for s in st_settings}:
                raise fail(path, a_el.sourceline, f"'{a.key.removeprefix('reg:')}' is both set and swept in '{el.get('name')}'")
            for v in a.grid():
                check(a_el, a.key, v)
            n *= len(a.grid())
        total += n
        scene, dark = el.get("scene"), el.get("dark", "none")
        if scene == "dark" and dark != "none":
            raise fail(path, el.sourceline, f"stage '{el.get('name')}': dark='{dark}' only applies to a flat scene")
        if scene == "dark" and any(a.key == "light" for a in axes):
            raise fail(path, el.sourceline, f"stage '{el.get('name')}' is dark but sweeps the light level")
        fr, dfr = el.get("frames"), el.get("dark_frames")
        stages.append(StageSpec(el.get("name"), scene, int(fr) if fr else None, dark, int(dfr) if dfr else None,
                                st_settings, axes, el.tag == "sweep"))
    if total > MAX_STAGES:
        raise fail(path, root.find("stages").sourceline, f"scan expands to {total} stages (at most {MAX_STAGES})")
    regions = []
    for el in root.iterfind("regions/region"):
        r = _region(el)
        _check_region(path, el, r, system.sensor.rows, system.sensor.cols, "region")
        regions.append(r)
    if len(regions) > MAX_REGIONS:
        raise fail(path, root.find("regions").sourceline, f"{len(regions)} regions of analysis (at most {MAX_REGIONS}; "
                                                          "each is accumulated on every frame)")
    analyses = tuple(el.get("name") for el in root.iterfind("analyses/analysis"))
    analysis_options = _analysis_options(path, root)
    limits = []
    for el in root.iterfind("limits/limit"):
        lim = parse_limit(el, path)
        why = unknown_limit(lim.quantity, analyses)
        if why:
            raise fail(path, el.sourceline, why)
        limits.append(lim)
    precision = _precision(root.find("precision"), path, analyses)
    de = root.find("defects")
    if de is not None:
        from ares.analysis.defects import DefectThresholds  # the parser the analysis uses: what validates runs

        for el in de.iterfind("threshold"):
            try:
                DefectThresholds.from_attrs({el.get("name"): el.get("value")}, where="<defects>")
            except InputError as exc:
                raise fail(path, el.sourceline, str(exc)) from None
        try:  # and together (ordering constraints between thresholds)
            DefectThresholds.from_attrs({el.get("name"): el.get("value") for el in de.iterfind("threshold")},
                                        where="<defects>")
        except InputError as exc:
            raise fail(path, de.sourceline, str(exc)) from None
    if de is not None and de.get("mask") is not None:
        mp = Path(path).parent / de.get("mask")
        if not mp.is_file():
            raise fail(path, de.sourceline, f"defect mask {de.get('mask')!r} is not a file ({mp})")
    su = root.find("suspend")
    suspend = None
    if su is not None:
        conds = tuple((c.get("quantity"), float(c.get("tolerance", 0))) for c in su.iterfind("condition"))
        for c, (q, _) in zip(su.iterfind("condition"), conds):
            if q != "device" and c.get("tolerance") is None:
                raise fail(path, c.sourceline, f"a {q} condition needs tolerance=")
            if q == "temperature" and system.chamber is None and system.simulator is None:
                raise fail(path, c.sourceline, f"a temperature condition needs a thermal chamber (system '{system.name}' "
                                               "has none)")
            if q == "light" and system.light_source is None and system.simulator is None:
                raise fail(path, c.sourceline, f"a light condition needs a light source (system '{system.name}' has none)")
        suspend = Suspend(conds, float(su.get("poll_s", 1)), float(su.get("hold_s", 0)), float(su.get("timeout_s", 600)),
                          int(su.get("max_recoveries", 5)))
    out = root.find("output")
    output = Output() if out is None else Output(
        *(out.get(k, d) in ("true", "1") for k, d in
          (("raw_frames", "false"), ("hdf5", "true"), ("csv", "true"), ("pdf", "true"))))
    desc = root.find("description")
    return Scan(
        name=root.get("name"), version=int(root.get("version", 1)), system_href=href,
        description=(desc.text or "").strip() if desc is not None else "",
        frames=int(root.findtext("frames")), on_loss=root.find("frames").get("on_loss", "fail"),
        max_regrabs=int(root.find("frames").get("max_regrabs", 2)), precision=precision, settings=settings, stages=tuple(stages), regions=tuple(regions),
        analyses=analyses, analysis_options=analysis_options, defects=tuple((el.get("name"), float(el.get("value"))) for el in root.iterfind("defects/threshold")),
        limits=tuple(limits), output=output, suspend=suspend, system=system, source=Path(path),
        defect_mask=root.find("defects").get("mask") if root.find("defects") is not None else None,
        system_path=Path(system_path) if system_path else system.source,
    )


def _analysis_options(path, root) -> tuple[tuple[str, str, float], ...]:
    """The named options of the ``<analysis>`` elements (ANALYSIS_OPTIONS), each checked."""
    out = []
    for el in root.iterfind("analyses/analysis"):
        name, known = el.get("name"), ANALYSIS_OPTIONS.get(el.get("name"), {})
        for k, v in el.attrib.items():
            if k == "name":
                continue
            if k not in known:
                raise fail(path, el.sourceline, f"<analysis name=\"{name}\"> has no option {k}= "
                                                f"({', '.join(known) or 'it takes none'})")
            try:
                x = float(v)
            except ValueError:
                x = math.nan
            if not (math.isfinite(x) and x >= known[k]):
                raise fail(path, el.sourceline, f"<analysis name=\"{name}\"> {k}={v!r}: give a number of at least "
                                                f"{known[k]:g}")
            out.append((name, k, x))
    return tuple(out)


def load_scan(path: str | Path, system: System | None = None, system_path: str | Path | None = None) -> Scan:
    """Load and check a scan XML and its system (or ``system``/``system_path`` instead of its href)."""
    tree = xmlsafe.load(path, "scan")
    if system is None and system_path is not None and not Path(system_path).is_file():
        from ares.safefile import not_a_file

        raise not_a_file(system_path, "system file")
    return scan_from_tree(tree, path, system, system_path)


# ---------------------------------------------------------------- saving
