"""The items of a batch and what is computed for each, on whichever worker gets it.

An item is a run directory (``run.json``), an EMVA 1288 descriptor file, or a frame stack
(anything ``ares analyze`` reads: image folder, ``.npy``, ``.npz``, ``file.h5:/dataset``).
``process`` is the task a worker runs: content hash -> cache hit, or analysis -> cache
entry. Its key figures are exactly what ``ares report`` (run directories), ``ares emva``
(descriptors, Release 4.0 Linear) or ``ares analyze`` (stacks) give for the item alone.
A failure is returned as one sentence, never raised: one bad item does not stop a lot.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from pathlib import Path

RUN, EMVA, STACK = "run", "emva", "stack"
# files ``ares report`` writes into a run directory: outputs, not inputs of the analysis
REPORT_OUTPUTS = {"report.pdf", "report.h5", "ptc.csv", "components.csv", "levels.csv", "key_figures.csv",
                  "emva_datasheet.pdf", "emva_datasheet.csv"}


def _file(path: str | Path) -> Path:
    from ares.hardware.stackfiles import split_spec

    return split_spec(str(path))[0]


def kind_of(path: str | Path) -> str:
    p = _file(path)
    if p.is_dir() and (p / "run.json").is_file():
        return RUN
    if p.is_file() and p.suffix.lower() == ".txt":
        return EMVA
    return STACK


def _files(path: Path, kind: str) -> list[Path]:
    """The files whose bytes the item's results depend on, in a fixed order."""
    if kind == RUN:
        return sorted(f for f in path.rglob("*") if f.is_file() and f.name not in REPORT_OUTPUTS
                      and not f.name.endswith(".tmp"))
    if kind == EMVA:
        from ares.hardware.emva_descriptor import read_descriptor

        d = read_descriptor(path)
        return [path] + sorted({p for lv in d.levels for p in lv.images})
    p = _file(path)
    return sorted(f for f in p.iterdir() if f.is_file()) if p.is_dir() else [p]


BLOCK = 1 << 16  # the cheap key reads this much at each end of every file


def content_hash(path: str | Path, kind: str, full: bool = True) -> str:
    """SHA-256 over the item's input files (relative names and bytes), the item spec and the
    ARES version: a changed file, a changed dataset name or a new ARES recomputes.

    ``full=False`` is the cheap cache key: each file's size and modification time plus its
    first and last ``BLOCK`` bytes (a rewrite that keeps size, time and both ends is not seen
    -- ``ares batch --verify`` uses the full hash)."""
    from ares import __version__

    path = Path(path)
    h = hashlib.sha256(f"{kind}\0{__version__}\0{'full' if full else 'quick'}\0{Path(str(path)).name}\0".encode())
    base = path if path.is_dir() else path.parent
    for f in _files(path, kind):
        h.update(str(f.relative_to(base) if f.is_relative_to(base) else f.name).encode() + b"\0")
        with open(f, "rb") as fh:
            if full:
                for chunk in iter(lambda: fh.read(1 << 20), b""):
                    h.update(chunk)
                continue
            st = os.fstat(fh.fileno())
            h.update(f"{st.st_size}\0{st.st_mtime_ns}\0".encode())
            h.update(fh.read(BLOCK))
            if st.st_size > BLOCK:
                fh.seek(max(BLOCK, st.st_size - BLOCK))
                h.update(fh.read(BLOCK))
    return h.hexdigest()


def _figures_of_run(path: Path) -> tuple[dict, str]:
    from ares.report import read_run, tables

    run = read_run(path, verify_arrays=True)  # incomplete / corrupt: the item's one line (ares.rundir.check)
    from ares.rundir import manifest
    from ares.rundir.check import RunDamaged

    found = manifest.problems(run.dir, by=manifest.REPORT)  # (the run's own files: read_run checked them)
    if found:
        raise RunDamaged(manifest.sentence(run.dir, found) + f"; `ares report {run.dir}` writes the reports anew")
    kf = tables.compute_key_figures(run)
    return ({k: {"label": v["label"], "value": v["value"], "se": v["se"], "unit": v["unit"],
                 "verdict": v.get("verdict", ""), "note": v["note"], **({"exact": v["exact"]} if v.get("exact") else {})}
            for k, v in kf.items()}, run.status)


def _figures_of_descriptor(path: Path) -> tuple[dict, str]:
    from ares.analysis.emva.sheet import SYMBOLS
    from ares.results.descriptor import analyse_descriptor

    sheet = analyse_descriptor(path).sheet
    return ({k: {"label": f"EMVA 1288 4.0 {SYMBOLS.get(k, k)}", **e.to_dict()} for k, e in sheet.values.items()},
            "done")


def _figures_of_stack(spec: str) -> tuple[dict, str]:
    from ares.analysis.noise.accumulate import StackAccumulator
    from ares.analysis.noise.decompose import StackAnalysis
    from ares.hardware.stackfiles import iter_frames
    from ares.labels import COMPONENTS

    acc = None
    for f in iter_frames([spec]):
        if acc is None:
            acc = StackAccumulator(f.shape)
        acc.add(f)
    comps = StackAnalysis(acc).components()
    return {k: {"label": COMPONENTS.get(k, k), **e.to_dict()} for k, e in comps.items()}, "done"


def analyse(path: str | Path, kind: str) -> tuple[dict, str]:
    """(key figures {name: {label, value, se, unit, ...}}, the item's run status)."""
    if kind == RUN:
        return _figures_of_run(Path(path))
    if kind == EMVA:
        from ares.batch.vocabulary import canonical_figures

        figures, status = _figures_of_descriptor(Path(path))
        return canonical_figures(figures), status
    return _figures_of_stack(str(path))


def _clean(o):
    if isinstance(o, float) and not math.isfinite(o):
        return None
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    return o


def one_line(path: str, exc: BaseException) -> str:
    """A worker's failure as one sentence naming the item (never a traceback)."""
    from ares.errors import AresError

    msg = " ".join(str(exc).split()) or type(exc).__name__
    if not isinstance(exc, (AresError, OSError)):
        msg = f"{type(exc).__name__}: {msg}"
    return msg if str(path) in msg else f"{path}: {msg}"


def process(path: str, cache_dir: str | None = None, verify: bool = False) -> dict:
    """The worker task: {item, kind, hash, key, status, figures, cached, started, ares_version}
    or {item, status "error", error}. ``hash`` is the full content hash (traceability; only
    computed when the item is analysed or ``verify``), ``key`` the cheap cache key. The cache
    entry (``<cache_dir>/<key>.json``) is written atomically."""
    import datetime

    from ares import __version__

    item = {"item": str(path), "ares_version": __version__,
            "started": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")}
    try:
        if not _file(path).exists():
            raise FileNotFoundError(f"{path}: no such file or directory on worker {os.uname().nodename} "
                                    "(the workers must see the client's files, e.g. on a shared file system)")
        kind = kind_of(path)
        item["kind"] = kind
        digest = content_hash(path, kind, full=verify)
        entry = Path(cache_dir) / f"{digest}.json" if cache_dir else None
        if entry is not None and entry.is_file():
            try:
                return {**json.loads(entry.read_text()), "item": str(path), "cached": True}
            except (OSError, json.JSONDecodeError):
                pass  # an unreadable cache entry is recomputed
        item["hash"] = digest if verify else content_hash(path, kind)
        figures, status = analyse(path, kind)
        out = _clean({**item, "status": status, "figures": figures, "cached": False})
        if entry is not None:
            entry.parent.mkdir(parents=True, exist_ok=True)
            tmp = entry.with_name(f"{entry.name}.{os.getpid()}.tmp")
            tmp.write_text(json.dumps(out))
            tmp.replace(entry)
        return out
    except Exception as exc:  # noqa: BLE001 -- any failure of one item is that item's one line
        return {**item, "status": "error", "error": one_line(path, exc)}


def rerun(path: str, out_root: str, cache_dir: str | None = None, verify: bool = False) -> dict:
    """The worker task of ``ares batch --rerun``: repeat a run from its directory alone (as
    ``ares rerun``: verbatim XML, seed, frame override) into ``out_root``, then analyse the new
    run; the result says how many stage results reproduce the original's. A run on hardware
    needs that hardware at the worker that gets it."""
    from ares.rundir.compare import compare, original_damage
    from ares.scan import Runner, load_run

    try:
        rec = load_run(path)
        damage = original_damage(rec)  # (the rerun runs all the same: it needs only the verbatim XML)
        root = Path(out_root)
        root.mkdir(parents=True, exist_ok=True)
        out = root / Path(path).name
        k = 1
        while out.exists():
            out, k = root / f"{Path(path).name}_{k}", k + 1
        outcome = Runner(rec.scan, out_dir=out, seed=rec.meta.get("seed"),
                         frames=rec.meta.get("frames_override")).run()
        same, n, diff = compare(rec, load_run(outcome.run_dir))
    except Exception as exc:  # noqa: BLE001 -- one line per item, never a traceback
        return {"item": str(path), "status": "error", "error": one_line(path, RuntimeError(f"rerun failed ({exc})"))}
    res = process(str(outcome.run_dir), cache_dir, verify)
    res.update(rerun_of=str(path), reproduced=f"{same}/{n}", differ=diff[:5])
    if damage:  # the original is not what was written: the item fails, saying so (and what the rerun gave)
        res.update(status="error", error=f"{damage} (its rerun {outcome.run_dir}: {same} of {n} stage(s) and "
                                         f"their arrays reproduce the recorded ones)")
    return res
