"""Integrity of a run directory: content hashes recorded as each stage is written, checked
when the run is read.

What the writer (``ares.rundir.writer``) records, hashing bytes it holds in memory anyway:

- in each stage's JSON (written after its HDF5): ``arrays_sha256`` -- ``{array name: SHA-256}``
  of every array of ``stages/NNNN.h5`` (``array_sha256``: dtype, shape and the C-order bytes,
  so the HDF5 filters do not matter) -- and ``h5_bytes``, that file's size;
- in ``run.json``: ``stage_sha256`` -- ``{"NNNN": SHA-256 of stages/NNNN.json}``; while a
  committed stage is rewritten (``RunWriter.replace_stage``) ``stage_sha256_replacing`` holds
  the new file's hash too, and either is accepted.

``check_run`` says what is wrong in one sentence, naming the stage and the file:
``incomplete: stage N ...`` (a recorded stage, or its arrays, deleted) or ``corrupt: stage N
...`` (a stage file modified, an HDF5 truncated or unreadable, an array whose bytes differ
from its recorded hash). ``ares report``, ``ares batch`` and ``ares rerun`` / ``ares batch
--rerun`` check before they report figures. A run written before these records is checked
for missing stages only (``run.json``'s ``stages_completed``).

Imports nothing of the project but its errors: the writer and the report both use it.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from ares.errors import InputError


class RunDamaged(InputError):
    """A run directory that is incomplete or corrupt (one sentence naming the stage)."""


def array_sha256(a) -> str:
    """SHA-256 of an array's dtype, shape and C-order bytes (what h5py reads back, whatever
    the dataset's chunking or compression)."""
    import numpy as np

    a = np.ascontiguousarray(a)
    h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
    h.update(memoryview(a).cast("B") if a.size else b"")
    return h.hexdigest()


def _stage_name(d: Path, key: str) -> str:
    try:
        return f" ('{json.loads((d / 'stages' / f'{key}.json').read_text())['name']}')"
    except Exception:  # noqa: BLE001 -- the name only decorates the sentence
        return ""


def _rerun(d: Path) -> str:
    return f"; `ares rerun {d}` makes the run again"


def check_stage_files(d: Path, meta: dict) -> None:
    """The stage JSON files against ``run.json``: every recorded stage present, byte for byte.
    A run without records: no completed stage missing."""
    d = Path(d)
    present = {p.stem for p in (d / "stages").glob("[0-9][0-9][0-9][0-9].json")}
    recorded = meta.get("stage_sha256")
    if not isinstance(recorded, dict):  # written before the records: the count is all there is
        expected = {f"{i:04d}" for i in range(int(meta.get("stages_completed") or 0))}
        missing = sorted(expected - present)
        if missing:
            raise RunDamaged(f"{d}: incomplete: stage {int(missing[0])} is missing (stages/{missing[0]}.json; "
                             f"run.json counts {len(expected)} completed stage(s), {len(expected & present)} are "
                             f"there){_rerun(d)}")
        return
    for key in sorted(recorded):
        p = d / "stages" / f"{key}.json"
        if key not in present:
            raise RunDamaged(f"{d}: incomplete: stage {int(key)} is missing (stages/{key}.json, recorded in "
                             f"run.json when it was written, is gone){_rerun(d)}")
        replacing = (meta.get("stage_sha256_replacing") or {}).get(key)  # a rewrite cut short after its file
        if hashlib.sha256(p.read_bytes()).hexdigest() not in (recorded[key], replacing):
            raise RunDamaged(f"{d}: corrupt: stage {int(key)}{_stage_name(d, key)}: stages/{key}.json differs from "
                             f"the SHA-256 recorded in run.json when it was written{_rerun(d)}")
    if meta.get("status") == "done":
        extra = sorted(present - set(recorded))
        if extra:
            raise RunDamaged(f"{d}: corrupt: stage {int(extra[0])}: stages/{extra[0]}.json was not written by this "
                             f"run (run.json does not record it){_rerun(d)}")


def check_stage_arrays(d: Path, stage: dict, arrays: bool = True) -> None:
    """One stage's HDF5 against the hashes its JSON recorded: present, not truncated,
    readable, and (``arrays``) every array's bytes as written."""
    recorded = stage.get("arrays_sha256")
    if not isinstance(recorded, dict):
        return
    key = f"{int(stage['index']):04d}"
    what = f"stage {int(key)} ('{stage.get('name', '')}')"
    rel = f"stages/{key}.h5"
    p = Path(d) / rel
    if not p.is_file():
        raise RunDamaged(f"{d}: incomplete: {what}: its arrays ({rel}) are missing{_rerun(d)}")
    size, want = p.stat().st_size, stage.get("h5_bytes")
    if isinstance(want, int) and size < want:
        raise RunDamaged(f"{d}: corrupt: {what}: {rel} is truncated ({size} of {want} bytes){_rerun(d)}")
    if isinstance(want, int) and size != want:
        raise RunDamaged(f"{d}: corrupt: {what}: {rel} is {size} bytes, {want} when written{_rerun(d)}")
    if not arrays:  # (readability: results.h5's links are followed by the reader)
        return
    import h5py

    try:
        with h5py.File(p, "r") as f:
            names = set(f)
            for name in sorted(recorded):
                if name not in names:
                    raise RunDamaged(f"{d}: corrupt: {what}: array '{name}' is missing from {rel}{_rerun(d)}")
                if array_sha256(f[name][()]) != recorded[name]:
                    raise RunDamaged(f"{d}: corrupt: {what}: array '{name}' of {rel} differs from the SHA-256 "
                                     f"recorded when it was written{_rerun(d)}")
    except RunDamaged:
        raise
    except (OSError, KeyError, ValueError, RuntimeError) as exc:
        raise RunDamaged(f"{d}: corrupt: {what}: {rel} is not readable HDF5 "
                         f"({' '.join(str(exc).split())}){_rerun(d)}") from None


def check_run(d: Path, meta: dict, stages: list[dict], arrays: bool = True) -> None:
    """Raise ``RunDamaged`` (one sentence) at the first stage that is missing or differs from
    what was recorded when it was written; ``arrays=False`` skips hashing the arrays (the
    files are still checked for presence, size and readability)."""
    check_stage_files(d, meta)
    for st in stages:
        check_stage_arrays(d, st, arrays)
