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
from ares.analysis.kernels import jit
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


WHERE = """
from pathlib import Path
from ares.analysis.kernels import jit
from ares.analysis.kernels import int_fold
from ares.analysis.kernels import pair as pair_kernel
from ares.sim import fused
for mod, fn in ((pair_kernel, pair_kernel._kernel), (int_fold, int_fold._extremes_kernel), (fused, fused._kernel)):
    index = Path(jit.compiled(fn)._cache._cache_file._index_path)  # numba's own locator (nothing compiled)
    src = Path(mod.__file__)
    assert index.parent == jit.cache_folder(src), (index, jit.cache_folder(src))
    assert index.match(f"{src.stem}.*.py*.nbi"), index
print(jit.kernels_cached())
"""


@pytest.mark.parametrize("custom", [False, True])
def test_kernels_cached_looks_where_numba_keeps_the_index(tmp_path, custom):
    """``jit.kernels_cached`` (the memory estimate's case) finds numba's index files without
    importing numba: the folder and name it looks for are numba's own, with and without
    NUMBA_CACHE_DIR; an empty NUMBA_CACHE_DIR reads as not cached."""
    env = dict(os.environ)
    env.pop("ARES_NO_NUMBA", None)
    env.pop("NUMBA_CACHE_DIR", None)
    if custom:
        env["NUMBA_CACHE_DIR"] = str(tmp_path / "cache")
    p = subprocess.run([sys.executable, "-c", WHERE], env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    if custom:
        assert p.stdout.strip() == "False"


def test_every_module_with_a_cached_kernel_is_looked_at():
    """A module that caches a kernel (``jit.compiled`` without ``inline``) and is missing
    from ``KERNEL_MODULES`` would go unseen by ``kernels_cached``."""
    from pathlib import Path

    from ares.analysis.kernels import jit

    root = Path(jit.__file__).parents[2]  # ares/
    using = {p.relative_to(root).as_posix() for p in root.rglob("*.py") if p != Path(jit.__file__)
             and any("jit.compiled(" in ln and "inline=True" not in ln for ln in p.read_text().splitlines())}
    assert using == set(jit.KERNEL_MODULES)
