"""Read a run directory for reporting: run.json, stages/*.json, scan_results.json,
results.h5 -- the files ``ares.rundir.writer`` writes (see its module docstring).

Read-only and independent of the scan package (the runner calls the report at the end
of a run, so the report must not import the runner). A partial run (stopped, failed,
killed) is fine: what is there is reported and ``Run.complete`` is False. A directory
that is missing, not a run, or holds unreadable files raises ``InputError`` with one
sentence naming the file.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ares.errors import InputError
from ares.rundir.state import effective_status

ATTRIBUTION = "EMVA 1288 reference data set, (C) 2011 Basler AG, CC BY-SA 3.0"
_EMVA_MARKERS = ("emva1288_referenceset", "basler")


@dataclass
class Run:
    dir: Path
    meta: dict
    stages: list[dict]
    scan_results: dict | None  # {"analyses": {...}, "limit_failures": [...]} or None
    has_h5: bool = False
    attribution: str = ""  # data attribution to print ("" for simulated/own data)
    notes: list[str] = field(default_factory=list)

    @property
    def status(self) -> str:
        """The recorded status, except that a ``running`` run whose process is gone reads
        as ``interrupted`` (ares.rundir.state)."""
        return effective_status(self.meta)[0]

    @property
    def complete(self) -> bool:
        return self.status == "done" and self.scan_results is not None

    @property
    def analyses(self) -> dict:
        return (self.scan_results or {}).get("analyses") or {}

    @property
    def limit_failures(self) -> list:
        return list((self.scan_results or {}).get("limit_failures") or [])

    @property
    def limits(self) -> dict:
        """The run's limits verdict (``ares.results.registry.limits_verdict``); a run recorded
        before it was written says what it can: failures, not checked, or passed/none set."""
        rec = (self.scan_results or {}).get("limits")
        if isinstance(rec, dict) and rec.get("text"):
            return rec
        lf = self.limit_failures
        if lf:
            return {"state": "failed", "text": f"limits: {len(lf)} failed -- " + "; ".join(lf)}
        if self.status != "done":
            return {"state": "not checked", "text": f"limits: not checked (the run is {self.status})"}
        return {"state": "passed", "text": "limits: none failed (the run predates recording whether any were set)"}

    def description(self) -> str:
        """The scan XML's <description> ("" if none or unreadable)."""
        try:
            from ares.protocol import xmlsafe

            p = self.dir / str(self.meta.get("scan_file") or "")
            el = xmlsafe.parse(xmlsafe.read_bytes(p), p).getroot().find("description")
            return " ".join((el.text or "").split()) if el is not None else ""
        except Exception:  # noqa: BLE001 -- cosmetic: a report never fails on it
            return ""

    def incompleteness(self) -> str:
        """One sentence on why the run is incomplete ("" when complete)."""
        if self.complete:
            return ""
        n, tot = len(self.stages), self.meta.get("stages_total")
        of = f" of {tot}" if tot else ""
        why = self.meta.get("message") or effective_status(self.meta)[1]
        s = f"Incomplete run (status '{self.status}'): {n}{of} stage(s) completed"
        if self.scan_results is None:
            s += ", no scan-level results (computed here from the completed stages where possible)"
        return s + (f". {why}" if why else ".")

    @property
    def setting_units(self) -> dict[str, str]:
        """Unit of each setting key (``exposure`` -> s, ``reg:sf_bias`` -> V), from the
        system XML kept in the run directory; {} when it cannot be read."""
        units = {"exposure": "s", "light": "photons/pixel/s", "temperature": "C", "analog_gain": "x"}
        rel = self.meta.get("system_file")
        try:
            from ares.protocol import load_system

            return load_system(self.dir / rel).setting_units()
        except Exception:  # noqa: BLE001 -- a label without its unit, never a failed report
            return units

    def arrays(self, index: int, names=None) -> dict[str, np.ndarray]:
        """Arrays of stage ``index`` from results.h5 ({} when absent); ``names``: only those."""
        if not self.has_h5:
            return {}
        import h5py

        with h5py.File(self.dir / "results.h5", "r") as f:
            g = f.get(f"stages/{index:04d}")
            return {} if g is None else {k: g[k][()] for k in g if names is None or k in names}

    def has_array(self, index: int, name: str) -> bool:
        """Whether stage ``index`` stored the array ``name`` (without reading it)."""
        if not self.has_h5:
            return False
        import h5py

        with h5py.File(self.dir / "results.h5", "r") as f:
            g = f.get(f"stages/{index:04d}")
            return g is not None and name in g


def _broken_stage_links(f) -> list[str]:
    """The stage files (paths relative to the run directory) that results.h5 links to and
    that cannot be opened."""
    import h5py

    group = f.get("stages")
    if group is None:
        return []
    out = []
    for name in group:
        link = group.get(name, getlink=True)
        if isinstance(link, h5py.ExternalLink) and group.get(name) is None:
            out.append(link.filename)
    return out


def _load_json(path: Path):
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: unreadable ({exc})") from None


def _attribution(d: Path, meta: dict) -> str:
    for d_ in (meta, meta.get("bench") if isinstance(meta.get("bench"), dict) else {}):
        if d_.get("attribution"):  # the replay bench records its data's attribution
            return str(d_["attribution"])
    texts = [json.dumps(meta)]
    for key in ("scan_file", "system_file"):
        p = d / str(meta.get(key) or "")
        if p.is_file():
            texts.append(p.read_text(errors="replace"))
    blob = " ".join(texts).lower()
    return ATTRIBUTION if any(m in blob for m in _EMVA_MARKERS) else ""


def read_run(run_dir: str | Path, verify_arrays: bool = False) -> Run:
    """The run directory, checked against the hashes recorded as it was written
    (``ares.rundir.check``: a missing or modified stage file, a truncated HDF5 raise
    ``RunDamaged``); ``verify_arrays`` also hashes every stored array (``ares report``,
    ``ares batch``: once per run, not on every read)."""
    from ares.rundir.check import check_run

    d = Path(run_dir)
    if not d.exists():
        raise InputError(f"{d}: run directory does not exist")
    if not d.is_dir():
        raise InputError(f"{d}: not a directory (expected an ARES run directory)")
    if not (d / "run.json").is_file():
        raise InputError(f"{d}: not an ARES run directory (no run.json)")
    meta = _load_json(d / "run.json")
    if not isinstance(meta, dict):
        raise InputError(f"{d / 'run.json'}: unreadable (not a JSON object)")
    notes = []
    for key in ("scan_file", "system_file"):
        rel = meta.get(key)
        if not rel:
            continue
        p = d / rel
        if not p.is_file():
            notes.append(f"{rel} is missing from the run directory")
        elif meta.get(key.replace("_file", "_sha256")) and \
                hashlib.sha256(p.read_bytes()).hexdigest() != meta[key.replace("_file", "_sha256")]:
            raise InputError(f"{p}: SHA-256 differs from the one recorded in run.json (file was modified)")
    stages = []
    for p in sorted((d / "stages").glob("[0-9][0-9][0-9][0-9].json")):
        st = _load_json(p)
        if not isinstance(st, dict) or "views" not in st or "full" not in st["views"]:
            raise InputError(f"{p}: not an ARES stage result (no views.full)")
        stages.append(st)
    check_run(d, meta, stages, arrays=verify_arrays)
    sr = None
    if (d / "scan_results.json").is_file():
        sr = _load_json(d / "scan_results.json")
        if not isinstance(sr, dict):
            raise InputError(f"{d / 'scan_results.json'}: unreadable (not a JSON object)")
    has_h5 = (d / "results.h5").is_file()
    if has_h5:
        import h5py

        try:
            with h5py.File(d / "results.h5", "r") as f:
                broken = _broken_stage_links(f)
        except OSError as exc:
            raise InputError(f"{d / 'results.h5'}: unreadable HDF5 ({exc})") from None
        if broken:  # h5py reads a link it cannot follow as absent: the report would lack them, silently
            raise InputError(f"{d / broken[0]}: a stage's arrays are missing or not HDF5"
                             + (f" ({len(broken)} stage files)" if len(broken) > 1 else "")
                             + f"; `ares rerun {d}` makes the run again")
    _check_manifest(d, verify_arrays, notes)
    return Run(d, meta, stages, sr, has_h5, _attribution(d, meta), notes)


def _check_manifest(d: Path, hashes: bool, notes: list[str]) -> None:
    """Every file the run wrote against ``manifest.json``: any altered one raises
    ``RunDamaged`` naming them all; a missing one (summary.csv, scan_results.json: the
    report rebuilds them; stages: ``check_run`` said so already) is a note naming it."""
    from ares.rundir import manifest
    from ares.rundir.check import RunDamaged

    found = manifest.problems(d, hashes=hashes, by=manifest.RUN)
    altered = [(rel, what) for rel, what in found if what != "missing"]
    if altered:
        raise RunDamaged(manifest.sentence(d, found) + f"; `ares rerun {d}` makes the run again")
    notes += [f"{rel} is missing (the run wrote it: {manifest.MANIFEST})" for rel, _ in found]
