"""The run directory: everything a run produced, written as it goes.

Layout (all paths relative to the run directory)::

    run.json            provenance: scan/system names, original paths, SHA-256 of the
                        verbatim XML, seed, frame override, argv, software and dependency
                        versions, bench info (simulator parameters with their defaults,
                        chip id), devices (what each bench part said it is: USB VID:PID and
                        serial, I2C bus/address/chip ID, *IDN? answers, GenICam model and
                        serial), link (each link's counts since the bench opened:
                        ares.hardware.link_stats), start/end time, status (running/done/stopped/aborted/
                        failed), message, stages completed, reports (writing /
                        complete / incomplete / failed: ``ares.rundir.state``), stage_sha256
                        (SHA-256 of each stages/NNNN.json: ``ares.rundir.check``). Rewritten
                        atomically.
    xml/<scan file>     the scan XML, byte for byte
    xml/<system file>   the system XML, byte for byte (``ares rerun`` loads these two)
    stages/NNNN.json    per completed stage: resolved settings, register snapshots
                        before/after, timing, results per view (see ares.results.registry);
                        with a defect mask also level_masked, components_masked (full view)
                        and the mask summary (defect_mask: count, source, classes);
                        arrays_sha256 (each array of NNNN.h5) and h5_bytes (``ares.rundir.check``)
    stages/NNNN.h5      HDF5 arrays of the stage: mean, variance (per-pixel temporal, DN^2),
                        frame_means, dark_mean (matched dark), hist_<view> (code histograms,
                        adc_linearity and photon_counting scans only; an ADC ramp stage's
                        also as histgroups_<view>, one row per sub-histogram), defect_mask (uint8, 1 = excluded from the
                        masked figures; on the stage the mask was built from or first used
                        with, see ares.scan.defect_mask); chunked, gzip; per frame:
                        frame_counter (the device's counter, else the source's count),
                        frame_timestamp (s), frame_temperature (C, when the device reports
                        one), dark_frame_* likewise for the matched dark; attrs name, scene,
                        settings (JSON), result (JSON)
    results.h5          HDF5 index: /stages/NNNN are external links to stages/NNNN.h5, so
                        h5py.File("results.h5")["stages/0003/mean"] just works (keep the
                        directory together). Each stage file and the index are written as
                        .tmp, fsynced and renamed: a SIGKILL at any instant leaves complete
                        files describing every completed stage
    frames/NNNN.h5      raw frames (only with <output raw_frames="true">): dataset
                        "frames" (F, rows, cols) chunked per frame, "dark" likewise;
                        written as NNNN.h5.partial and renamed when the stage completes
    summary.csv         one row per completed stage: index, name, scene, frames,
                        settings..., mean/variance and the main components of view
                        "full", every column named with its unit (exposure_s,
                        Ps_dn2: ares.labels.with_unit) (rewritten atomically per stage);
                        every HDF5 dataset carries its unit as attribute "unit"
    scan_results.json   scan-level analyses (PTC fit ...) and limit checks, at the end
    manifest.json       SHA-256 and size of every file above (and of the reports, as they
                        are written): ``ares.rundir.manifest``

Each stage's files are flushed (fsync) before the next stage starts, so killing a run
after k stages leaves k complete, readable stages. A stage commits when its JSON appears
(its HDF5 is written before it); run.json records pid, host and a heartbeat, so a run
whose process died reads as ``interrupted`` (``ares.rundir.state``) and ``ares resume``
continues it. The directory is claimed exclusively (``.ares-claim``, the writer's pid).
Disk full, read-only and quota errors end the run with one sentence (``StorageError``).
"""

from __future__ import annotations

import csv
import io
import json
import os
import threading
import time
from pathlib import Path

import numpy as np

from ares.labels import array_unit
from ares.rundir.state import Heartbeat, owner
from ares.rundir.files import (_clean, _fsync, _json_default, claim_run_dir, dump_json, json_bytes, sha256, storage,
                               versions, write_atomic)

SUMMARY_COMPONENTS = ("o", "Pt", "Ps", "Rt", "Rs", "Ct", "Cs", "frame_global")


class RunWriter:
    """Writes one run directory (see the module docstring)."""

    def __init__(self, out_dir: str | Path, scan, *, seed: int | None, frames_override: int | None,
                 argv: list[str] | None = None, save_frames: bool = False):
        self.dir = Path(out_dir)
        self._lock = threading.Lock()
        self._heartbeat: Heartbeat | None = None
        claim_run_dir(self.dir)
        with storage(self.dir):
            for sub in ("xml", "stages"):
                (self.dir / sub).mkdir(parents=True, exist_ok=True)
        self.scan = scan
        self.save_frames = save_frames
        self.rows: list[dict] = []
        self.h5_stages: list[str] = []
        scan_bytes = Path(scan.source).read_bytes()
        sys_path = Path(scan.system_path or scan.system.source)
        sys_bytes = sys_path.read_bytes()
        scan_name = Path(scan.source).name
        sys_name = sys_path.name if sys_path.name != scan_name else "system_" + sys_path.name
        with storage(self.dir):
            write_atomic(self.dir / "xml" / scan_name, scan_bytes)
            write_atomic(self.dir / "xml" / sys_name, sys_bytes)
            _copy_calibration(scan.system, sys_path, self.dir)
        self.meta = {
            "format": "ares-run/1", "scan_name": scan.name, "system_name": scan.system.name,
            "scan_file": f"xml/{scan_name}", "system_file": f"xml/{sys_name}",
            "scan_source": str(scan.source), "system_source": str(sys_path), "system_href": scan.system_href,
            "scan_sha256": sha256(scan_bytes), "system_sha256": sha256(sys_bytes),
            "seed": seed, "frames_override": frames_override, "argv": argv or [],
            "versions": versions(), "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "finished": None, "status": "running", "message": "", "stages_completed": 0, "stages_total": None,
            "save_frames": save_frames, "stage_sha256": {},
        }
        self.meta.update(owner())
        self._write_meta()
        self._heartbeat = Heartbeat(self.beat).start()

    @classmethod
    def reopen(cls, run_dir: str | Path, scan, stages: list[dict]) -> "RunWriter":
        """The writer of an interrupted run, to append its missing stages (``ares resume``)."""
        self = cls.__new__(cls)
        self.dir = Path(run_dir)
        self._lock = threading.Lock()
        self.scan = scan
        self.meta = json.loads((self.dir / "run.json").read_text())
        self.save_frames = bool(self.meta.get("save_frames"))
        self.rows = [_summary_row(st, self.scan) for st in stages]
        self.h5_stages = [f"{st['index']:04d}" for st in stages if (self.dir / "stages" / f"{st['index']:04d}.h5").exists()]
        resumed = list(self.meta.get("resumed") or [])
        resumed.append({"at": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "from_stage": len(stages),
                        "previous_status": self.meta.get("status"), "previous_message": self.meta.get("message")})
        self.meta.update(owner(), status="running", message="", finished=None, resumed=resumed)
        self.meta.pop("reports", None)  # (written again at its end)
        from ares.rundir import manifest

        manifest.forget(self.dir)  # (this run writes again: swept anew at its end)
        for leftover in (self.dir / "stages").glob("*.tmp"):  # a stage write the kill cut short
            leftover.unlink(missing_ok=True)
        from ares.rundir.record import clean_report_leftovers

        clean_report_leftovers(self.dir)  # results.h5.tmp, a report's .tmp and report.pdf.parts
        recorded = self.meta["stage_sha256"] = dict(self.meta.get("stage_sha256") or {})
        for key, new in (self.meta.pop("stage_sha256_replacing", None) or {}).items():  # a rewrite the kill cut
            p = self.dir / "stages" / f"{key}.json"  # short after its file: the file is the stage now
            if p.is_file() and sha256(p.read_bytes()) == new:
                recorded[key] = new
        dropped = self._drop_stages_from(len(stages), recorded)
        if dropped:  # committed with a provisional defect mask (ares.scan.resume): acquired again
            resumed[-1]["acquired_again"] = dropped
        elif stages:  # a kill after a stage's JSON (its commit) and before the index and summary.csv
            with storage(self.dir):  # followed: both written again from the committed stages
                if self.scan.output.hdf5:
                    self._write_index()
                if self.scan.output.csv:
                    write_atomic(self.dir / "summary.csv", summary_csv(self.rows))
        for st in stages:  # a stage committed (its JSON written) just before the kill reached run.json
            key = f"{st['index']:04d}"
            if key not in recorded:
                recorded[key] = sha256((self.dir / "stages" / f"{key}.json").read_bytes())
        self._write_meta()
        self._heartbeat = Heartbeat(self.beat).start()
        return self

    def _drop_stages_from(self, n: int, recorded: dict) -> list[int]:
        """Remove the committed stages from index ``n`` on (JSON -- the commit -- first, the
        highest index first, then their arrays and raw frames), the index and summary.csv
        rewritten: a resume that acquires them again (ares.scan.resume). Their indices."""
        gone = sorted((int(p.stem) for p in (self.dir / "stages").glob("[0-9][0-9][0-9][0-9].json")
                       if int(p.stem) >= n), reverse=True)
        with storage(self.dir / "stages"):
            for i in gone:
                (self.dir / "stages" / f"{i:04d}.json").unlink()
                recorded.pop(f"{i:04d}", None)
            for i in gone:
                for p in (self.dir / "stages" / f"{i:04d}.h5", self.dir / "frames" / f"{i:04d}.h5"):
                    p.unlink(missing_ok=True)
            if gone:
                self.h5_stages = [k for k in self.h5_stages if int(k) < n]
                if self.scan.output.hdf5:
                    self._write_index()
                if self.scan.output.csv:
                    write_atomic(self.dir / "summary.csv", summary_csv(self.rows))
        self.meta["stages_completed"] = len(self.rows)
        return sorted(gone)

    def beat(self) -> None:
        self.meta["heartbeat"] = time.time()
        self._write_meta()

    def _write_meta(self) -> None:
        link = getattr(self, "link", None)  # the bench's link totals (ares.hardware.link_stats), when it counts
        if link is not None:
            self.meta["link"] = link()
        with self._lock, storage(self.dir / "run.json"):
            dump_json(self.dir / "run.json", self.meta)

    def set_total(self, n: int) -> None:
        self.meta["stages_total"] = n
        self._write_meta()

    # -- raw frames ------------------------------------------------------------
    def frame_writer(self, index: int, shape, dtype) -> "FrameWriter | None":
        if not self.save_frames:
            return None
        (self.dir / "frames").mkdir(exist_ok=True)
        return FrameWriter(self.dir / "frames" / f"{index:04d}.h5", shape, dtype)

    # -- per stage ------------------------------------------------------------
    def add_stage(self, result: dict, arrays: dict, registers_before: dict, registers_after: dict,
                  timing: dict) -> None:
        """Commit one stage: its HDF5 first, its JSON last -- the JSON is the commit, so a
        kill between the two leaves an orphan .h5 that no reader counts (and resume
        rewrites), never a stage without its arrays."""
        self._write_stage(result, arrays, registers_before, registers_after, timing, replace=False)

    def replace_stage(self, result: dict, arrays: dict, registers_before: dict, registers_after: dict,
                      timing: dict) -> None:
        """Rewrite a committed stage in place (analysed again with the defect mask a later
        flat completed, ares.scan.mask_complete): its HDF5, then its JSON, each atomically
        (tmp -> fsync -> rename), its summary.csv row and run.json's hash of it. A kill
        between the two leaves the JSON with the provisional mask, which ``ares resume``
        acquires again."""
        self._write_stage(result, arrays, registers_before, registers_after, timing, replace=True)

    def _write_stage(self, result, arrays, registers_before, registers_after, timing, replace: bool) -> None:
        i = result["index"]
        record = dict(result, registers_before=registers_before, registers_after=registers_after, timing=timing)
        with storage(self.dir / "stages"):
            if self.scan.output.hdf5:  # its arrays' hashes go into the JSON (ares.rundir.check)
                record["arrays_sha256"], record["h5_bytes"] = self._write_stage_h5(i, result, arrays)
            key = f"{i:04d}"
            if replace:  # two-phase: run.json learns the new JSON's hash before the file changes, so a
                # kill between the two leaves a file matching one of the two recorded hashes
                # (ares.rundir.check accepts "stage_sha256_replacing"), never a "corrupt" stage
                with self._lock:
                    self.meta["stage_sha256_replacing"] = {**self.meta.get("stage_sha256_replacing", {}),
                                                           key: sha256(json_bytes(record))}
                self._write_meta()
            digest = dump_json(self.dir / "stages" / f"{key}.json", record)
            with self._lock:  # (a new dict: the heartbeat thread may be serialising the old one)
                self.meta["stage_sha256"] = {**self.meta.get("stage_sha256", {}), key: digest}
                if replace:
                    rest = {k: v for k, v in self.meta.get("stage_sha256_replacing", {}).items() if k != key}
                    if rest:
                        self.meta["stage_sha256_replacing"] = rest
                    else:
                        self.meta.pop("stage_sha256_replacing", None)
            if self.scan.output.hdf5 and not replace:
                self._write_index(f"{i:04d}")
            row = _summary_row(result, self.scan)
            if replace:
                self.rows[next(k for k, r in enumerate(self.rows) if int(r["index"]) == i)] = row
            else:
                self.rows.append(row)
            if self.scan.output.csv:
                write_atomic(self.dir / "summary.csv", summary_csv(self.rows))
        self.meta["stages_completed"] = len(self.rows)
        self.meta["heartbeat"] = time.time()
        self._write_meta()

    def _write_stage_h5(self, i: int, result: dict, arrays: dict) -> tuple[dict, int]:
        """Stage arrays into stages/NNNN.h5 (tmp -> fsync -> rename): at every instant the
        file is complete or absent. Returns each array's SHA-256 (of the bytes in memory, as
        they are written: ~1 ms a VGA float map, benchmarks/stage_write.md) and the file's size."""
        import h5py

        from ares.rundir.check import array_sha256

        name = f"{i:04d}"
        path = self.dir / "stages" / f"{name}.h5"
        tmp = path.with_name(path.name + ".tmp")
        hashes = {}
        with h5py.File(tmp, "w") as f:
            for k, a in arrays.items():
                a = np.asarray(a)
                hashes[k] = array_sha256(a)
                # float maps are written as they are: byte shuffle + gzip-1 took 60 ms a VGA
                # stage (12x the plain write) to save 18 % on float32 noise; integer maps
                # (the defect mask) shrink >10x for ~nothing (benchmarks/stage_write.md)
                packed = a.ndim == 2 and a.dtype.kind in "iub"
                ds = f.create_dataset(k, data=a, chunks=a.shape if packed and a.size else None,
                                      compression="gzip" if packed else None, compression_opts=1 if packed else None,
                                      shuffle=packed)
                if array_unit(k):
                    ds.attrs["unit"] = array_unit(k)
            f.attrs["name"] = result["name"]
            f.attrs["scene"] = result["scene"]
            f.attrs["settings"] = json.dumps(_clean(result["settings"]))
            f.attrs["result"] = json.dumps(_clean(result), default=_json_default)
        _fsync(tmp)
        size = tmp.stat().st_size
        os.replace(tmp, path)
        return hashes, size

    def _write_index(self, name: str | None = None) -> None:
        """Rewrite the small results.h5 index of external links (tmp -> fsync -> rename)."""
        import h5py

        if name is not None and name not in self.h5_stages:
            self.h5_stages.append(name)
        index = self.dir / "results.h5"
        tmp = index.with_name("results.h5.tmp")
        with h5py.File(tmp, "w") as f:
            f.attrs["scan_name"] = self.scan.name
            f.attrs["format"] = "ares-run/1"
            g = f.create_group("stages")
            for n in self.h5_stages:
                g[n] = h5py.ExternalLink(f"stages/{n}.h5", "/")
        _fsync(tmp)
        os.replace(tmp, index)

    # -- end ------------------------------------------------------------------
    def finish(self, status: str, message: str = "", scan_results: dict | None = None,
               limit_failures: list | None = None, reports: str | None = None,
               limits: dict | None = None) -> None:
        """The run's end in run.json; ``reports="writing"`` when report files are still to
        come (``ares.rundir.state``: the run reads as done only once they are complete)."""
        self.stop_heartbeat()
        if reports is not None:
            self.meta["reports"] = reports
        if scan_results is not None or limit_failures:
            doc = {"analyses": scan_results or {}, "limit_failures": list(limit_failures or [])}
            if limits is not None:  # ares.results.registry.limits_verdict: none set / not checked / failed / passed
                doc["limits"] = limits
            with storage(self.dir / "scan_results.json"):
                dump_json(self.dir / "scan_results.json", doc)
        self.meta.update(status=status, message=message, finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
        from ares.rundir import manifest

        with storage(self.dir / manifest.MANIFEST):  # every file the run wrote, with its hash
            manifest.sweep(self.dir)
        self._write_meta()

    def set_reports(self, state: str, **extra) -> None:
        """``reports`` in run.json (writing / complete / incomplete, see ``ares.rundir.state``)."""
        self.meta.update(extra, reports=state)
        self._write_meta()

    def stop_heartbeat(self) -> None:
        hb = getattr(self, "_heartbeat", None)
        if hb is not None:
            hb.stop()
            self._heartbeat = None


class FrameWriter:
    """Raw frames of one stage (chunked per frame), renamed into place on ``close``."""

    def __init__(self, path: Path, shape, dtype):
        import h5py

        self.path = path
        self.partial = path.with_name(path.name + ".partial")
        self.f = h5py.File(self.partial, "w")
        self.ds = {}
        self.shape, self.dtype = tuple(shape), dtype

    def add(self, data: np.ndarray, dark: bool = False) -> None:
        key = "dark" if dark else "frames"
        ds = self.ds.get(key)
        if ds is None:
            ds = self.ds[key] = self.f.create_dataset(key, shape=(0, *self.shape), maxshape=(None, *self.shape),
                                                      dtype=data.dtype, chunks=(1, *self.shape))
            ds.attrs["unit"] = array_unit(key)
        ds.resize(ds.shape[0] + 1, axis=0)
        ds[-1] = data

    def close(self, keep: bool = True) -> None:
        self.f.close()
        if keep:
            os.replace(self.partial, self.path)
        else:
            self.partial.unlink(missing_ok=True)


def _summary_row(result: dict, scan) -> dict:
    from ares.rundir.summary import summary_row

    return summary_row(result, scan.system.setting_units())


def summary_csv(rows: list[dict]) -> bytes:
    cols: list[str] = []
    for r in rows:
        cols += [k for k in r if k not in cols]
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    for r in rows:
        # repr(float(v)): a numpy scalar (np.float64 is a float) must not print as "np.float64(...)"
        w.writerow({k: ("" if v is None else (repr(float(v)) if isinstance(v, float) else v)) for k, v in r.items()})
    return buf.getvalue().encode()


# ------------------------------------------------------------------ reading


def _copy_calibration(system, sys_path: Path, run_dir: Path) -> None:
    """The photodiode's calibration table beside the system file's copy (``xml/``), at the
    path the system file names it by, so the run directory loads alone (an absolute path
    is left as it is; a relative one leading out of the run directory is not copied)."""
    pd = getattr(system, "photodiode", None)
    if pd is None or Path(pd.calibration).is_absolute():
        return
    target = (run_dir / "xml" / pd.calibration).resolve()
    if run_dir.resolve() not in target.parents:
        return
    target.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(target, (sys_path.parent / pd.calibration).read_bytes())
