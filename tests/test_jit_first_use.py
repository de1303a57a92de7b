"""A kernel compiled on first use says so once on stderr (issue 40: a first run 4x slower
than the second, and nothing told the user why); a cached one says nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytest.importorskip("numba")

CODE = """
import sys
sys.path.insert(0, sys.argv[1])
from ares import jit
import kmod
d = jit.compiled(kmod.add_one)
assert d(1) == 2
"""


def _run(tmp_path, announce: bool) -> str:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    env.pop("ARES_NO_NUMBA", None)
    env.pop("ARES_ANNOUNCE_COMPILE", None)
    if announce:
        env["ARES_ANNOUNCE_COMPILE"] = "1"
    p = subprocess.run([sys.executable, "-c", CODE, str(tmp_path)], env=env, capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    return p.stderr


def test_first_compilation_is_announced_once_then_the_cache_is_silent(tmp_path):
    (tmp_path / "kmod.py").write_text("def add_one(x):\n    return x + 1\n")
    first = _run(tmp_path, announce=True)
    assert first.count("ares: compiling the numba kernels for this machine (add_one first), once") == 1
    assert _run(tmp_path, announce=True) == ""  # loaded from the cache


def test_no_notice_when_stderr_is_not_a_terminal(tmp_path):
    (tmp_path / "kmod.py").write_text("def add_one(x):\n    return x + 1\n")
    assert _run(tmp_path, announce=False) == ""
