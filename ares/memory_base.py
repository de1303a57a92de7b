"""What the libraries a run imports take in memory on this machine, measured at install.

The memory estimate of ``ares validate`` / ``--dry-run`` (``ares.scan.preflight``) starts
from a base: the interpreter with numpy, scipy, numba, h5py, lxml, matplotlib, pypdf and
Pillow imported. That base is a property of the installed packages, not of ARES: a numba
release moved it by ~36 MiB (mtf.xml's peak 253 -> 289 MiB with no change here). So
``python -m ares.jit`` (the Makefile's install step) measures it once, in a child that
imports what ``ares run`` imports and reads its high-water mark (VmHWM), and records it with
the versions it was measured with; ``recorded()`` returns it while those versions are still
the installed ones, None otherwise (the estimate then uses its fitted constant and says so).
Linux only (``/proc/self/status``); elsewhere nothing is recorded. The figure also moves
with the machine's page cache (242 MiB, then 170 MiB after 14 GB of other files had gone
through it, the same packages): what was resident at install is what the estimate has.
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
from pathlib import Path

# what `ares run` has imported by its peak (read off sys.modules after runs of the shipped scans)
_CHILD = r"""
import numpy, scipy.linalg, scipy.special, scipy.ndimage, h5py, lxml.etree, pypdf, PIL.Image
import matplotlib
matplotlib.use("Agg")
import matplotlib.figure, matplotlib.backends.backend_agg, matplotlib.backends.backend_pdf
try:
    import numba
except ImportError:
    pass
print([ln for ln in open("/proc/self/status") if ln.startswith("VmHWM")][0].split()[1])
"""
_PACKAGES = ("numpy", "scipy", "numba", "llvmlite", "h5py", "lxml", "matplotlib", "pypdf", "pillow")


@functools.lru_cache(maxsize=1)
def _installed() -> tuple:
    from importlib import metadata

    out = []
    for name in _PACKAGES:
        try:
            out.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            out.append((name, None))
    return tuple(out)


def versions() -> dict[str, str]:
    """The installed versions of the packages in the base (read once a process), and the interpreter's."""
    return {"python": sys.version.split()[0], "no_numba": bool(os.environ.get("ARES_NO_NUMBA")), **dict(_installed())}


def record_path() -> Path:
    """Beside numba's cache of ``ares/jit.py``'s folder (``__pycache__`` or ``NUMBA_CACHE_DIR``)."""
    from ares.analysis.kernels.jit import cache_folder

    return cache_folder(Path(os.path.abspath(__file__))) / "memory_base.json"


def measure() -> int | None:
    """Bytes: the high-water mark of a child that imports the base; None where it cannot be read."""
    if not os.path.exists("/proc/self/status"):
        return None
    p = subprocess.run([sys.executable, "-c", _CHILD], capture_output=True, text=True)
    if p.returncode != 0:
        return None
    return int(p.stdout.split()[-1]) * 1024


def record() -> int | None:
    """Measure the base and write it with the versions; returns the bytes (None: not measured)."""
    got = measure()
    if got is None:
        return None
    path = record_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"bytes": got, "versions": versions()}))
        os.replace(tmp, path)
    except OSError:  # a read-only install: the estimate keeps its constant
        return None
    return got


def recorded() -> int | None:
    """The base measured at install, while the packages are the ones it was measured with."""
    try:
        data = json.loads(record_path().read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("versions") != versions() or not isinstance(data.get("bytes"), int):
        return None
    return data["bytes"]
