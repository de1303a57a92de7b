"""`ares --help` and `ares validate` stay light: no scipy, matplotlib, h5py or Qt at import
(their cost is seconds; measured in benchmarks/startup.md)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "matplotlib", "h5py", "PySide6", "dask")


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["validate", "scans/photon_transfer.xml"],
                                  ["validate", "protocols/sim_wire.xml"]])
def test_no_heavy_imports(argv):
    # main(), not the script: the script ends a finished command with os._exit (cli.console)
    code = ("import sys\nfrom ares.cli import main\n"
            f"try:\n    main({argv!r})\nexcept SystemExit:\n    pass\n"
            f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[]", out
