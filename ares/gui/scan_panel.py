"""Scan controls: Start/Stop/Pause/Abort/Auto Repeat, the control tabs (Scan, Regions
of Analysis, Output Options, Input Images, Instrumentation) and the progress line."""

from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (QCheckBox, QFileDialog, QFormLayout, QHBoxLayout, QLabel,
                               QLineEdit, QPlainTextEdit, QProgressBar, QPushButton, QSpinBox,
                               QTabWidget, QVBoxLayout, QWidget)

from ares.gui.models import progress as P
from ares.gui.models.progress import ProgressModel
from ares.gui.models.session import SessionModel
from ares.gui.instrument_panel import InstrumentationTab
from ares.gui.layout import ElidedLabel, scrolled
from ares.gui.regions_table import RegionsTable

CONTROL_TABS = ("Scan", "Regions of Analysis", "Output Options", "Input Images", "Instrumentation")


class ScanButtons(QWidget):
    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.start = QPushButton("Start Scan")
        self.stop = QPushButton("Stop Scan")
        self.stop.setToolTip("Finish the stage in flight, keep it, then stop.")
        self.pause = QPushButton("Pause")
        self.pause.setCheckable(True)
        self.abort = QPushButton("Abort")
        self.abort.setToolTip("Stop now; the stage in flight is dropped, completed stages are kept.")
        self.auto_repeat = QCheckBox("Auto Repeat")
        self.start.setStyleSheet("font-weight: bold;")
        lay = QHBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        for w in (self.start, self.stop, self.pause, self.abort, self.auto_repeat):
            lay.addWidget(w)
        lay.addStretch(1)
        self.set_running(False)

    def set_running(self, running: bool) -> None:
        self.start.setEnabled(not running)
        for w in (self.stop, self.pause, self.abort):
            w.setEnabled(running)
        if not running:
            self.pause.setChecked(False)
            self.pause.setText("Pause")


class ScanTab(QWidget):
    open_requested = Signal()

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.file = QLabel("No scan file loaded: Start Scan runs the built-in demo scan.")
        self.file.setWordWrap(True)
        self.open_button = QPushButton("Open Scan…")
        self.details = QPlainTextEdit()
        self.details.setReadOnly(True)
        self.details.setLineWrapMode(QPlainTextEdit.LineWrapMode.NoWrap)
        font = self.details.font()
        font.setStyleHint(font.StyleHint.Monospace)
        font.setFamily("monospace")
        self.details.setFont(font)
        # a shorter (or longer) scan without editing its XML: as ``ares run --frames N``
        from ares.scan.preflight import MAX_FRAMES

        self.frames = QSpinBox()
        self.frames.setRange(1, MAX_FRAMES)  # 1 stands for "the scan's own" (a stage needs 2 frames or more)
        self.frames.setSpecialValueText("as in the scan")
        self.frames.setValue(1)
        self.frames.setToolTip("Frames of every stage, dark stacks included, as `ares run --frames N`: "
                               "fewer for a quick look, more for smaller SEs. The run directory records it.")
        top = QHBoxLayout()
        top.addWidget(self.file, 1)
        top.addWidget(self.open_button)
        count = QHBoxLayout()
        count.addWidget(QLabel("Frames per stage:"))
        count.addWidget(self.frames)
        count.addStretch(1)
        lay = QVBoxLayout(self)
        lay.addLayout(top)
        lay.addLayout(count)
        lay.addWidget(self.details)
        self.open_button.clicked.connect(self.open_requested)
        self.frames.valueChanged.connect(self._render)

    def frame_count(self) -> int | None:
        """The frames every stage takes (None: each stage's own, as the scan says)."""
        return self.frames.value() if self.frames.value() >= 2 else None

    def show_job(self, path: str | None, title: str, info: dict, stage_lines: list[str] | None = None) -> None:
        self.file.setText(f"Scan file: {path}" if path else f"Built-in: {title}")
        self._shown = ("\n".join(f"{k}: {v}" for k, v in info.items() if not isinstance(v, dict)), stage_lines)
        self._render()

    def _render(self, *_) -> None:
        """The job's details and its stage list with the frames each stage will take: the
        Frames per stage choice replaces the scan's counts (dark stacks included), as it runs."""
        import re

        text, lines = getattr(self, "_shown", ("", None))
        n = self.frame_count()
        if lines:
            if n is not None:
                lines = [re.sub(r"\+ \d+ dark", f"+ {n} dark", re.sub(r"\b\d+ frames", f"{n} frames", ln))
                         for ln in lines]
            head = "Stages" + (f" (Frames per stage: {n})" if n is not None else "")
            text += f"\n\n{head}:\n" + "\n".join(lines)
        self.details.setPlainText(text)


class OutputOptionsTab(QWidget):
    """Where the run directory goes and every choice of the scan's ``<output>``; both are
    handed to the run (the choices are saved in the run's scan XML, so a rerun repeats them)."""

    FLAGS = (("raw_frames", "Raw frames (every frame, HDF5)"), ("hdf5", "HDF5 tables and arrays"),
             ("csv", "CSV tables"), ("pdf", "PDF report"))

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.directory = QLineEdit("runs")
        browse = QPushButton("Browse…")
        browse.clicked.connect(self._browse)
        row = QHBoxLayout()
        row.addWidget(self.directory, 1)
        row.addWidget(browse)
        self.write_run = QCheckBox("Write a run directory for each run")
        self.write_run.setChecked(True)
        self.flags = {key: QCheckBox(text) for key, text in self.FLAGS}
        form = QFormLayout(self)
        form.addRow("", self.write_run)
        form.addRow("Run directory root:", row)
        for key, _ in self.FLAGS:
            form.addRow("", self.flags[key])
        note = QLabel("Each run of a scan file writes its XML files, settings, per-stage results and "
                      "versions to a new directory under this root, plus what is ticked above "
                      "(loaded from the scan's <output>); `ares rerun DIR` repeats it. "
                      "The built-in demo scan writes nothing.")
        note.setWordWrap(True)
        form.addRow(note)
        self.write_run.toggled.connect(lambda on: [w.setEnabled(on) for w in self.flags.values()])
        self.show_output(None)

    def show_output(self, output) -> None:
        """Tick the boxes as a scan's ``Output`` says (None: the format's defaults)."""
        from ares.protocol.scan import Output

        output = output or Output()
        for key, box in self.flags.items():
            box.setChecked(bool(getattr(output, key)))

    def output(self):
        from ares.protocol.scan import Output

        return Output(**{key: box.isChecked() for key, box in self.flags.items()})

    def root(self) -> str | None:
        return self.directory.text().strip() or None if self.write_run.isChecked() else None

    def _browse(self) -> None:
        d = QFileDialog.getExistingDirectory(self, "Run directory root", self.directory.text())
        if d:
            self.directory.setText(d)


class InputImagesTab(QWidget):
    """Recorded frames analysed as ``ares analyze`` does (files, folders, .npy/.npz,
    file.h5:/dataset), shown on the same result tabs as a scan; or one image displayed."""

    image_requested = Signal(str)
    analyse_requested = Signal(list, list, object)  # input specs, dark specs, gain in DN/e- or None

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.source = QLabel("Frames come from the bench the scan's system XML declares.")
        self.source.setWordWrap(True)
        self.inputs, self.darks = QLineEdit(), QLineEdit()
        for w, what in ((self.inputs, "input (flat) frames"), (self.darks, "dark frames (optional)")):
            w.setPlaceholderText(f"{what}: files or folders, ';' between them")
        self.gain = QLineEdit()
        self.gain.setPlaceholderText("optional: K in DN/e- (figures also in electrons)")
        form = QFormLayout()
        for label, edit in (("Frames:", self.inputs), ("Dark:", self.darks)):
            row = QHBoxLayout()
            row.addWidget(edit, 1)
            for text, folder in (("Files…", False), ("Folder…", True)):
                b = QPushButton(text)
                b.clicked.connect(lambda _=False, e=edit, f=folder: self._browse(e, f))
                row.addWidget(b)
            form.addRow(label, row)
        form.addRow("Gain:", self.gain)
        self.analyse_button = QPushButton("Analyse Images")
        self.analyse_button.setToolTip("The 13-component decomposition of the stacks, as ares analyze.")
        self.analyse_button.clicked.connect(self._analyse)
        self.load_button = QPushButton("Display an Image File…")
        self.load_button.setToolTip("Show one recorded PNG/TIFF frame in the live image with its distributions.")
        self.load_button.clicked.connect(self._choose)
        lay = QVBoxLayout(self)
        lay.addWidget(self.source)
        lay.addLayout(form)
        buttons = QHBoxLayout()
        buttons.addWidget(self.analyse_button)
        buttons.addWidget(self.load_button)
        lay.addLayout(buttons)
        lay.addStretch(1)

    @staticmethod
    def specs(text: str) -> list[str]:
        return [p.strip() for p in text.split(";") if p.strip()]

    def _browse(self, edit: QLineEdit, folder: bool) -> None:
        if folder:
            d = QFileDialog.getExistingDirectory(self, "Folder of frames")
            picked = [d] if d else []
        else:
            picked, _ = QFileDialog.getOpenFileNames(self, "Frames", "", "Frames (*.png *.tif *.tiff *.npy *.npz *.h5 "
                                                                        "*.hdf5);;All files (*)")
        if picked:
            edit.setText("; ".join(picked))

    def _analyse(self) -> None:
        text = self.gain.text().strip()
        try:
            gain = float(text) if text else None
        except ValueError:
            gain = text  # the window reports it in one sentence
        self.analyse_requested.emit(self.specs(self.inputs.text()), self.specs(self.darks.text()), gain)

    def _choose(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Display an image", "", "Images (*.png *.tif *.tiff);;All files (*)")
        if path:
            self.image_requested.emit(path)


class ControlTabs(QTabWidget):
    def __init__(self, session: SessionModel, parent=None) -> None:
        super().__init__(parent)
        self.scan = ScanTab()
        self.regions = RegionsTable(session.regions)
        self.output = OutputOptionsTab()
        self.inputs = InputImagesTab()
        self.instruments = InstrumentationTab()
        self.setUsesScrollButtons(True)
        for w, name in zip((self.scan, self.regions, self.output, self.inputs, self.instruments), CONTROL_TABS):
            self.addTab(scrolled(w), name)
        self.setStyleSheet("QTabBar::tab { padding: 4px 6px; }")

    def minimumSizeHint(self):  # noqa: N802 -- Qt's name
        """Wide enough for every tab's name: none is cut or hidden behind scroll buttons."""
        hint = super().minimumSizeHint()
        bar = self.tabBar()
        hint.setWidth(max(hint.width(), sum(bar.tabSizeHint(i).width() for i in range(self.count())) + 4))
        return hint


class ProgressLine(QWidget):
    """``Current Stage: … Time Remaining: H : MM : SS`` and a progress bar."""

    def __init__(self, model: ProgressModel, parent=None) -> None:
        super().__init__(parent)
        self.model = model
        # the run's state is always whole; the stage text takes what the column leaves and
        # is elided when longer, whole in its tooltip (never pushed off the window)
        self.stage = ElidedLabel()
        self.remaining = QLabel()
        self.state = QLabel()
        self.bar = QProgressBar()
        self.bar.setRange(0, 1000)
        self.bar.setTextVisible(False)
        self.bar.setMaximumWidth(160)
        lay = QHBoxLayout(self)
        lay.setContentsMargins(0, 0, 8, 0)  # the state clear of the window's edge
        lay.addWidget(QLabel("<b>Current Stage:</b>"))
        lay.addWidget(self.stage, 3)
        lay.addSpacing(10)
        lay.addWidget(QLabel("<b>Time Remaining:</b>"))
        lay.addWidget(self.remaining)
        lay.addSpacing(10)
        lay.addWidget(self.bar, 1)
        lay.addWidget(self.state)
        model.subscribe(lambda _: self.refresh())
        self.refresh()

    def refresh(self) -> None:
        m = self.model
        stage = m.stage_text
        if m.frames and m.state in (P.RUNNING, P.PAUSED):
            stage += f", frame {m.frame}/{m.frames}"
        self.stage.setText(stage)
        self.remaining.setText(m.remaining_text)
        self.bar.setValue(int(round(1000 * max(0.0, min(1.0, m.fraction)))))
        self.state.setText(m.state)
