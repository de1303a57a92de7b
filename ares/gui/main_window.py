"""The ARES main window: scan controls and tabs on the left with the live image, the
progress line and the result tabs on the right."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Callable

from PySide6.QtCore import Qt, QTimer
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QFileDialog, QMainWindow, QMessageBox, QSplitter, QTabWidget, QVBoxLayout, QWidget

from ares.errors import AresError

from ares.gui import engine
from ares.gui.events import Ending, Failed, Health, ReportsWritten, Stopped
from ares.gui.info_panel import InfoPanel, versions
from ares.gui.layout import scrolled
from ares.gui.models import progress as P
from ares.gui.models.regions import Region
from ares.gui.models.session import SessionModel
from ares.gui.plots.components_view import ComponentsView
from ares.gui.plots.defects_view import DefectCountsView
from ares.gui.plots.distributions_view import DistributionsView
from ares.gui.plots.image_view import ImagePlot
from ares.gui.plots.profile_view import ProfilesView
from ares.gui.plots.ptc_view import PTCView
from ares.gui.plots.sweep_view import SweepView
from ares.gui.results_panel import ResultsTab
from ares.gui.view_bar import ViewBar
from ares.gui.scan_panel import ControlTabs, ProgressLine, ScanButtons
from ares.gui.worker import ScanThread, StatsExecutor, one_sentence

RESULT_TABS = ("Results", "Pixel Distributions", "Profiles", "Signal Map", "Noise Map", "PTC",
               "Sweep Map", "Components", "Defect Counts", "Information")
SCAN_FILTER = "Scan files (*.xml);;All files (*)"
log = logging.getLogger(__name__)


class MainWindow(QMainWindow):
    def __init__(self, session: SessionModel | None = None) -> None:
        super().__init__()
        self.setWindowTitle("ARES — image sensor characterization")
        self.session = session or SessionModel()
        # the statistics panels (Results, Pixel Distributions) while a scan runs, off this
        # thread (see SessionModel)
        self._stats_pool = StatsExecutor()
        self.session.executor = self._stats_pool
        self.scan_path: str | None = None
        self.job_factory: Callable[[], engine.Job] = self._demo
        self.scan_thread: ScanThread | None = None
        self.last_error: str | None = None
        self.error_box: QMessageBox | None = None
        self.runs_started = 0
        self._loaded_regions: list = []
        self.background: list[ScanThread] = []  # ended runs still analysing and writing their directory
        self._closing = False

        s = self.session
        self.buttons = ScanButtons()
        self.controls = ControlTabs(s)
        self.preview = ImagePlot(s.preview, cmap="CET-L1",  # monochrome, as the sensor sees it
                                 on_edit=lambda row, x, y, w, h: s.regions.update(row, x=x, y=y, width=w, height=h),
                                 on_new=self._new_region, overlay=s.defects)
        self.progress_line = ProgressLine(s.progress)
        self.results = ResultsTab(s)
        self.distributions = DistributionsView(s)
        self.profiles = ProfilesView(s.profiles)
        self.signal_map = ImagePlot(s.signal_map, overlay=s.defects)
        self.noise_map = ImagePlot(s.noise_map)
        self.ptc = PTCView(s.ptc)
        self.sweep = SweepView(s.sweep)
        self.components = ComponentsView(s.components)
        self.defects = DefectCountsView(s.defects, run_dir=lambda: s.info.items.get("run directory", ""),
                                        on_error=self.show_error)
        self.info = InfoPanel(s.info)
        self.view_bar = ViewBar(s)
        self.result_tabs = QTabWidget()
        self.result_tabs.setStyleSheet("QTabBar::tab { padding: 4px 7px; }")  # all ten tabs in view
        self.result_tabs.setUsesScrollButtons(True)
        for w, name in zip((self.results, self.distributions, self.profiles, self.signal_map, self.noise_map,
                            self.ptc, self.sweep, self.components, self.defects, self.info), RESULT_TABS):
            self.result_tabs.addTab(scrolled(w), name)

        left = self.left_split = QSplitter(Qt.Orientation.Vertical)
        top = QWidget()
        tl = QVBoxLayout(top)
        tl.setContentsMargins(0, 0, 0, 0)
        tl.addWidget(self.buttons)
        tl.addWidget(self.controls)
        left.addWidget(top)
        left.addWidget(self.preview)
        left.setSizes([400, 450])
        right = QWidget()
        rl = QVBoxLayout(right)
        rl.setContentsMargins(0, 0, 0, 0)
        rl.addWidget(self.progress_line)
        rl.addWidget(self.view_bar)
        rl.addWidget(self.result_tabs, 1)
        split = self.main_split = QSplitter(Qt.Orientation.Horizontal)
        split.addWidget(left)
        split.addWidget(right)
        split.setSizes([470, 830])  # at 1280 px every control tab's name and the Results panels fit
        self.setCentralWidget(split)
        self._menus()
        self.statusBar().showMessage("Ready.")

        self.result_tabs.currentChanged.connect(lambda _: self._tab_shown())
        self._tab_shown()
        self.buttons.start.clicked.connect(lambda: self.start_scan())
        self.buttons.stop.clicked.connect(self.stop_scan)
        self.buttons.pause.toggled.connect(self.pause_scan)
        self.buttons.abort.clicked.connect(self.abort_scan)
        self.controls.scan.open_requested.connect(self._open_dialog)
        self.controls.regions.error.connect(self.show_error)
        self.controls.inputs.image_requested.connect(self.show_image_file)
        self.controls.inputs.analyse_requested.connect(self.analyse_images)
        self.controls.instruments.error.connect(self.show_error)
        self.controls.instruments.frame.connect(lambda image: self.show_image(image, "test frame from the bench"))
        self.controls.instruments.system_chosen.connect(self._system_chosen)
        self._show_job_info(engine.DemoScan())

    def _demo(self) -> engine.Job:
        """The built-in demo scan, with the Scan tab's frame count when one is set."""
        n = self.controls.scan.frame_count()
        return engine.DemoScan() if n is None else engine.DemoScan(frames=n)

    def _tab_shown(self) -> None:
        """Only the result tab on screen is computed as the scan runs (the others catch up
        when shown): the window's work never competes with acquisition for nothing."""
        self.session.set_visible({self.result_tabs.tabText(self.result_tabs.currentIndex())})

    def _menus(self) -> None:
        file_menu = self.menuBar().addMenu("&File")
        for text, slot, key in (("&Open Scan…", self._open_dialog, QKeySequence.StandardKey.Open),
                                ("&Load RoA File…", self.controls.regions._load_clicked, None),
                                ("&Save RoA File…", self.controls.regions._save_clicked, None),
                                ("E&xit", self.close, QKeySequence.StandardKey.Quit)):
            act = QAction(text, self)
            if key is not None:
                act.setShortcut(key)
            act.triggered.connect(slot)
            file_menu.addAction(act)
        scan_menu = self.menuBar().addMenu("&Scan")
        for text, slot in (("Start Scan", lambda: self.start_scan()), ("Stop Scan", self.stop_scan),
                           ("Abort", self.abort_scan)):
            act = QAction(text, self)
            act.triggered.connect(slot)
            scan_menu.addAction(act)

    # ---- scan loading -----------------------------------------------------------------
    def _open_dialog(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Open Scan", "scans", SCAN_FILTER)
        if path:
            self.load_scan(path)

    def load_scan(self, path: str | Path) -> bool:
        """Prepare a scan XML for Start Scan; a bad file shows one sentence."""
        try:
            job = engine.open_scan(path, system=self.controls.instruments.model.path)
        except AresError as exc:
            self.show_error(str(exc))
            return False
        except Exception as exc:  # noqa: BLE001 -- one sentence, never a traceback dialog
            self.show_error(one_sentence(exc))
            return False
        self.scan_path = str(path)
        # what runs is the scan with the RoA table's regions (edited or drawn after loading)
        self.job_factory = lambda: engine.open_scan(path, regions=self.session.regions.active(),
                                                    output=self.controls.output.output(),
                                                    system=self.controls.instruments.model.path,
                                                    frames=self.controls.scan.frame_count())
        regions = getattr(job, "regions", None)
        note = ""
        table = self.session.regions
        if callable(regions) and regions():
            new = regions()
            edited = list(table.regions) != list(self._loaded_regions) and table.active()
            if edited and list(table.regions[:len(new)]) != new and not self.confirm(
                    "Replace the regions of analysis?",
                    f"The RoA table holds regions you edited. Replace them with the {len(new)} region(s) of "
                    f"{Path(path).name}? (No keeps the table; what it holds at Start is what runs.)"):
                note = " The RoA table keeps your regions; they are what runs."
            else:
                table.replace_all(new)
                note = f" The RoA table now holds its {len(new)} region(s); what the table holds at Start is what runs."
            # what the table holds when nothing was edited: the scan's regions
            self._loaded_regions = new + [Region()] * (len(table.regions) - len(new))
        else:
            self._loaded_regions = list(table.regions)
        self.controls.output.show_output(getattr(job, "output", None))
        self._set_views(job)
        self._show_job_info(job)
        self.statusBar().showMessage(f"Loaded {path}.{note}")
        return True

    def _new_region(self, x: int, y: int, width: int, height: int) -> None:
        row = self.session.regions.add(Region(True, True, x, y, width, height))
        self.statusBar().showMessage(f"Region {row + 1}: {width} x {height} at ({x}, {y}) added to the RoA table; "
                                     "the next scan analyses it.")

    def confirm(self, title: str, question: str) -> bool:
        """Ask a yes/no question (tests replace this method)."""
        answer = QMessageBox.question(self, title, question,
                                      QMessageBox.StandardButton.Yes | QMessageBox.StandardButton.No)
        return answer == QMessageBox.StandardButton.Yes

    def _set_views(self, job) -> None:
        """The Bayer-phase / ADC-channel choices of the job's sensor, and which engine view
        each RoA row becomes in the run."""
        channels = getattr(job, "channel_views", None)
        views, labels = channels() if callable(channels) else ({}, {})
        self.session.views.region_names = dict(getattr(job, "region_names", {}) or {})
        self.session.views.set_channels(views, labels)
        units = getattr(job, "setting_units", None)
        self.session.sweep.units = units() if callable(units) else {}

    def set_job_factory(self, factory: Callable[[], engine.Job], path: str | None = None) -> None:
        """Use ``factory()`` to make the job each Start Scan (and each Auto Repeat) runs."""
        self.job_factory = factory
        self.scan_path = path
        self._show_job_info(factory())

    def _show_job_info(self, job) -> None:
        info = dict(getattr(job, "info", {}) or {})
        self.controls.scan.show_job(self.scan_path, getattr(job, "title", ""), info, getattr(job, "stage_lines", None))
        self.controls.instruments.show_instruments(info.get("instruments", {}) or
                                                   {"sensor": info.get("system", "unknown")})
        items = dict(versions())
        items["scan"] = self.scan_path or getattr(job, "title", "")
        items.update({k: v for k, v in info.items() if not isinstance(v, dict) and k != "scan"})
        self.session.info.replace(items)
        source = info.get("frame source") or info.get("system")
        if source:
            self.controls.inputs.source.setText(f"Frame source: {source}")

    # ---- run control ------------------------------------------------------------------
    @property
    def running(self) -> bool:
        """A scan is taking frames (Start is disabled)."""
        return self.scan_thread is not None

    @property
    def finishing(self) -> bool:
        """An ended run is still analysing and writing its run directory."""
        return bool(self.background)

    @property
    def previews_dropped(self) -> int:
        return sum(t.pump.dropped for t in ([self.scan_thread] if self.scan_thread else []) + self.background)

    def start_scan(self, job=None) -> None:
        """Start the loaded scan (or ``job``: e.g. the Input Images analysis)."""
        if self.running:
            return
        self.controls.instruments.disconnect_bench()  # the scan opens the devices itself
        try:
            job = job if job is not None else self.job_factory()
            options = getattr(job, "set_output", None)
            if callable(options):
                options(self.controls.output.root())
        except Exception as exc:  # noqa: BLE001
            discard = getattr(job, "discard", None)
            if callable(discard):  # a job that will not run leaves no files behind
                discard()
            self.show_error(str(exc) if isinstance(exc, AresError) else one_sentence(exc))
            return
        self._set_views(job)
        self.last_error = None
        self.runs_started += 1
        self.session.begin_run(getattr(job, "title", ""))
        from ares.gui.plots.lowlight_view import show_for_run

        show_for_run(self.result_tabs, None)  # the previous run's RTN map / Fe-55 fit leave with it
        thread = self.scan_thread = ScanThread(job, self)
        thread.event.connect(lambda ev: self._on_event(ev, thread))
        thread.timer.timeout.connect(self._flush)  # statistics computed meanwhile are shown
        thread.settle = self.session.settle  # ... and the last of them before the run is over
        thread.finished.connect(lambda: self._on_finished(thread))
        self.buttons.set_running(True)
        n = getattr(getattr(job, "runner", None), "frames_override", None)  # the Scan tab's frame count
        self.statusBar().showMessage(f"Running {getattr(job, 'title', 'scan')}"
                                     + (f" with {n} frames per stage" if n else "") + "…")
        self.scan_thread.start()

    def stop_scan(self) -> None:
        if self.scan_thread is not None:
            self.scan_thread.stop()
            self.session.progress.update(state=P.STOPPING)
            self.statusBar().showMessage("Stopping after the stage in flight…")

    def pause_scan(self, paused: bool) -> None:
        if self.scan_thread is None:
            return
        if paused:
            self.scan_thread.pause()
            self.session.progress.update(state=P.PAUSED)
        else:
            self.scan_thread.resume()
            self.session.progress.update(state=P.RUNNING)
        self.buttons.pause.setText("Resume" if paused else "Pause")

    def abort_scan(self) -> None:
        if self.scan_thread is not None:
            self.scan_thread.abort()
            self.statusBar().showMessage("Aborting…")

    def _flush(self) -> None:
        try:
            self.session.flush()
        except Exception as exc:  # noqa: BLE001 -- a drawing bug must not take the run down with it
            log.exception("could not draw")
            self.statusBar().showMessage(f"Could not draw: {one_sentence(exc)}")

    def _on_event(self, ev, thread=None) -> None:
        if thread is not None and thread is not self.scan_thread and thread is not self._newest:
            return  # a run that ended before the one now shown: its events no longer draw
        try:
            self.session.handle(ev)
            self.session.flush()  # shown tabs whose newest data waited (at most every REFRESH_S)
        except Exception as exc:  # noqa: BLE001 -- a drawing bug must not take the run down with it
            log.exception("could not draw %s", type(ev).__name__)
            self.statusBar().showMessage(f"Could not draw a {type(ev).__name__} event: {one_sentence(exc)}")
            return
        if isinstance(ev, Ending) and thread is self.scan_thread:
            self._release(thread)  # control back now; the analysis and files finish in the background
            self.statusBar().showMessage(self.session.progress.message)
        elif isinstance(ev, Failed):
            self.show_error(ev.message)
        elif isinstance(ev, (Stopped, ReportsWritten)):  # "kept in DIR", then its reports' state
            self.statusBar().showMessage(ev.message)
        elif isinstance(ev, Health):  # Paused/Resumed/Regrab with why, the links' trouble counters
            self.statusBar().showMessage(ev.text)

    @property
    def _newest(self):
        return self.background[-1] if self.background and self.scan_thread is None else None

    def _release(self, thread) -> None:
        """The scan takes no more frames: Start is enabled again while the thread finishes."""
        self.scan_thread = None
        self.background.append(thread)
        self.buttons.set_running(False)

    def _on_finished(self, thread) -> None:
        newest = thread is self.scan_thread or thread is self._newest
        if thread is self.scan_thread:
            self.scan_thread = None
            self.buttons.set_running(False)
        if thread in self.background:
            self.background.remove(thread)
        thread.wait()
        thread.deleteLater()
        if self._closing:
            if not self.running and not self.finishing:
                self.close()
            return
        if not newest:
            return
        state = self.session.progress.state
        if state in (P.RUNNING, P.FINISHING):  # the job returned without Done/Stopped
            self.session.progress.update(state=P.DONE)
            state = P.DONE
        if state == P.DONE:
            run_dir = self.session.info.items.get("run directory")
            self.statusBar().showMessage(f"Scan finished; {run_dir} complete." if run_dir else "Scan finished.")
            from ares.gui.plots.lowlight_view import show_for_run  # the RTN map / Fe-55 histogram, when it has them
            show_for_run(self.result_tabs, run_dir)
            if self.buttons.auto_repeat.isChecked() and not self.running:
                QTimer.singleShot(0, self._repeat)

    def _repeat(self) -> None:
        """Auto Repeat's next run, unless it was unticked since the last one ended."""
        if self.buttons.auto_repeat.isChecked():
            self.start_scan()

    # ---- messages and images ----------------------------------------------------------
    def show_error(self, message: str) -> None:
        """One sentence in the status bar and a (non-blocking) message box."""
        self.last_error = message
        self.statusBar().showMessage(message)
        if self.error_box is None:
            self.error_box = QMessageBox(QMessageBox.Icon.Warning, "ARES", message,
                                         QMessageBox.StandardButton.Ok, self)
            self.error_box.setModal(False)
        self.error_box.setText(message)
        self.error_box.show()

    def _system_chosen(self, path: str) -> None:
        """The Instrumentation tab's system: the loaded scan is re-read on it."""
        if self.scan_path:
            self.load_scan(self.scan_path)
        self.statusBar().showMessage(f"Scans run on {path or 'their own system'}.")

    def analyse_images(self, files: list, dark: list, gain) -> None:
        """Recorded frames through ``ares analyze``'s decomposition, on the result tabs."""
        from ares.errors import InputError

        from ares.gui.image_job import ImageStackJob

        if self.running:
            self.show_error("A scan is running: analyse images when it has ended.")
            return
        try:
            if isinstance(gain, str) or (gain is not None and not gain > 0):
                raise InputError(f"gain '{gain}' is not a positive number (DN/e-)")
            job = ImageStackJob(files, dark, gain)
        except AresError as exc:
            self.show_error(str(exc))
            return
        self.start_scan(job)

    def show_image_file(self, path: str) -> None:
        from ares.hardware.imagefile import read_image

        try:
            image = read_image(path)
        except AresError as exc:
            self.show_error(str(exc))
            return
        self.show_image(image, Path(path).name)

    def show_image(self, image, caption: str) -> None:
        from ares.gui.events import FramePreview

        self.session.handle(FramePreview(0, 1, 1, image))
        self.session.preview.set_image(image, caption)

    def closeEvent(self, event) -> None:  # noqa: N802 -- Qt name
        """Closing during a scan asks first; then the scan is aborted (the stage in flight
        dropped, the completed ones kept) and the window closes once the run directory is
        complete -- never with half-written files, never blocking the window meanwhile."""
        if self.running and not self._closing:
            if not self.confirm("Close ARES?", "A scan is running. Abort it (completed stages are kept and "
                                               "the run directory is finished) and close?"):
                event.ignore()
                return
            self.abort_scan()
        if self.running or self.finishing:
            self._closing = True
            self.statusBar().showMessage("Closing once the run directory is complete…")
            event.ignore()
            return
        self.controls.instruments.disconnect_bench()
        self.session.executor = None
        self._stats_pool.shutdown()
        super().closeEvent(event)
