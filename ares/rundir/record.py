"""Reading a run directory back: ``load_run`` -> ``RunRecord`` (run.json, the stage records, scan results), and the reports' state in run.json."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from ares.errors import InputError
from ares.rundir.state import effective_status
from ares.rundir.files import dump_json, sha256, storage


@dataclass
class RunRecord:
    """A run as the directory holds it (or as the runner holds it live)."""

    dir: Path | None
    meta: dict
    scan: object  # ares.protocol.Scan
    stages: list[dict] = field(default_factory=list)

    @property
    def system(self):
        return self.scan.system

    @property
    def status(self) -> str:
        """``run.json``'s status; ``interrupted`` for a ``running`` run whose process is gone."""
        return effective_status(self.meta)[0]

    def arrays(self, index: int, names=None) -> dict:
        """Arrays of stage ``index`` from results.h5 (empty if none); ``names``: only those."""
        import h5py

        if self.dir is None or not (self.dir / "results.h5").exists():
            return {}
        with h5py.File(self.dir / "results.h5", "r") as f:
            g = f.get(f"stages/{index:04d}")
            return {} if g is None else {k: g[k][()] for k in g if names is None or k in names}


def set_reports_state(run_dir, state: str, **extra) -> None:
    """``reports`` (and ``extra``) in the run.json of a run no writer holds any more."""
    path = Path(run_dir) / "run.json"
    with storage(path):
        meta = json.loads(path.read_text())
        meta.update(extra, reports=state)
        dump_json(path, meta)


REPORT_LEFTOVERS = ("*.tmp", "report.pdf.parts", "*.pdf.parts")


def clean_report_leftovers(run_dir: Path) -> None:
    """The temporary files of report writing that a signal or a kill cut short (every
    report file is written under a temporary name and renamed: these are never complete)."""
    import shutil

    for pattern in REPORT_LEFTOVERS:
        for p in Path(run_dir).glob(pattern):
            if p.is_dir():
                shutil.rmtree(p, ignore_errors=True)
            else:
                p.unlink(missing_ok=True)


def load_run(run_dir: str | Path) -> RunRecord:
    """Read a run directory (also one whose run was killed) into a ``RunRecord``."""
    from ares.protocol import load_scan

    d = Path(run_dir)
    if not (d / "run.json").is_file():
        raise InputError(f"{d}: not an ARES run directory (no run.json)")
    try:
        meta = json.loads((d / "run.json").read_bytes())
    except (ValueError, OSError) as exc:
        raise InputError(f"{d / 'run.json'}: unreadable ({type(exc).__name__}: {exc})") from None
    if not isinstance(meta, dict):
        raise InputError(f"{d / 'run.json'}: not a run record (not a JSON object)")
    for key in ("scan_file", "system_file"):
        if not isinstance(meta.get(key), str):
            raise InputError(f"{d / 'run.json'}: names no {key.replace('_', ' ')}; not an ARES run record")
    for key in ("scan_file", "system_file"):
        p = d / meta[key]
        if not p.is_file():
            raise InputError(f"{d}: {meta[key]} is missing")
        if sha256(p.read_bytes()) != meta[key.replace("_file", "_sha256")]:
            raise InputError(f"{p}: SHA-256 differs from the one recorded in run.json (file was modified)")
    scan = load_scan(d / meta["scan_file"], system_path=d / meta["system_file"])
    if scan.system.replay is not None:  # recorded data where the run found it, not below xml/
        import dataclasses

        from ares.hardware.replay import relocate_replay

        scan = dataclasses.replace(scan, system=relocate_replay(scan.system, meta.get("bench")))
    stages = [_stage_json(p) for p in sorted((d / "stages").glob("[0-9][0-9][0-9][0-9].json"))]
    return RunRecord(d, meta, scan, stages)


def _stage_json(p: Path) -> dict:
    """A committed stage's record, or one sentence naming its file (cut short, damaged)."""
    try:
        st = json.loads(p.read_bytes())
    except (ValueError, OSError) as exc:  # (JSONDecodeError and UnicodeDecodeError are ValueErrors)
        raise InputError(f"{p}: the stage record is damaged or cut short ({type(exc).__name__}); the run directory "
                         "cannot be read as written") from None
    if not isinstance(st, dict) or not isinstance(st.get("index"), int):
        raise InputError(f"{p}: not a stage record (no stage index); the run directory cannot be read as written")
    return st
