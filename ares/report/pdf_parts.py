"""The report PDF drawn by two processes: this one and a helper, merged page by page.

matplotlib draws a page in pure Python under the GIL (0.2-0.9 s a page), so the second
core can only help from another process. ``write_reports`` starts the helper first
(``start``): it imports matplotlib and the report modules while this process imports
its own and plans the pages. Both plan the same pages from the run directory
(``pdf.page_plan`` is deterministic from it; the helper checks the titles it was sent
against its own plan); the helper draws the share it is given into a PDF of its own, this
process draws the rest, and the two are merged in page order with pypdf (pages are
copied, nothing redrawn).

When the helper cannot be started, fails, or plans other pages, this process draws its
pages too: the report is the same, only slower. ``ARES_PDF_HELPER=0`` turns it off.

The helper's command line: ``python -m ares.report.pdf_parts RUN_DIR``; it reads one
request line ``PATH<TAB>I,J,K<TAB>TITLES_SHA1`` on stdin (none: exit).
"""

from __future__ import annotations

import hashlib
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

log = logging.getLogger(__name__)

# drawing cost of a page in seconds (matplotlib, one core, the shipped scan's report)
WEIGHTS = {"maps": 0.75, "ptc": 0.45, "snr": 0.45, "stages": 0.35, "defect map": 0.3}
WEIGHT = 0.25  # any other page
HELPER_IMPORT_S = 1.6  # python + numpy + scipy + matplotlib + the report modules (this process has them)
MIN_PAGES = 4  # fewer pages: one process is as fast


class Helper:
    def __init__(self, run_dir: Path, background: bool = False):
        self.t0 = time.monotonic()
        self.err = tempfile.TemporaryFile()  # not a pipe: a chatty helper cannot block on it
        self.proc = subprocess.Popen([sys.executable, "-m", "ares.report.pdf_parts", str(run_dir)]
                                     + (["--background"] if background else []),
                                     stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self.err, text=True)

    def request(self, path: Path, indices: list[int], titles: list[str], run_dir: Path) -> None:
        self.proc.stdin.write(f"{path}\t{','.join(map(str, indices))}\t{titles_sha1(titles, run_dir)}\n")
        self.proc.stdin.close()

    def wait(self) -> bool:
        """True when the helper drew its pages."""
        self.proc.wait()
        if self.proc.returncode != 0:
            self.err.seek(0)
            log.warning("report helper failed (exit %s): %s", self.proc.returncode,
                        self.err.read().decode(errors="replace").strip()[-500:])
        return self.proc.returncode == 0

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
    +10) so that it takes the cycles the scan leaves, not the scan's."""
    if os.environ.get("ARES_PDF_HELPER", "1") == "0" or (os.cpu_count() or 1) < 2:
        return None
    try:
        return Helper(Path(run_dir), background)
    except OSError as exc:
        log.warning("report helper not started: %s", exc)
        return None


def titles_sha1(titles: list[str], run_dir) -> str:
    """What both processes must agree on: the run directory and the page titles."""
    return hashlib.sha1("\n".join([str(Path(run_dir).resolve()), *titles]).encode()).hexdigest()


def weight(title: str) -> float:
    return next((w for k, w in WEIGHTS.items() if title.startswith(k)), WEIGHT)


def split(titles: list[str], own_delay: float = 0.0, helper_delay: float = 0.0) -> tuple[list[int], list[int]]:
    """(this process's pages, the helper's pages): the heaviest first to the one that
    would finish first, each starting after its delay (seconds of imports left)."""
    load = [own_delay, helper_delay]
    share: tuple[list[int], list[int]] = ([], [])
    for i in sorted(range(len(titles)), key=lambda i: -weight(titles[i])):
        k = 0 if load[0] <= load[1] else 1
        share[k].append(i)
        load[k] += weight(titles[i])
    return sorted(share[0]), sorted(share[1])


def write_split(run, pages, tmp: Path, helper: Helper) -> None:
    """Draw ``pages`` into ``tmp`` with the helper's share drawn by the helper."""
    from ares.report.pdf import render

    titles = [t for t, _ in pages]
    mine, theirs = split(titles, 0.0, max(HELPER_IMPORT_S - (time.monotonic() - helper.t0), 0.0))
    if len(pages) < MIN_PAGES or not theirs:
        helper.close()
        render(run, pages, range(len(pages)), tmp)
        return
    own, part = tmp.with_name(tmp.name + ".a"), tmp.with_name(tmp.name + ".b")
    try:
        helper.request(part, theirs, titles, run.dir)
    except OSError:  # it died already
        pass
    try:
        render(run, pages, mine, own)
        if not (helper.wait() and part.exists()):
            render(run, pages, theirs, part)  # the helper's share, here
        merge(len(pages), [(own, mine), (part, theirs)], tmp, run.meta.get("scan_name", ""))
    finally:
        for p in (own, part):
            p.unlink(missing_ok=True)


def merge(n: int, parts: list[tuple[Path, list[int]]], out: Path, scan_name: str) -> None:
    """Pages 0..n-1 of the report from the part files (each: path, the page numbers it holds)."""
    from pypdf import PdfReader, PdfWriter

    where = {}
    for path, indices in parts:
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


def main(argv: list[str]) -> int:
    if "--background" in argv:
        argv = [a for a in argv if a != "--background"]
        try:
            os.nice(10)
        except OSError:
            pass
    import matplotlib  # imported while the parent prepares

    from ares.report import pdf, plots, tables
    from ares.report.source import read_run

    line = sys.stdin.readline().rstrip("\n")
    if not line:
        return 0
    path, indices, sha = line.split("\t")
    run = read_run(argv[0])
    groups = tables.ptc_groups(run)
    kf = tables.compute_key_figures(run, groups)
    with matplotlib.rc_context(plots.RC):
        pages = pdf.page_plan(run, groups, kf, pdf.emva_sheet(run))
    if titles_sha1([t for t, _ in pages], run.dir) != sha:
        sys.stderr.write("the helper planned other pages than the report\n")
        return 3
    pdf.render(run, pages, [int(i) for i in indices.split(",") if i], Path(path))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
