"""Run the EMVA 1288 reference implementation (PyPI ``emva1288`` 1.0.2) in its own venv: the
certification XML of the EMVA reference CCD set and of small data sets its own camera
simulator writes, for ``ares emva-compare`` (tests/test_emva_xml.py, docs/emva1288_releases.md).

    python tools/emva_reference.py OUTDIR [--venv DIR] [--data-sets] [--ccd]

* ``--venv DIR`` (default ``~/.cache/ares/emva1288-ref``): made on first use with
  ``python -m venv`` and ``pip install emva1288==1.0.2 'numpy<1.24'`` (the package calls
  ``np.int``, removed in NumPy 1.24; 1.23.5 installs on Python 3.11; its simulator's 16-bit PNGs need Pillow < 13);
* ``--data-sets``: writes ``OUTDIR/<name>/`` (descriptor ``EMVA1288_Data.txt``, ``images/``,
  and the reference's ``reference.xml``) for each of ``DATA_SETS`` -- several gains, offsets
  and bit depths, with and without dark-current steps (exposure-time series or a fixed
  exposure), one with a nonlinear response (its images bent by ``NONLINEAR`` after the
  simulator wrote them); fixed seeds;
* ``--ccd``: ``OUTDIR/ccd_reference.xml`` from ``../shared/data/EMVA1288_ReferenceSet_001_CCD_12Bit``.

The committed fixtures (``fixtures/emva_reference/``) were made with
``python tools/emva_reference.py fixtures/emva_reference --data-sets --ccd``; run it again
to regenerate them (same seeds, same files). Exit 2 with one sentence when the venv cannot
be made (no network, no pip).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CCD = ROOT.parent / "shared" / "data" / "EMVA1288_ReferenceSet_001_CCD_12Bit" / "EMVA1288_Data.txt"
DEFAULT_VENV = Path.home() / ".cache" / "ares" / "emva1288-ref"
REQUIREMENTS = ["emva1288==1.0.2", "numpy<1.24", "pillow<13"]  # (Pillow 13 cannot write its 16-bit PNGs)
SMALL = {"width": 64, "height": 48, "steps": 30, "L": 16}
# name: camera and generator settings (the reference simulator's keywords)
DATA_SETS = {
    "sim_12bit_k0.5_texp": {"bit_depth": 12, "K": 0.5, "blackoffset": 20, "seed": 11, "dsnu_e": 3.0, "prnu": 0.01},
    "sim_8bit_auto_texp": {"bit_depth": 8, "seed": 12, "dsnu_e": 1.0, "prnu": 0.005},
    "sim_10bit_k1_fixed": {"bit_depth": 10, "K": 1.0, "blackoffset": 8, "seed": 13, "exposure_fixed": 10_000_000,
                           "dsnu_e": 2.0, "prnu": 0.02},
    "sim_14bit_k3_offset200": {"bit_depth": 14, "K": 3.0, "blackoffset": 200, "seed": 14, "dsnu_e": 5.0,
                               "prnu": 0.01},
    "sim_12bit_k0.3_nonlinear": {"bit_depth": 12, "K": 0.3, "blackoffset": 30, "seed": 15, "nonlinear": True,
                                 "dsnu_e": 2.0, "prnu": 0.01},
    "sim_16bit_k2_fixed_dark": {"bit_depth": 16, "K": 2.0, "blackoffset": 100, "seed": 16,
                                "exposure_fixed": 50_000_000, "dark_current_ref": 300, "dsnu_e": 0.0, "prnu": 0.0},
}
NONLINEAR = 0.08  # y -> y (1 - NONLINEAR (y / y_max)): 8 % compression at the top

CHILD = r"""
import json, os, sys
import numpy as np
spec, out, nonlinear = json.loads(sys.argv[1]), sys.argv[2], float(sys.argv[3])
from emva1288.camera.dataset_generator import DatasetGenerator
from emva1288 import process
small = spec.pop("_small")
rng = np.random.default_rng(spec["seed"])
shape = (small["height"], small["width"])
dsnu_e, prnu = spec.pop("dsnu_e"), spec.pop("prnu")
bent = spec.pop("nonlinear", False)
kw = dict(spec, width=small["width"], height=small["height"], dsnu=rng.normal(0, dsnu_e, shape) if dsnu_e else None,
          prnu=1 + rng.normal(0, prnu, shape) if prnu else None)
gen = DatasetGenerator(steps=small["steps"], L=small["L"], outdir=out, **kw)
desc = gen.descriptor_path
if bent:
    from PIL import Image
    top = 2 ** spec["bit_depth"] - 1
    for name in sorted(os.listdir(os.path.join(out, "images"))):
        p = os.path.join(out, "images", name)
        a = np.asarray(Image.open(p)).astype(np.float64)
        b = np.rint(a * (1 - nonlinear * a / top)).astype(np.uint16 if spec["bit_depth"] > 8 else np.uint8)
        Image.fromarray(b).save(p)
final = os.path.join(out, "EMVA1288_Data.txt")
if os.path.abspath(desc) != os.path.abspath(final):
    os.replace(desc, final)
process.Emva1288(final).xml(os.path.join(out, "reference.xml"))
"""

CCD_CHILD = r"""
import sys
from emva1288 import process
process.Emva1288(sys.argv[1]).xml(sys.argv[2])
"""


def venv_python(venv: Path) -> Path:
    """The venv's python, the venv made (and the reference installed) on first use; raises
    ``RuntimeError`` with the reason when that cannot be done."""
    py = venv / "bin" / "python"
    ok = py.exists() and subprocess.run([str(py), "-c", "import emva1288, numpy; import PIL; assert numpy.__version__ < '1.24' and int(PIL.__version__.split('.')[0]) < 13"],
                                        capture_output=True).returncode == 0
    if ok:
        return py
    r = subprocess.run([sys.executable, "-m", "venv", str(venv)], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"cannot make a venv at {venv}: {r.stderr.strip()[-300:]}")
    r = subprocess.run([str(py), "-m", "pip", "install", "-q", *REQUIREMENTS], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"cannot install {' '.join(REQUIREMENTS)} into {venv}: {r.stderr.strip()[-300:]}")
    return py


def make_data_set(py: Path, name: str, out: Path) -> Path:
    """``out/name/``: the reference simulator's data set and the reference's XML of it."""
    d = out / name
    if d.exists():
        import shutil

        shutil.rmtree(d)
    spec = dict(DATA_SETS[name], _small=SMALL)
    r = subprocess.run([str(py), "-c", CHILD, json.dumps(spec), str(d), str(NONLINEAR)],
                       env={**os.environ, "PYTHONWARNINGS": "ignore"}, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"the reference failed on {name}: {r.stderr.strip()[-800:]}")
    return d


def reference_xml(py: Path, descriptor: Path, out: Path) -> None:
    subprocess.run([str(py), "-c", CCD_CHILD, str(descriptor), str(out)], check=True, capture_output=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", type=Path)
    ap.add_argument("--venv", type=Path, default=DEFAULT_VENV)
    ap.add_argument("--data-sets", action="store_true")
    ap.add_argument("--ccd", action="store_true")
    a = ap.parse_args(argv)
    try:
        py = venv_python(a.venv)
    except RuntimeError as exc:
        print(f"emva_reference: {exc}", file=sys.stderr)
        return 2
    a.outdir.mkdir(parents=True, exist_ok=True)
    try:
        if a.ccd:
            reference_xml(py, CCD, a.outdir / "ccd_reference.xml")
            print(a.outdir / "ccd_reference.xml")
        if a.data_sets:
            for name in DATA_SETS:
                print(make_data_set(py, name, a.outdir))
    except (RuntimeError, subprocess.CalledProcessError) as exc:
        print(f"emva_reference: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
