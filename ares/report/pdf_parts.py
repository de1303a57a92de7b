"""The report PDF drawn by two processes: this one and a helper, merged page by page.

matplotlib draws a page in pure Python under the GIL (0.2-0.9 s a page), so the second
core can only help from another process. The helper is started early (``start``: by
``ares run`` with the scan, niced, or by ``write_reports``) and imports matplotlib and
the report modules meanwhile. ``Helper.go`` hands it a work directory before this
process imports its own; from then on both plan the same pages from the run directory
(``pdf.page_plan`` is deterministic from it) and *claim* them, heaviest first, by
creating ``claimNNN`` in the work directory (``O_CREAT|O_EXCL``: exactly one process
gets each page). Whoever is ready first draws the most: no guess of either's speed.
Each writes the pages it drew into its own PDF plus a JSON of their numbers and the
plan's fingerprint (run directory + titles); this process merges them in page order with
pypdf (pages are copied, nothing redrawn).

When the helper cannot be started, fails, hangs past ``HELPER_TIMEOUT_S`` or planned
another run's pages, this process draws every page it does not hold: the report is the
same, only slower. ``ARES_PDF_HELPER=0`` turns it off.

The helper's command line: ``python -m ares.report.pdf_parts RUN_DIR [--background]
[--parent PID]``; it reads one line on stdin, the work directory (none: it exits).

The helper never outlives the run: it runs in its own process group (a Ctrl-C at the
terminal reaches only the run, which then ends it), ``kill`` ends and reaps it on every
path that abandons the report, and on Linux it asks the kernel to kill it when its
parent dies (``PR_SET_PDEATHSIG``: a SIGKILLed run leaves no helper drawing pages).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

log = logging.getLogger(__name__)

# drawing cost of a page, relative (matplotlib, the shipped scan's report): claim order
WEIGHTS = {"maps": 2.0, "snr": 1.7, "ptc": 1.4, "stages": 1.0, "defect map": 0.4}  # (measured, 2026-11-26)
HELPER_TIMEOUT_S = 600.0
MIN_PAGES = 4  # fewer pages: not worth a merge


class Helper:
    def __init__(self, run_dir: Path, background: bool = False):
        self.workdir: Path | None = None
        self.err = tempfile.TemporaryFile()  # not a pipe: a chatty helper cannot block on it
        self.proc = subprocess.Popen([sys.executable, "-m", "ares.report.pdf_parts", str(run_dir),
                                      "--parent", str(os.getpid())] + (["--background"] if background else []),
                                     stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self.err, text=True,
                                     process_group=0)

    def go(self, workdir: Path) -> None:
        """Start drawing into ``workdir`` (created here)."""
        workdir.mkdir(parents=True, exist_ok=True)
        self.workdir = workdir
        try:
            self.proc.stdin.write(f"{workdir}\n")
            self.proc.stdin.close()
        except OSError:  # it died already: this process draws everything
            pass

    def wait(self) -> bool:
        """True when the helper ended normally."""
        try:
            self.proc.wait(timeout=HELPER_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self.proc.returncode != 0:
            self.err.seek(0)
            log.warning("report helper failed (exit %s): %s", self.proc.returncode,
                        self.err.read().decode(errors="replace").strip()[-500:])
        return self.proc.returncode == 0

    def kill(self) -> None:
        """End the helper (and anything it started) now, and reap it: the report is abandoned."""
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except OSError:
                self.proc.kill()
            self.proc.wait()
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        self.err.close()

    def close(self) -> None:
        """End a helper that was not (or no longer) needed."""
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()
            except OSError:
                pass
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.err.close()


def start(run_dir, background: bool = False) -> Helper | None:
    """A helper process for the report of ``run_dir`` (None when turned off or impossible).
    ``background``: started with the scan, it imports at a lower CPU priority (niceness
    +5): it takes mostly the cycles the scan leaves."""
    if os.environ.get("ARES_PDF_HELPER", "1") == "0" or (os.cpu_count() or 1) < 2:
        return None
    try:
        return Helper(Path(run_dir), background)
    except OSError as exc:
        log.warning("report helper not started: %s", exc)
        return None


def fingerprint(titles: list[str], run_dir) -> str:
    """What both processes must agree on: the run directory and the page titles."""
    return hashlib.sha1("\n".join([str(Path(run_dir).resolve()), *titles]).encode()).hexdigest()


def weight(title: str) -> float:
    return next((w for k, w in WEIGHTS.items() if title.startswith(k)), 1.0)


def claim_order(titles: list[str]) -> list[int]:
    """The order both processes claim pages in: the heaviest first."""
    return sorted(range(len(titles)), key=lambda i: -weight(titles[i]))


def draw_claimed(run, pages, workdir: Path, who: str) -> list[int]:
    """Draw every page of the plan this process can claim into ``workdir/WHO.pdf``; its
    page numbers (in drawing order) and the plan's fingerprint go to ``WHO.json`` once
    the PDF is complete. Returns the page numbers."""
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages

    from ares.report import plots
    from ares.report.pdf import draw_page

    titles = [t for t, _ in pages]
    drawn: list[int] = []
    tmp = workdir / f"{who}.pdf.tmp"
    with matplotlib.rc_context(plots.RC), PdfPages(tmp) as pdf:
        for i in claim_order(titles):
            try:
                os.close(os.open(workdir / f"claim{i:03d}", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            except FileExistsError:
                continue
            pdf.savefig(draw_page(run, pages, i))
            drawn.append(i)
    if drawn:
        tmp.replace(workdir / f"{who}.pdf")
    else:  # the other process claimed every page first (matplotlib writes no file for no page)
        tmp.unlink(missing_ok=True)
    (workdir / f"{who}.json.tmp").write_text(json.dumps({"pages": drawn, "plan": fingerprint(titles, run.dir)}))
    (workdir / f"{who}.json.tmp").replace(workdir / f"{who}.json")
    return drawn


def _helper_part(workdir: Path, plan: str) -> list[int] | None:
    """The helper's page numbers when its part is complete and of this plan (none: it
    drew no page, and has no PDF)."""
    try:
        d = json.loads((workdir / "helper.json").read_text())
    except (OSError, ValueError):
        return None
    complete = not d["pages"] or (workdir / "helper.pdf").exists()
    return d["pages"] if d.get("plan") == plan and complete else None


def write_split(run, pages, tmp: Path, helper: Helper) -> None:
    """Draw ``pages`` into ``tmp``, the helper drawing the pages it claims first."""
    from ares.report.pdf import render

    titles = [t for t, _ in pages]
    workdir = helper.workdir
    if workdir is None or len(pages) < MIN_PAGES:
        helper.close()
        render(run, pages, range(len(pages)), tmp)
        return
    try:
        mine = draw_claimed(run, pages, workdir, "main")
        theirs = _helper_part(workdir, fingerprint(titles, run.dir)) if helper.wait() else None
        parts = [(workdir / "main.pdf", mine)]
        if theirs:
            parts.append((workdir / "helper.pdf", theirs))
        held = set(mine) | set(theirs or [])
        rest = [i for i in range(len(pages)) if i not in held]
        if rest:  # the helper's share, here (it failed, or drew another plan)
            render(run, pages, rest, workdir / "rest.pdf")
            parts.append((workdir / "rest.pdf", rest))
        merge(len(pages), parts, tmp, run.meta.get("scan_name", ""))
    except BaseException:  # a signal or an error: the helper's pages are not waited for
        helper.kill()
        raise
    finally:
        helper.close()
        shutil.rmtree(workdir, ignore_errors=True)


def merge(n: int, parts: list[tuple[Path, list[int]]], out: Path, scan_name: str) -> None:
    """Pages 0..n-1 of the report from the part files (each: path, the page numbers it
    holds in its order)."""
    from pypdf import PdfReader, PdfWriter

    where = {}
    for path, indices in parts:
        if not indices:
            continue
        reader = PdfReader(path)
        for k, i in enumerate(indices):
            where[i] = (reader, k)
    w = PdfWriter()
    for i in range(n):
        reader, k = where[i]
        w.add_page(reader.pages[k])
    w.add_metadata({"/Title": f"ARES report {scan_name}", "/Creator": "ares report"})
    with open(out, "wb") as f:
        w.write(f)


def die_with_parent(parent: int) -> bool:
    """Ask the kernel to SIGKILL this process when its parent ends (Linux); False when the
    parent is gone already (it died before the request)."""
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    return os.getppid() == parent


def main(argv: list[str]) -> int:
    if "--parent" in argv:
        k = argv.index("--parent")
        parent = int(argv[k + 1])
        argv = argv[:k] + argv[k + 2:]
        if not die_with_parent(parent):
            return 0
    if "--background" in argv:
        argv = [a for a in argv if a != "--background"]
        try:
            os.nice(5)
        except OSError:
            pass
    import h5py  # noqa: F401 -- with scipy.special: what planning the pages would import after the go (0.3 s)
    import matplotlib  # imported while the parent scans or prepares
    from scipy import special  # noqa: F401

    from ares.report import pdf, plots, tables
    from ares.report.source import read_run

    workdir = sys.stdin.readline().rstrip("\n")
    if not workdir:
        return 0
    run = read_run(argv[0])
    groups = tables.ptc_groups(run)
    kf = tables.compute_key_figures(run, groups)
    with matplotlib.rc_context(plots.RC):
        pages = pdf.page_plan(run, groups, kf, pdf.emva_sheet(run))
    draw_claimed(run, pages, Path(workdir), "helper")
    return 0


if __name__ == "__main__":
    code = main(sys.argv[1:])  # exceptions end the process as usual (traceback, exit 1)
    # the parts are written and closed, and the parent merges them only once this process
    # has ended: skip the interpreter's teardown of matplotlib & co. (~0.2 s on its path)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def write_pdf(run, path: str | Path, groups=None, kf=None, emva=None, helper=None) -> list[str]:
    """Write the report to ``path``; returns the page titles. ``helper``: a
    ``Helper`` process drawing part of the pages beside this one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    import matplotlib

    from ares.report import plots
    from ares.report.pdf import page_plan, render

    with matplotlib.rc_context(plots.RC):
        pages = page_plan(run, groups, kf, emva)
    if helper is not None:
        write_split(run, pages, tmp, helper)
    else:
        render(run, pages, range(len(pages)), tmp)
    tmp.replace(path)
    return [t for t, _ in pages]
