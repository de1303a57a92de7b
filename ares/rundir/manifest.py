"""Integrity of every file a run wrote: ``manifest.json``, each file's SHA-256 and size.

The stage files have their own records (``ares.rundir.check``); the manifest covers the
whole directory: the verbatim XML, the stages and their arrays, ``results.h5``, raw frames,
``summary.csv``, ``scan_results.json`` -- recorded by the writer when the run ends
(``sweep``) -- and the reports (``report.h5``, ``report.pdf``, the CSV tables, the EMVA
datasheets), recorded by whoever writes them (``record``, ``by="report"``). Not in it:
``run.json`` (its state changes after the end: reports, heartbeat), the manifest itself,
the claim file and temporary files.

``problems`` names every recorded file that is missing or altered (size, or with
``hashes`` the SHA-256); ``ares report``, ``ares batch`` and ``ares rerun`` / ``ares batch
--rerun`` say them all, and ``ares report`` says which altered report it writes anew. A run
written before manifests has none: nothing more is checked than before.

Imports nothing of the project but its errors and ``rundir.files``.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

MANIFEST = "manifest.json"
NOT_RECORDED = ("run.json", MANIFEST, ".ares-claim")
TEMPORARY = (".tmp", ".partial", ".parts")
RUN, REPORT = "run", "report"


def file_sha256(p: Path) -> str:
    h = hashlib.sha256()
    with open(p, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _recordable(d: Path, p: Path) -> bool:
    rel = p.relative_to(d)
    return p.is_file() and str(rel) not in NOT_RECORDED and not any(
        part.endswith(TEMPORARY) for part in rel.parts)


def load(d: Path) -> dict:
    """The manifest's ``files`` ({relative path: {sha256, bytes, by}}); {} when there is none
    (or it cannot be read: then ``problems`` says so)."""
    p = Path(d) / MANIFEST
    try:
        doc = json.loads(p.read_text())
        files = doc["files"]
        return files if isinstance(files, dict) else {}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def _entry(p: Path, by: str) -> dict:
    return {"sha256": file_sha256(p), "bytes": p.stat().st_size, "by": by}


def _write(d: Path, files: dict) -> None:
    from ares.rundir.files import dump_json, storage

    with storage(d / MANIFEST):
        dump_json(d / MANIFEST, {"format": "ares-manifest/1", "files": dict(sorted(files.items()))})


def sweep(d: Path) -> None:
    """Record every file now in the run directory as the run's own (the writer, at the end)."""
    d = Path(d)
    old = load(d)
    files = {str(p.relative_to(d)): _entry(p, old.get(str(p.relative_to(d)), {}).get("by", RUN))
             for p in sorted(d.rglob("*")) if _recordable(d, p)}
    _write(d, files)


def record(d: Path, paths, by: str = REPORT) -> None:
    """Add (or renew) the files ``paths`` that lie inside the run directory ``d``."""
    d = Path(d).resolve()
    files = load(d)
    changed = False
    for p in paths:
        p = Path(p).resolve()
        try:
            rel = p.relative_to(d)
        except ValueError:
            continue  # written elsewhere (--pdf FILE, --out DIR): not the run's
        if _recordable(d, p):
            files[str(rel)] = _entry(p, by)
            changed = True
    if changed:  # (reports written elsewhere: the run directory is not touched, read-only or not)
        _write(d, files)


def restore(d: Path, entries: dict) -> None:
    """Put recorded entries back as they were ({relative path: entry}): a file a resume found
    altered and left as it was stays recorded as altered, not re-blessed by the new sweep.
    Nothing when the directory has no manifest (then nothing was recorded anew either)."""
    d = Path(d)
    if entries and (d / MANIFEST).exists():
        _write(d, {**load(d), **entries})


def forget(d: Path) -> None:
    """No manifest (a run being resumed writes again: the writer sweeps at its end)."""
    (Path(d) / MANIFEST).unlink(missing_ok=True)


def problems(d: Path, hashes: bool = True, by: str | None = None) -> list[tuple[str, str]]:
    """(relative path, what is wrong) for every recorded file (written ``by`` run or report,
    or both) that is missing, or whose size -- and with ``hashes`` SHA-256 -- differs."""
    d = Path(d)
    out = []
    if (d / MANIFEST).exists() and not load(d):
        return [(MANIFEST, "unreadable")]
    for rel, e in load(d).items():
        if by is not None and e.get("by", RUN) != by:
            continue
        p = d / rel
        if not p.is_file():
            out.append((rel, "missing"))
        elif p.stat().st_size != e.get("bytes"):
            out.append((rel, f"altered ({p.stat().st_size} bytes, {e.get('bytes')} when written)"))
        elif hashes and file_sha256(p) != e.get("sha256"):
            out.append((rel, "altered (its SHA-256 differs from the one recorded when it was written)"))
    return out


def sentence(d: Path, found: list[tuple[str, str]]) -> str:
    """Every problem in one sentence naming the files."""
    return f"{d}: not as written: " + "; ".join(f"{rel} {what}" for rel, what in found) + \
        f" (recorded in {MANIFEST})"
