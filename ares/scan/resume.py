"""Continue an interrupted run from its first missing stage (``ares resume RUN_DIR``).

What an uninterrupted run would have at that point is rebuilt from the run directory
alone: the verbatim scan and system XML and the seed (``run.json``), the defect mask
(the HDF5 of the stage it was built from), the bench's settings at the end of the last
committed stage (checked against its register snapshot), the frame stream's position
(``bench_position`` in each stage JSON: the simulator's frame counter and RTS trap states)
and the dark a later stage reuses (grabbed again at its recorded position: on the
simulator the same frames, bit for bit). Stages committed with a provisional defect mask
(no flat had completed it yet, ``ares.scan.mask_complete``) are acquired again from the
mask's dark stage, recorded in run.json (``resumed[].acquired_again``). The resumed stages are then identical to those
of an uninterrupted run with the same seed. A real sensor cannot replay frames: its
resumed stages are new measurements at the same settings, and the run records that.
"""

from __future__ import annotations

import math

from ares.errors import InputError
from ares.scan.apply import apply_settings


def resumable(run) -> list[dict]:
    """The committed stages to resume after, or one sentence why the run cannot be resumed."""
    from ares.rundir.state import effective_status

    status, _ = effective_status(run.meta)
    if status == "running":
        raise InputError(f"{run.dir}: the run is still running (process {run.meta.get('pid')} on "
                         f"{run.meta.get('host')}); stop it first")
    stages = sorted(run.stages, key=lambda s: s["index"])
    for k, st in enumerate(stages):  # (first: a complete run with a stage taken out is not complete)
        if st["index"] != k:
            raise InputError(f"{run.dir}: stage {k} is missing but stage {st['index']} is there; the run "
                             "directory was edited and cannot be resumed")
    if status == "done":
        raise InputError(f"{run.dir}: the run is complete ({len(run.stages)} stage(s)); nothing to resume")
    # stages committed with a provisional defect mask (ares.scan.mask_complete: the run ended
    # before a flat completed it) are acquired again from the mask's dark stage: their kept
    # frames are gone, and an uninterrupted run masks them with the completed mask
    first = next((k for k, st in enumerate(stages) if (st.get("defect_mask") or {}).get("provisional")), None)
    return stages if first is None else stages[:first]


def _mask_of(runner, completed: list[dict]):
    from ares.scan.defect_mask import DefectMask

    summ = next((s["defect_mask"] for s in completed if s.get("defect_mask")), None)
    if not summ:
        return None
    import h5py

    for st in completed:
        path = runner.out_dir / "stages" / f"{st['index']:04d}.h5"
        if not path.exists():
            continue
        with h5py.File(path, "r") as f:
            if "defect_mask" in f:
                return DefectMask(f["defect_mask"][()].astype(bool), summ["mask_source"],
                                  dict(summ.get("mask_classes") or {}), unseen=dict(summ.get("mask_incomplete") or {}))
    raise InputError(f"{runner.out_dir}: the stages used a defect mask that is not in their HDF5 files "
                     "(hdf5=\"false\"?); the run cannot be resumed with the same figures")


def _seek(bench, pos) -> bool:
    fn = getattr(bench.frames, "seek", None)
    if pos is None or not callable(fn):
        return False
    fn(pos)
    return True


def restore(runner, bench, completed: list[dict], vw, max_code):
    """(cached dark StackSet or None, the settings now applied, the defect mask or None,
    a note for run.json: register differences, or that the frames could not be replayed)."""
    system, stages = runner.system, runner.stages
    mask = _mask_of(runner, completed)
    runner._mask = mask
    replayed = True
    cache = None
    nxt = stages[len(completed)] if len(completed) < len(stages) else None
    if nxt is not None and nxt.dark_source == "reuse":
        for res in reversed(completed):
            stg = stages[res["index"]]
            kind = "flat" if stg.scene == "dark" else "dark" if stg.dark_source == "grab" else None
            if kind is None:
                continue
            settings = stg.settings if kind == "flat" else stg.dark_settings
            apply_settings(bench, system, settings, None)
            replayed &= _seek(bench, (res.get("bench_position") or {}).get(kind))
            n = stg.frames if kind == "flat" else stg.dark_frames
            cache = runner._grab(bench, stg, n, vw, max_code, None, dark=(kind == "dark"))
            break
    last = completed[-1]
    apply_settings(bench, system, last["settings"], None)
    replayed &= _seek(bench, (last.get("bench_position") or {}).get("end"))
    note = {}
    want = last.get("registers_after") or {}
    have = bench.registers.snapshot()
    diff = {k: (want[k], have.get(k)) for k in want
            if not (isinstance(want[k], (int, float)) and isinstance(have.get(k), (int, float))
                    and math.isclose(want[k], have[k], rel_tol=1e-9, abs_tol=1e-12))}
    diff = {k: v for k, v in diff.items() if k not in ("frame_count", "temperature_sensor")}
    if diff:
        note["register_differences"] = {k: {"recorded": a, "now": b} for k, (a, b) in diff.items()}
    if not replayed:
        note["frames"] = ("the frame source cannot replay its stream: resumed stages are new measurements at the "
                          "same settings")
    return cache, dict(last["settings"]), mask, note
