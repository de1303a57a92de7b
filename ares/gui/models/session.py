"""The whole window's state as plain models, fed by engine events (no Qt).

``SessionModel.handle(event)`` is the only entry point the worker's events reach; each
Qt view subscribes to one sub-model. Tests drive this class directly, without a GUI.
"""

from __future__ import annotations

import logging
import math
import time

import numpy as np

from ares.labels import FIGURES, HEADLINE_FIGURES, PTC_FIGURES
from ares.gui.events import (Done, Ending, Failed, FramePreview, Health, Progress, ReportsWritten, RunInfo, StageResult,
                             StageStarted, Stopped)
from ares.gui.models import progress as P
from ares.gui.models.components import ComponentsModel
from ares.gui.models.defects import DefectCountsModel
from ares.gui.models.image import ImageModel
from ares.gui.models.observable import Observable
from ares.gui.models.profiles import ProfilesModel
from ares.gui.models.ptc import PTCModel
from ares.gui.models.regions import Region, RegionSet, full_frame
from ares.gui.models.stats import StatsPanelModel
from ares.gui.models.sweep import SweepModel, SweepPoint
from ares.gui.models.views import StageStore, ViewModel

log = logging.getLogger(__name__)

PANELS = ("MEAN SIGNAL", "NOISE", "COLUMNS", "ROWS")
# Result tabs whose models are computed only while the tab is shown (the window says
# which with ``set_visible``); a hidden one is brought up to date when it is shown.
RESULTS, DISTRIBUTIONS, PROFILES, SIGNAL_MAP, NOISE_MAP = (
    "Results", "Pixel Distributions", "Profiles", "Signal Map", "Noise Map")
LAZY_TABS = (RESULTS, DISTRIBUTIONS, PROFILES, SIGNAL_MAP, NOISE_MAP)
# While a scan runs, a shown tab is recomputed at most every REFRESH_S, and the newest stage
# reaches the tabs at most every RESULTS_S -- each drawing costs the scan a few tens of ms of
# the shared cores and, being Python, holds the interpreter the scan's threads share (the
# newest stage or frame wins; ``flush`` catches up, and the scan's end draws everything at
# once). Measured on make run's scan (benchmarks/gui.md, 5 pairs each): GUI/headless 1.13
# with the newest stage every 1 s, 1.05 every 2 s, 1.02 every 3 s. A real sensor's stage
# takes longer than that: every stage is still shown as it ends.
REFRESH_S = 1.0
RESULTS_S = 3.0


def headline_key(label: str, component: str | None = None, unit: str | None = None) -> str:
    """The Information tab's name of a headline figure: ``PTC: <label>`` for a photon-transfer
    figure of ``labels.PTC_FIGURES`` (the label alone where it already starts with "PTC"), ``<name>, <unit>`` for the others of
    ``labels.HEADLINE_FIGURES`` (DSNU in e- and in DN), ``<meaning> [<symbol>]`` for a component."""
    if component:
        return f"{label} [{component}]"
    if unit is not None:
        return f"{label}, {unit}" if unit else label
    return label if label.startswith("PTC") else f"PTC: {label}"


# the unit each headline figure after the photon-transfer ones is stated in
HEADLINE_UNITS = {"snr_max_emva": "", "snr_max": "", "dsnu_e": "e-", "dsnu_dn": "DN", "dsnu_all_e": "e-", "dsnu_all_dn": "DN",
                  "prnu_pct": "% rms", "prnu_all_pct": "% rms"}


def figure_key(key: str, name: str) -> str:
    """The Information tab's row name of headline figure ``key`` (named ``name``)."""
    return headline_key(name, unit=HEADLINE_UNITS[key]) if key in HEADLINE_UNITS else headline_key(name)


# The headline figures, in the terminal's order (ares.commands.run_summary.print_headline): they head
# the Information tab, above the versions, the scan and the run directory.
HEADLINE = tuple(headline_key(label) for _, label in PTC_FIGURES) + tuple(
    figure_key(k, FIGURES[k][0]) for k in HEADLINE_FIGURES)


class InfoModel(Observable):
    def __init__(self) -> None:
        super().__init__()
        self.items: dict[str, str] = {}

    def ordered(self) -> list[tuple[str, str]]:
        """The items, the headline figures first (in ``HEADLINE``'s order), then the rest as added."""
        rank = {k: i for i, k in enumerate(HEADLINE)}
        head = sorted((k for k in self.items if k in rank), key=rank.__getitem__)
        return [(k, self.items[k]) for k in head] + [(k, v) for k, v in self.items.items() if k not in rank]

    def replace(self, mapping: dict) -> None:
        self.items = {str(k): str(v) for k, v in mapping.items()}
        self._changed()

    def update(self, mapping: dict | None = None, **items) -> None:
        """Add or replace items; keyword names use ``_`` for spaces."""
        self.items.update({str(k): str(v) for k, v in (mapping or {}).items()})
        self.items.update({k.replace("_", " "): str(v) for k, v in items.items()})
        self._changed()

    def forget(self, keys) -> None:
        if any(k in self.items for k in keys):
            self.items = {k: v for k, v in self.items.items() if k not in keys}
            self._changed()


class SessionModel:
    def __init__(self, regions: RegionSet | None = None) -> None:
        self.regions = regions or RegionSet()
        self.progress = P.ProgressModel()
        self.preview = ImageModel("Live image")
        self.signal_map = ImageModel("Signal map (mean, DN)")
        self.noise_map = ImageModel("Noise map (temporal sigma, DN)")
        self.panels = {name: StatsPanelModel(name) for name in PANELS}
        self.distributions: dict[int, StatsPanelModel] = {}
        self.distributions_changed = Observable()
        self.profiles = ProfilesModel()
        self.ptc = PTCModel()
        self.sweep = SweepModel()
        self.components = ComponentsModel()
        self.defects = DefectCountsModel()
        self.info = InfoModel()
        self._result_keys: set[str] = set()  # Information items that are a run's figures
        self.views = ViewModel(self.regions)
        self.stages = StageStore()
        self.visible: set[str] | None = None  # None: every tab (no window says otherwise)
        self._dirty: set[str] = set()
        self.throttle = False  # on while a scan runs (begin_run .. its end)
        # an executor for the statistics panels (Results, Pixel Distributions): ``submit``,
        # and ``available()`` while it may be used (the window's: while a scan thread runs).
        # A large sensor's panels (1-2 s each at 12 Mpx) then do not hold the window; they
        # are shown at a later ``flush``, the last at ``settle``. None: computed here.
        self.executor = None
        self._jobs: dict[str, object] = {}  # "panels" / "distributions" -> the work in flight
        self._before: dict[str, object] = {}  # ... and what to do before it is shown
        self.panels_stage: StageResult | None = None  # the stage the Results panels show
        self.clock = time.monotonic
        self._drawn_at: dict[str, float] = {}
        self._result_at, self._result_waits = -math.inf, False  # the newest stage: when shown; waiting?
        self.last_frame: np.ndarray | None = None
        self.regions.subscribe(lambda _: self._regions_changed())
        self.views.subscribe(lambda _: self._view_changed())

    # ---- which pixels and which stage the tabs show -----------------------------------
    @property
    def last_result(self) -> StageResult | None:
        """The stage the tabs show: the one picked in the stage browser, else the latest."""
        return self.stages.current()

    def region_label(self, shape: tuple[int, int]) -> str:
        return self.views.label(shape)

    def select_view(self, key: str | None) -> None:
        self.views.select(key)

    def show_stage(self, stage: int | None) -> None:
        """Show a finished stage on every tab (None: follow the latest)."""
        self.stages.show(stage)
        self._show_result()

    # ---- work only for what is shown ----------------------------------------------------
    def set_visible(self, tabs) -> None:
        """The result tabs on screen; hidden tabs' models wait until they are shown."""
        self.visible = set(tabs)
        for tab in [t for t in LAZY_TABS if t in self._dirty and t in self.visible]:
            self._drawn_at.pop(tab, None)  # shown now: drawn now
            self._recompute(tab)

    def _need(self, tab: str) -> bool:
        if self.visible is not None and tab not in self.visible:
            self._dirty.add(tab)
            return False
        if self.throttle and self.clock() - self._drawn_at.get(tab, -math.inf) < REFRESH_S:
            self._dirty.add(tab)  # drawn moments ago: the newest data waits for flush()
            return False
        self._drawn_at[tab] = self.clock()
        self._dirty.discard(tab)
        return True

    def flush(self, force: bool = False) -> None:
        """Draw the shown tabs whose newest data waited (every one when ``force``), and the
        statistics panels the executor has computed."""
        for key in list(self._jobs):
            self._show_computed(key, wait=False)
        if self._result_waits and (force or self.clock() - self._result_at >= RESULTS_S):
            self._result_waits = False
            if self.stages.following_latest:
                self._show_latest(force=True)
        for tab in [t for t in LAZY_TABS if t in self._dirty and (self.visible is None or t in self.visible)]:
            if force or self.clock() - self._drawn_at.get(tab, -math.inf) >= REFRESH_S:
                self._drawn_at.pop(tab, None)
                self._recompute(tab)

    def settle(self) -> None:
        """Wait for the statistics panels still being computed, and show them."""
        for key in list(self._jobs):
            self._show_computed(key, wait=True)

    def _end_of_run(self) -> None:
        self.throttle = False
        self.flush(force=True)

    def _recompute(self, tab: str) -> None:
        if tab == DISTRIBUTIONS and self.last_frame is not None:
            self._update_distributions(self.last_frame)
        elif tab in (SIGNAL_MAP, NOISE_MAP):
            self._maps()
        elif tab == RESULTS:
            self._refresh_panels()
        elif tab == PROFILES:
            self._refresh_profiles()

    def _drawn(self) -> list[tuple[int, Region]]:
        return self.regions.visible()

    def _regions_changed(self) -> None:
        rects = self._drawn()
        for m in (self.preview, self.signal_map, self.noise_map):
            m.set_rectangles(rects)
        if self.last_frame is not None:
            self._update_distributions(self.last_frame)
        self._refresh_result()

    # ---- run lifecycle ----------------------------------------------------------------
    def begin_run(self, title: str = "") -> None:
        self.info.forget(self._result_keys)  # the previous run's figures are not this run's
        self._result_keys = set()
        self.progress.reset()
        self.progress.update(state=P.RUNNING, message=f"Running {title}".strip())
        self.ptc.clear()
        self.sweep.clear()
        self.components.clear()
        self.defects.clear()
        self.stages.clear()
        self.last_frame = None
        self._forget_images()
        self.throttle = True
        self._result_at, self._result_waits = -math.inf, False
        self._drawn_at.clear()  # the run's first frame and first stage are drawn at once

    def _forget_images(self) -> None:
        """Nothing of the previous run on any tab once a run starts: the live image, the maps,
        the statistics panels, the distributions and the profiles are emptied at once."""
        for key in list(self._jobs):  # the previous run's panels still being computed are not shown
            job = self._jobs.pop(key)
            self._before.pop(key, None)
            job.cancel()
        for m in (self.preview, self.signal_map, self.noise_map):
            m.set_image(None, "")
        for m in list(self.panels.values()) + list(self.distributions.values()):
            if m.values.size:  # (an empty panel is left as it is)
                m.clear()
        self.panels_stage = None
        self.profiles.update(None, [])

    def handle(self, ev) -> None:
        if isinstance(ev, RunInfo):
            if ev.run_dir:
                self.info.update(run_directory=ev.run_dir)
            self.progress.update(total=ev.total_stages, seconds_remaining=ev.estimated_s)
        elif isinstance(ev, StageStarted):
            self.progress.update(stage=ev.stage, total=ev.total, stage_name=ev.name,
                                 frame=0, frames=ev.frames, state=P.RUNNING)
        elif isinstance(ev, FramePreview):
            self.last_frame = ev.image
            what = "dark frame" if ev.dark else "frame"
            self.preview.set_image(ev.image, f"stage {ev.stage}, {what} {ev.frame} of {ev.frames}")
            self.preview.set_rectangles(self._drawn())
            self._update_distributions(ev.image)
            self.progress.update(frame=ev.frame, frames=ev.frames)
        elif isinstance(ev, StageResult):
            self._stage_result(ev)
        elif isinstance(ev, Progress):
            left = ev.seconds_remaining  # counted down by the time the event waited to be shown
            self.progress.update(stage=ev.stage, total=ev.total, fraction=ev.fraction,
                                 seconds_remaining=None if left is None else max(left - (self.clock() - ev.at), 0.0))
        elif isinstance(ev, Ending):
            self._end_of_run()
            self.progress.update(state=P.FINISHING, seconds_remaining=None,
                                 message=f"{ev.stages_completed} stage(s) acquired ({ev.status}); "
                                         "analysing and writing the run directory in the background.")
        elif isinstance(ev, Done):
            self._end_of_run()
            self._summary(ev.summary)
            if ev.run_dir:
                self.info.update(run_directory=ev.run_dir)
            message = "Scan finished."
            if ev.limit_failures:
                message = (f"Scan finished; {len(ev.limit_failures)} limit(s) failed: "
                           + "; ".join(ev.limit_failures) + ".")
            self._results({"limits": ev.limits.removeprefix("limits: ") if ev.limits
                           else message.removeprefix("Scan finished; ") if ev.limit_failures else "not recorded"})
            self.progress.update(state=P.DONE, fraction=1.0, seconds_remaining=0.0, message=message)
        elif isinstance(ev, Stopped):
            self._end_of_run()
            self._summary(ev.summary)  # the stopped run's own figures (or their reasons), never another's
            self._results({"limits": str(ev.summary.get("limits_text", "limits: not checked")).removeprefix("limits: ")})
            if ev.run_dir:
                self.info.update(run_directory=ev.run_dir)
            self.progress.update(state=P.STOPPED, seconds_remaining=None,
                                 message=ev.message)
        elif isinstance(ev, ReportsWritten):
            self.progress.update(message=ev.message)
        elif isinstance(ev, Failed):
            self._end_of_run()
            self.progress.update(state=P.FAILED, seconds_remaining=None, message=ev.message)
        elif isinstance(ev, Health):  # a pause, a resume, a re-grab (why), the links' trouble counters
            if ev.kind == "link":
                self.info.update(link_health=ev.text.removeprefix("link: "))
            else:
                self.progress.update(state=P.PAUSED if ev.kind == "paused" else P.RUNNING, message=ev.text)

    # ---- per-event updates ------------------------------------------------------------
    def _update_distributions(self, image: np.ndarray) -> None:
        if not self._need(DISTRIBUTIONS):
            return
        active = self.regions.active() or [(-1, full_frame(image.shape))]
        keys = {i for i, _ in active}
        changed = set(self.distributions) != keys
        mask = self.views.channel_mask(image.shape)  # a Bayer phase or ADC channel: its pixels only
        work = []
        for i, region in active:
            model = self.distributions.get(i)
            if model is None:
                title = "Full frame" if i < 0 else f"Region {i + 1}"
                model = self.distributions[i] = StatsPanelModel(title)
            pixels = region.crop(image)
            if mask is not None and pixels is not None:
                pixels = pixels[region.crop(mask)]
            work.append((model, pixels))
        self._compute("distributions", work)
        for i in set(self.distributions) - keys:
            del self.distributions[i]
        if changed:
            self.distributions_changed._changed()

    def _stage_result(self, ev: StageResult) -> None:
        self.stages.add(ev)
        with self.ptc.batch():  # one PTC redraw per stage
            if self.stages.following_latest:
                self._show_latest()
            if ev.dark:
                self.ptc.set_dark(float(np.nanmean(ev.mean)))
            self.ptc.select(self.views.engine_view(None))
            points = ev.ptc_points or ({ev.ptc_view or "full": ev.ptc_point} if ev.ptc_point is not None else {})
            for view, point in points.items():  # every view's: the PTC tab shows the chosen one
                self.ptc.add(ev.stage, ev.name, *point, view=view)
        if ev.coords and ev.quantities:
            self.sweep.add(SweepPoint(ev.stage, ev.group, tuple(ev.coords), dict(ev.settings), dict(ev.quantities),
                                      dict(ev.view_quantities)))
        if ev.summary:
            self._summary(ev.summary)

    def _show_latest(self, force: bool = False) -> None:
        """The newest stage on every tab; while a scan runs at most every ``RESULTS_S``
        (stages a fifth of a second apart would otherwise redraw the window five times a
        second beside the acquisition): a stage that comes sooner waits for ``flush``."""
        now = self.clock()
        if not force and self.throttle and now - self._result_at < RESULTS_S:
            self._result_waits = True
            return
        self._result_at, self._result_waits = now, False
        self._show_result()

    def _show_result(self) -> None:
        """Draw the shown stage on the maps, panels, profiles, components and defects."""
        ev = self.last_result
        if ev is None:
            self._refresh_result()
            return
        caption = f"stage {ev.stage}: {ev.name}"
        self._maps()
        self.ptc.highlight(ev.stage)
        self._refresh_result()
        if ev.components:
            self.components.set_stage(f"stage {ev.stage}: {ev.name} ({ev.frames} frames)", ev.components)
        if ev.defects is not None and ev.mean is not None:
            self.defects.set_counts(ev.defects, ev.mean.size, caption=caption)

    def _maps(self) -> None:
        ev = self.last_result
        if ev is None:
            return
        caption = f"stage {ev.stage}: {ev.name}"
        if ev.mean is None:
            caption += " (arrays dropped to bound memory; the run directory has them)"
        else:
            if self._need(SIGNAL_MAP):  # (a hidden or just-drawn map is marked for later)
                self.signal_map.set_image(ev.mean, caption)
            if self._need(NOISE_MAP):
                self.noise_map.set_image(np.sqrt(np.clip(ev.variance, 0, None)), caption)
        for m in (self.signal_map, self.noise_map):
            m.set_rectangles(self._drawn())

    def _view_changed(self) -> None:
        if self.last_frame is not None:
            self._update_distributions(self.last_frame)
        self._refresh_result()

    def _refresh_result(self) -> None:
        self._refresh_panels()
        self._refresh_profiles()
        view = self.views.engine_view(None)  # the View selector drives the PTC and Sweep Map tabs too
        self.ptc.select(view)
        self.sweep.select(view)
        ev = self.last_result
        if ev is not None and ev.mean is not None:
            self.components.select(self.views.engine_view(ev.mean.shape))

    def _refresh_panels(self) -> None:
        if not self._need(RESULTS):
            return
        ev = self.last_result
        mean = None if ev is None or ev.mean is None else self.views.pixels(ev.mean)

        def shown():  # the stage the panels show (newer ones may have come while they were computed)
            self.panels_stage = ev
        if mean is None:
            self._compute("panels", [(m, None) for m in self.panels.values()], shown)
            return
        var = self.views.pixels(ev.variance)
        p = self.panels
        self._compute("panels", [(p["MEAN SIGNAL"], mean), (p["NOISE"], np.sqrt(np.clip(var, 0, None))),
                                 (p["COLUMNS"], mean.mean(axis=0)), (p["ROWS"], mean.mean(axis=1))], shown)

    def _compute(self, key: str, work: list[tuple[StatsPanelModel, np.ndarray | None]], before=None) -> None:
        """Give each panel its values: in the executor while a scan runs (shown by
        ``flush``; this work replaces ``key``'s still in flight), else here and now;
        ``before()`` is called just before they are shown."""
        old = self._jobs.pop(key, None)
        self._before.pop(key, None)
        if old is not None:
            old.cancel()  # (one already running finishes; its result is not shown)
        before = before or (lambda: None)
        if self.executor is None or not self.executor.available():
            before()
            for model, values in work:
                model.set_values(values)
            return
        jobs = [(model, model.job(values)) for model, values in work]
        self._jobs[key] = self.executor.submit(lambda: [(model, job()) for model, job in jobs])
        self._before[key] = before

    def _show_computed(self, key: str, wait: bool) -> None:
        job = self._jobs.get(key)
        if job is None or not (wait or job.done()):
            return
        del self._jobs[key]
        before = self._before.pop(key)
        if job.cancelled():
            return
        try:
            states = job.result()
        except Exception:  # noqa: BLE001 -- a bug in a panel's statistics must not end the run's drawing
            log.exception("the %s statistics could not be computed", key)
            return
        before()
        for model, state in states:
            model.show(state)

    def _refresh_profiles(self) -> None:
        if not self._need(PROFILES):
            return
        ev = self.last_result
        if ev is None or ev.mean is None:
            self.profiles.update(None, [])
        else:
            self.profiles.update(ev.mean, self.regions.active() or [(-1, full_frame(ev.mean.shape))])

    def _results(self, items: dict) -> None:
        """Figures of the run shown in the Information tab: forgotten when the next run starts."""
        self._result_keys |= set(items)
        self.info.update(items)

    def _summary(self, summary: dict) -> None:
        results = summary.get("results")
        if isinstance(results, dict) and results:
            self._results(results)
        if summary.get("ptc_level_status"):
            self.ptc.set_status(summary["ptc_level_status"])
        gain = summary.get("gain_e_per_dn")
        if gain is not None:
            value = getattr(gain, "value", gain)
            if value is not None and math.isfinite(float(value)):
                self.ptc.set_fit(float(value), summary.get("gain_note", ""), summary.get("gain_text", ""))
        if summary.get("thresholds"):
            self.defects.set_thresholds(summary["thresholds"])
        defects = summary.get("defects")
        if isinstance(defects, dict) and defects:
            total = int(summary.get("pixels", 0)) or (
                self.last_result.mean.size if self.last_result is not None else 1)
            self.defects.set_counts(defects, total, summary.get("defect_criteria"),
                                    caption=summary.get("defect_caption", "scan summary"))
            self.defects.set_map(summary.get("defect_map"))
