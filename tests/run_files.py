"""Reading a run directory's stage files back in tests."""

from __future__ import annotations

import json
from pathlib import Path


def stage_results(run_dir: Path) -> list[dict]:
    """Each stage's JSON in order, without its timing (which differs between runs)."""
    out = []
    for p in sorted((Path(run_dir) / "stages").glob("*.json")):
        d = json.loads(p.read_text())
        d.pop("timing")
        out.append(d)
    return out
