"""Input Images: recorded frames (PNG/TIFF lists or folders, .npy/.npz, ``file.h5:/dataset``)
analysed exactly as ``ares analyze`` does -- the same accumulation and the same
13-component decomposition -- as a GUI job (no Qt), so the result tabs show them with
the same panels as a scan: a dark stack (when given) and the flat/input stack are its
two "stages"."""

from __future__ import annotations

import time
from pathlib import Path

from ares.errors import InputError

from ares.gui.engine import JobControl
from ares.gui.events import Done, FramePreview, Progress, RunInfo, StageResult, StageStarted


def _name(specs) -> str:
    p = Path(str(specs[0]).split(":")[0])
    return p.name + (f" + {len(specs) - 1} more" if len(specs) > 1 else "")


class ImageStackJob(JobControl):
    def __init__(self, files: list[str], dark: list[str] | None = None, gain: float | None = None) -> None:
        super().__init__()
        if not files:
            raise InputError("choose the image files or a folder to analyse")
        self.files, self.dark, self.gain = [str(f) for f in files], [str(d) for d in dark or []], gain
        self.title = f"recorded images: {_name(self.files)}" + (f" with dark {_name(self.dark)}" if self.dark else "")
        self.info = {"scan": self.title, "frame source": "recorded images (as ares analyze)",
                     "input": ", ".join(self.files), "dark": ", ".join(self.dark) or "none"}

    def run(self, emit) -> None:
        from ares.analysis.noise.decompose import StackAnalysis
        from ares.commands.analyze import accumulate_files

        stacks = ([("dark", self.dark)] if self.dark else []) + [("flat" if self.dark else "input", self.files)]
        emit(RunInfo(None, len(stacks), None))
        accs = []
        t0 = time.monotonic()
        for k, (what, specs) in enumerate(stacks):  # k: the stage index, from 0
            emit(StageStarted(k, len(stacks), what, 0))

            def seen(i, frame, k=k, what=what):
                self.checkpoint()
                emit(FramePreview(k, i + 1, 0, frame, dark=(what == "dark")))
                emit(Progress(k, len(stacks), k / len(stacks), None))

            accs.append(accumulate_files(specs, None, what, on_frame=seen))
        if len(accs) == 2 and accs[0].shape != accs[1].shape:
            raise InputError(f"dark frames {accs[0].shape} and flat frames {accs[1].shape} differ in shape")
        an = StackAnalysis(*accs, gain=self.gain) if len(accs) == 2 else StackAnalysis(accs[0], gain=self.gain)
        comps = {k: e.to_dict() for k, e in {**an.components(), **an.extras()}.items()}
        for k, ((what, _), acc) in enumerate(zip(stacks, accs)):
            view = {"components": comps} if k == len(accs) - 1 else {}
            if len(accs) == 2 and k == 0:
                view = {"components": {k_: v for k_, v in comps.items()
                                       if k_ in ("o", "Cs", "Ct", "Rs", "Rt", "Ps", "Pt", "frame_global")}}
            emit(StageResult(k, what, acc.mean_map(), acc.temporal_var_map(), acc.n_frames, dark=(what == "dark"),
                             components={"full": view}))
        emit(Done(None, {"results": {"images analysed": f"{sum(a.n_frames for a in accs)} frames in "
                                                        f"{time.monotonic() - t0:.1f} s"}}))
