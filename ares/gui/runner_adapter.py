"""A scan XML run through ``ares.scan.Runner``, as a GUI job (no Qt).

Translates the runner's events (``ares.scan.events``; 0-based stage indices, JSON-able
stage results) into ``ares.gui.events`` (1-based, arrays + the engine's PTC point), and
forwards pause/resume/stop/abort to the runner.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ares import labels
from ares.analysis.stats.estimate import GAIN_SPREADS, Estimate, format_dict, pct_rms
from ares.errors import AresError

from ares.gui import events as G
from ares.gui.models.session import figure_key


def _value(d):
    if isinstance(d, dict):
        v = d.get("value")
        return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None
    return None


def _fmt(d) -> str | None:
    """An estimate with the digits its SE supports, or its reason when not available."""
    if not isinstance(d, dict):
        return None
    return format_dict(d, with_reason=True)


def summarize(scan_results: dict, thresholds: tuple = ()) -> dict:
    """The parts of the runner's scan-level results the window shows."""
    out: dict = {"results": {}}
    if thresholds:
        out["results"]["defect thresholds"] = ", ".join(f"{k} = {v:g}" for k, v in thresholds)
        out["thresholds"] = dict(thresholds)
    ptc = scan_results.get("ptc")
    if isinstance(ptc, dict):
        g = _value(ptc.get("gain_e_per_dn"))
        if g is not None:
            out["gain_e_per_dn"] = g
            fitted = (ptc.get("gain_model") or {}).get("levels")
            out["gain_note"] = (f"fit by the engine over {fitted} of {ptc.get('levels', '?')} levels" if fitted
                                else f"fit by the engine over {ptc.get('levels', '?')} levels")
            # the figures as the engine states them: the digits their SE supports
            out["gain_text"] = (f"system gain K = {_fmt(ptc.get('gain_dn_per_e'))}, "
                                f"1/K = {_fmt(ptc.get('gain_e_per_dn'))}")
        if isinstance(ptc.get("level_status"), list):
            out["ptc_level_status"] = ptc["level_status"]
        if "note" in ptc and "gain_dn_per_e" not in ptc:
            out["results"]["PTC"] = str(ptc["note"])
    from ares.report.headline import full_well_note, headline, same_point
    from ares.report.page_tables import analysis_label

    for key, name, d in headline(scan_results):  # the terminal's figures, its order and wording
        text = _fmt(d)
        if text:
            out["results"][figure_key(key, name)] = text
    if isinstance(ptc, dict):
        for label, text in (("same level", same_point(ptc)), ("full well", full_well_note(ptc))):
            if text:
                out["results"][label] = text
    d = scan_results.get("decomposition")
    if isinstance(d, dict) and d.get("masked_pixels") is not None:
        classes = ", ".join(f"{k} {v}" for k, v in (d.get("mask_classes") or {}).items())
        out["results"][labels.MASKED_PIXELS] = Estimate.count(d["masked_pixels"], "pixels").text() + (
            f"; mask from {d.get('mask_source')}") + (f": {classes}" if classes else "")  # (as the report's figure)
    defects = scan_results.get("defects")
    if isinstance(defects, dict):
        counts = defects.get("counts")
        if isinstance(counts, dict) and counts:
            crit = {str(k): str(v) for k, v in (defects.get("criteria") or {}).items()}
            why = defects.get("unavailable") if isinstance(defects.get("unavailable"), dict) else {}
            out["defects"] = {}
            for k, v in counts.items():  # a class the run could not test: its row says n/a and why
                if v is None:
                    crit.setdefault(str(k), "not available: " + str(why.get(k) or "not tested by this scan"))
                out["defects"][str(k)] = int(v) if isinstance(v, (int, float)) else None
            out["defect_criteria"] = crit
            if defects.get("locations") is not None and defects.get("shape"):
                out["defect_map"] = {"shape": tuple(defects["shape"]), "locations": defects["locations"],
                                     "bad_column_x": defects.get("bad_column_x") or [],
                                     "bad_row_y": defects.get("bad_row_y") or []}
            if isinstance(defects.get("pixels"), int):
                out["pixels"] = defects["pixels"]
            parts = []
            if defects.get("dark_stages"):
                parts.append("dark stage(s) " + ", ".join(map(str, defects["dark_stages"])))
            if defects.get("flat_stage"):
                parts.append(f"flat stage {defects['flat_stage']}")
            if "passed" in defects:
                parts.append("defect limits " + ("passed" if defects["passed"] else "FAILED"))
            out["defect_caption"] = "Scan-level defect classification: " + "; ".join(parts) + "."
        elif defects.get("note"):
            out["results"]["defects"] = str(defects["note"])
    out["results"].update(lowlight_items(scan_results))
    for name, r in scan_results.items():
        if name in ("ptc", "defects", "decomposition") or not isinstance(r, dict):
            continue
        if r.get("status"):
            out["results"][name] = f"{r['status']}" + (f" ({r['note']})" if r.get("note") else "")
            continue
        for key, e in estimates(r):  # every estimate the result holds, as the terminal prints it
            label = analysis_label(name, key) if name == "emva4" else f"{name}: {key}"  # (the standard's symbols)
            if label in out["results"]:  # one symbol in two units (DR, DR in dB): the second says its unit
                label += f" ({e.get('unit') or 'ratio'})"
            out["results"][label] = _fmt(e)
    return out


def estimates(d: dict, prefix: str = "", depth: int = 0) -> list[tuple[str, dict]]:
    """(dotted key, estimate dict) of an analysis result, nested as the terminal prints them."""
    out = []
    for k, v in d.items():
        if isinstance(v, dict) and "value" in v and "unit" in v:
            out.append((prefix + k, v))
        elif isinstance(v, dict) and depth < 5:
            out += estimates(v, f"{prefix}{k}.", depth + 1)
    return out


def lowlight_items(scan_results: dict) -> dict[str, str]:
    """The low-light analyses' headline figures for the Information tab, as ``ares run`` words them:
    RTN pixels and the pixels' temporal noise with and without them, the activation energy and doubling
    temperature, the Fe-55 gain per stage."""
    out = {}
    r = scan_results.get("rtn")
    if isinstance(r, dict) and "rtn_pixels" in r:
        out["RTN pixels"] = f"{r['rtn_pixels']} ({_fmt(r.get('rtn_fraction'))} of the pixels, {r.get('frames')} frames)"
        out["pixel temporal noise with / without RTN"] = (f"{_fmt(r.get('temporal_noise_dn'))} / "
                                                          f"{_fmt(r.get('temporal_noise_without_rtn_dn'))}")
    d = scan_results.get("dark_temperature")
    if isinstance(d, dict) and isinstance(d.get("pixels"), dict):
        px, fr = d["pixels"], d.get("frame") or {}
        if "median_activation_ev" in px:
            out["activation energy (per-pixel median)"] = _fmt(px["median_activation_ev"])
            out["Meyer-Neldel energy"] = _fmt(px.get("meyer_neldel_ev"))
            out["hot pixels by activation energy"] = str(px.get("hot_by_activation"))
        if "doubling_c" in fr:
            out["dark current doubling temperature (frame)"] = _fmt(fr["doubling_c"])
    f = scan_results.get("fe55")
    if isinstance(f, dict) and isinstance(f.get("stages"), dict):
        for stage, v in f["stages"].items():
            if isinstance(v, dict) and "gain_e_per_dn" in v:
                out[f"Fe-55 gain ({stage}, {v.get('temperature_c'):g} C)"] = _fmt(v["gain_e_per_dn"])
    return {k: v for k, v in out.items() if v}


def _meta(run_dir) -> dict:
    """A run directory's run.json ({} when there is none or it cannot be read)."""
    import json

    try:
        return json.loads((Path(run_dir) / "run.json").read_text()) if run_dir else {}
    except (OSError, ValueError):
        return {}


def _reports_state(run_dir) -> str | None:
    """run.json's ``reports``: "writing", "complete", "failed", "incomplete" or None."""
    return _meta(run_dir).get("reports")


COMPONENT_LABELS = {k: v for k, v in labels.COMPONENTS.items() if k not in ("o", "q", "delta", "signal")}


def quantities(view: dict) -> dict[str, float]:
    """Sweep-map quantities of one stage view, as the engine computed them."""
    out: dict[str, float] = {}
    level = view.get("level", {})
    for label, key, root in (("mean output (DN, offset included)", "mean_dn", False), ("temporal noise (DN)", "var_dn2", True),
                             ("spatial noise (DN)", "spatial_var_dn2", True)):
        v = level.get(key)
        if isinstance(v, (int, float)) and math.isfinite(v):
            out[label] = math.sqrt(v) if root and v >= 0 else (v if not root else math.nan)
    for name, d in (view.get("components") or {}).items():
        v = _value(d)
        if v is not None and name in GAIN_SPREADS:  # relative variances: % rms, as the CLI and the PDF
            out[f"{name}: {COMPONENT_LABELS[name]}, % rms"] = pct_rms(v)
        elif v is not None and name in COMPONENT_LABELS:
            out[f"{name}: {COMPONENT_LABELS[name]}, {d.get('unit', '')}"] = v  # as the report's sweep maps
    return out


# Modules the runner imports lazily during a run. Importing a large package in the
# worker thread while the GUI thread runs Qt's event loop deadlocked PySide6 6.12
# (seen: the worker inside matplotlib -> fontTools imports, the GUI thread waiting for
# the GIL in a timer callback). Importing them here, in the GUI thread, before the run
# starts leaves the worker nothing big to import.
WARM_IMPORTS = (
    "scipy.special", "scipy.ndimage", "h5py", "matplotlib", "matplotlib.figure",
    "matplotlib.backends.backend_pdf", "ares.sim", "ares.sim.truth", "ares.rig.factory",
    "ares.analysis", "ares.analysis.ptc.photon_transfer", "ares.analysis.ptc.fit", "ares.analysis.ptc.levels",
    "ares.analysis.defects", "ares.analysis.ptc.dark_current", "ares.analysis.ptc.gain_split", "ares.analysis.ptc.lag",
    "ares.analysis.ptc.adc", "ares.analysis.emva.release3", "ares.analysis.emva.sheet", "ares.analysis.emva.general",
    "ares.report.datasheet", "ares.results.analyses", "ares.report",
    "ares.report.pdf", "ares.report.plots", "ares.report.csv_export", "ares.report.h5_export",
)


def warm_imports() -> None:
    import importlib

    for name in WARM_IMPORTS:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 -- optional pieces; the runner reports what it misses
            pass


def edited_scan(scan, rows=None, output=None):
    """``scan`` as the window runs it: the RoA table's regions (GUI ``Region`` rows) as
    its regions of analysis (a rectangle the scan has keeps its name, others are roa1,
    roa2...) and the Output Options' ``Output``. An edited scan is written as XML (in a
    temporary folder, its system href made absolute) and becomes the scan's source, so
    the run directory keeps exactly what ran and ``ares rerun`` repeats it; a defect mask
    file named relative to the scan is made absolute, so it is the same file. The folder
    goes with the job (``RunnerJob.run``/``discard``). A region outside the array is one
    sentence."""
    import dataclasses
    import tempfile

    from ares.errors import InputError
    from ares.protocol import Region as ScanRegion
    from ares.protocol import save_scan

    changes = {}
    if rows is not None:
        s = scan.system.sensor
        out = []
        for i, r in enumerate(rows, start=1):
            if r.x < 0 or r.y < 0 or r.x + r.width > s.cols or r.y + r.height > s.rows:
                raise InputError(f"RoA row {i} (x={r.x}, y={r.y}, {r.width} x {r.height}) lies outside the "
                                 f"{s.cols} x {s.rows} array")
            geom = (int(r.x), int(r.y), int(r.width), int(r.height))
            same = [g.name for g in scan.regions if (g.x, g.y, g.width, g.height) == geom]  # keep the scan's name
            out.append(ScanRegion(same[0] if same else f"roa{i}", *geom))
        if tuple(out) != tuple(scan.regions):
            changes["regions"] = tuple(out)
    if output is not None and output != scan.output:
        changes["output"] = output
    if not changes:
        return scan
    src = Path(scan.source)
    if scan.defect_mask and not Path(scan.defect_mask).is_absolute():
        changes["defect_mask"] = str((src.parent / scan.defect_mask).resolve())
    tmp = Path(tempfile.mkdtemp(prefix="ares-gui-")) / src.name
    href = str(Path(scan.system_path or scan.system.source).resolve())
    edited = dataclasses.replace(scan, **changes, system_href=href, source=tmp)
    save_scan(edited, tmp)
    return edited


class RunnerJob:
    """One run of the scan at ``path``; make a new job for each run (Auto Repeat)."""

    def __init__(self, path: str | Path, frames: int | None = None, seed: int | None = None,
                 faults: dict | None = None, regions=None, output=None, system: str | None = None) -> None:
        from ares.protocol import load_scan
        from ares.scan import Runner

        self.path = Path(path)
        self.scan = load_scan(self.path, system_path=system or None)  # InputError: file and line
        rows = [i for i, _ in regions] if regions is not None else list(range(len(self.scan.regions)))
        loaded = self.scan
        self.scan = edited_scan(self.scan, None if regions is None else [r for _, r in regions], output)
        # the edited scan's temporary folder: removed once the run has copied the XML
        self._edited_dir = Path(self.scan.source).parent if self.scan is not loaded else None
        # RoA row -> the engine's view name of that region in this run
        self.region_names = {row: r.name for row, r in zip(rows, self.scan.regions)}
        warm_imports()
        if self.scan.system.simulator is not None:  # numba imported and loaded in the GUI thread
            from ares.sim import fused

            fused.warm()
        try:
            self.runner = Runner(self.scan, seed=seed, frames=frames, faults=faults,
                                 argv=["ares", "gui", str(self.path)])
        except BaseException:
            self.discard()
            raise
        self.runner.add_listener(self._on_event)
        self._emit = None
        self._failed_sent = False
        self._stopped: str | None = None  # a stopped run's message while its reports are written
        self._stopped_dir: str | None = None
        self._dark_level: dict[str, dict] = {}  # view -> the last dark stage's level
        scan, system = self.scan, self.scan.system
        self.title = f"{scan.name} ({self.path.name})"
        sensor = system.sensor
        self.info = {
            "scan": str(self.path),
            "description": scan.description or "—",
            "system": f"{system.name}: {sensor.name} {sensor.cols} x {sensor.rows}, {sensor.adc_bits}-bit, "
                      f"CFA {sensor.cfa}",
            "stages": str(len(self.runner.stages)),
            "estimated duration": f"{self.runner.estimate_seconds():.1f} s of exposure, readout and settling",
            "analyses": ", ".join(scan.analyses) or "none",
            "frame source": "simulated sensor (ares.sim)" if system.simulator is not None else "hardware",
            "seed": str(self.runner.seed),
            "instruments": self._instruments(system),
        }
        self.stage_lines = [self._stage_line(st) for st in self.runner.stages]

    @staticmethod
    def _stage_line(st) -> str:
        sets = ", ".join(f"{k.removeprefix('reg:')}={v:g}" for k, v in st.settings.items()
                         if isinstance(v, (int, float)))
        dark = {"grab": f" + {st.dark_frames} dark", "reuse": " + dark (reused)"}.get(st.dark_source, "")
        return f"{st.index:3d}  {st.name:<12} {st.scene:<4} {st.frames} frames{dark}  {sets}"

    @staticmethod
    def _instruments(system) -> dict:
        out = {"sensor": f"{system.sensor.name} ({system.sensor.cols} x {system.sensor.rows})"}
        if system.simulator is not None:
            wire = " behind emulated I2C/USB/serial devices" if system.simulator.wire else ""
            out["simulator"] = f"ARTEMIS-style Monte Carlo model, seed {system.simulator.seed}{wire}"
        if system.genicam is not None:
            out["camera"] = f"GenICam {system.genicam.name} ({system.genicam.cti}, device {system.genicam.device})"
        elif system.simulator is None or system.simulator.wire:
            out["frame grabber"] = (f"USB {system.usb_grabber.name} ({system.usb_grabber.format})"
                                    if system.usb_grabber else "none declared")
        for bus in system.buses:
            out[f"I2C bus {bus.name}"] = f"bus {bus.bus}, address 0x{bus.address:02X}, {bus.speed_hz // 1000} kHz"
        for label, dev in (("light source", system.light_source), ("thermal chamber", system.chamber)):
            if dev is not None:
                rng = f", {dev.min:g}..{dev.max:g} {dev.unit or ''}" if dev.min is not None and dev.max is not None else ""
                out[label] = f"{dev.name} on {dev.port} ({dev.baud} baud{rng.rstrip()})"
            elif system.simulator is not None:
                out[label] = "simulated"
        return out

    def regions(self) -> list:
        """The scan's regions as RoA rows (on and drawn)."""
        from ares.gui.models.regions import Region

        return [Region(True, True, r.x, r.y, r.width, r.height) for r in self.scan.regions]

    def setting_units(self) -> dict[str, str]:
        """Unit of every setting a stage can carry, from the system XML."""
        return self.scan.system.setting_units()

    def channel_views(self) -> tuple[dict, dict]:
        """The engine's Bayer-phase and ADC-channel views of the sensor (slices) and their labels."""
        from ares.scan.stage_analysis import views

        from ares.gui.models.views import channel_label

        v = {k: s for k, s in views(self.scan).items() if k.startswith(("cfa_", "adc"))}
        return v, {k: channel_label(k, self.scan.system.sensor.adc_interleave) for k in v}

    @property
    def output(self):
        return self.scan.output

    def set_output(self, root: str | None) -> None:
        """Write the run directory under ``root`` (None: no run directory)."""
        if root:
            base = Path(root) / f"{self.scan.name}_{time.strftime('%Y%m%d-%H%M%S')}"
            p, k = base, 1
            while p.exists():
                k += 1
                p = base.with_name(f"{base.name}_{k}")
            self.runner.out_dir = p
        else:
            self.runner.out_dir = None

    # ---- control ----------------------------------------------------------------------
    def pause(self) -> None:
        self.runner.pause()

    def resume(self) -> None:
        self.runner.resume()

    def stop(self) -> None:
        self.runner.stop()

    def abort(self) -> None:
        self.runner.abort()

    @property
    def paused(self) -> bool:
        return self.runner.paused

    # ---- running ----------------------------------------------------------------------
    def run(self, emit) -> None:
        self._emit = emit
        self._stopped = None
        try:
            self.runner.run()  # (the reports are written before it returns)
        except AresError:
            if not self._failed_sent:  # failed before the runner could say so
                raise
        finally:
            self.discard()
            if self._stopped:
                self._reports_written()

    def _reports_written(self) -> None:
        """The stopped run's reports are done: say so, from run.json (never before)."""
        run_dir = self._stopped_dir
        state = _reports_state(run_dir) or "not recorded"
        if state == "complete":
            message = f"{self._stopped}; its reports are complete."
        else:
            error = _meta(run_dir).get("report_error")
            message = f"{self._stopped}; its reports are {state}" + (f": {error}" if error else "") + "."
        self._emit(G.ReportsWritten(message, state))

    def discard(self) -> None:
        """Remove the edited scan's temporary folder (the run directory has its copy)."""
        import shutil

        if self._edited_dir is not None:
            shutil.rmtree(self._edited_dir, ignore_errors=True)
            self._edited_dir = None

    def _on_event(self, e) -> None:
        from ares.scan import events as ev

        emit = self._emit
        if isinstance(e, ev.RunStarted):
            emit(G.RunInfo(e.run_dir, e.total_stages, e.estimated_s))
        elif isinstance(e, ev.StageStarted):
            st = e.stage
            emit(G.StageStarted(e.index, e.total, st.name, st.frames, dict(st.settings)))
        elif isinstance(e, ev.FramePreview):
            emit(G.FramePreview(e.index, e.frame + 1, e.frames, e.data, e.dark))
        elif isinstance(e, ev.Progress):
            emit(G.Progress(e.index, e.total, e.fraction, e.remaining_s))
        elif isinstance(e, (ev.StageFinished, ev.StageUpdated)):  # updated: masked again, replaces it
            emit(self._stage_result(e))
        elif isinstance(e, (ev.Paused, ev.Resumed, ev.Regrab, ev.LinkHealth)):
            from ares.commands.run import health_line  # (the terminal's words, one vocabulary)

            text = health_line(e)
            if text:
                kind = {ev.Paused: "paused", ev.Resumed: "resumed", ev.Regrab: "regrab"}.get(type(e), "link")
                emit(G.Health(kind, e.index, text))
        elif isinstance(e, ev.Ending):
            emit(G.Ending(e.status, e.stages_completed))
        elif isinstance(e, ev.Done):
            from ares.results.registry import limits_verdict

            summary = summarize(e.scan_results or {}, self.scan.defects)
            # the run's limits line, as the terminal and run.json state it
            summary["limits_text"] = limits_verdict(e.status, len(self.scan.limits), e.limit_failures)["text"]
            if e.status == "done":
                emit(G.Done(e.run_dir, summary, tuple(e.limit_failures), summary["limits_text"]))
            else:
                kept = f"; {e.stages_completed} completed stage(s) kept" + (f" in {e.run_dir}" if e.run_dir else "")
                # the reports follow this event: said so, and ReportsWritten once they are there
                self._stopped = f"Scan {e.status}{kept}" if _reports_state(e.run_dir) == "writing" else None
                self._stopped_dir = e.run_dir
                emit(G.Stopped(f"Scan {e.status}{kept}" + ("; writing its reports…" if self._stopped else "."),
                               aborted=(e.status == "aborted"), run_dir=e.run_dir, summary=summary))
        elif isinstance(e, ev.Failed):
            self._failed_sent = True
            msg = e.message.strip()
            emit(G.Failed(msg if msg.endswith(".") else msg + "."))

    def _stage_result(self, e) -> G.StageResult:
        r = e.result
        full = r["views"]["full"]
        points = {}  # view -> (signal above dark, temporal variance above dark), as the engine states them
        for name, v in r["views"].items():
            level, dark = v.get("level") or {}, v.get("dark_level")
            if r["scene"] == "dark":
                self._dark_level[name] = level
            elif dark is None:
                dark = self._dark_level.get(name)
            if r["scene"] == "flat" and dark is not None:
                var, dvar = level.get("var_dn2"), dark.get("var_dn2")
                if var is not None and dvar is not None and level.get("mean_dn") is not None:
                    points[name] = (level["mean_dn"] - dark["mean_dn"], var - dvar)
        point = points.get("full")
        values = quantities(full)
        from ares.results.analyses import stage_lag_cycle

        cycle = stage_lag_cycle(r)  # dark="after": this stage is a bright->dark cycle
        if cycle is not None and cycle[0].available and not cycle[0].bound:  # (a limit -- not resolved from 0 --
            values["image lag (%)"] = cycle[0].value  # is no value to colour a map cell with: left blank)
        return G.StageResult(e.index, r["name"], e.arrays["mean"], e.arrays["variance"], r["frames"],
                             dark=(r["scene"] == "dark"), settings=dict(r["settings"]), ptc_point=point,
                             ptc_view="full", ptc_points=points, group=r.get("group", ""), coords=tuple(r.get("coords") or ()),
                             quantities=values, view_quantities={k: quantities(v) for k, v in r["views"].items()},
                             components={v: {k: d[k] for k in ("components", "dark_components", "components_masked",
                                                               "masked_pixels") if k in d}
                                         for v, d in r["views"].items()})
