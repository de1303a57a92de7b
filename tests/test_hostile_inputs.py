"""Issue 41: run-directory names, storage errors, sizes read from headers and text
fields, the hostile-XML decisions. Each test failed before the change it covers."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# ---------------------------------------------------------------- run-directory names


def test_run_names_are_unique_in_the_out_folder(tmp_path, monkeypatch):
    """--out a non-empty folder that is not a run directory, the same second for every run:
    each claim gets its own name, counted in that folder (it was checked against ./runs/)."""
    from ares.commands import run as cmd

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(cmd.time, "strftime", lambda fmt: "20260101-000000")
    out = tmp_path / "shared"
    out.mkdir()
    (out / "notes.txt").write_text("not a run")
    got = [cmd.claim_out(out, "s") for _ in range(5)]
    for p in got:
        (p / "run.json").write_text("{}")  # (a run writes it: the claim alone is this process's)
    assert len(set(got)) == 5 and all(p.parent == out for p in got)


_CLAIM = """
import sys, time
from ares.commands import run as cmd
cmd.time.strftime = lambda fmt: "20260101-000000"
p = cmd.claim_out(sys.argv[1], "s")
(p / "run.json").write_text("{}")
print(p)
"""


def test_many_concurrent_claims_into_one_out(tmp_path):
    """8 processes claim run directories in the same --out at once: 8 distinct names."""
    out = tmp_path / "shared"
    out.mkdir()
    (out / "notes.txt").write_text("x")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    procs = [subprocess.Popen([sys.executable, "-c", _CLAIM, str(out)], cwd=tmp_path, env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(8)]
    paths = []
    for p in procs:
        o, e = p.communicate()
        assert p.returncode == 0, e
        paths.append(o.strip())
    assert len(set(paths)) == 8
