"""Units on every CSV column and HDF5 dataset, one naming scheme (issue 38): summary.csv
had components without units ("o", "Cs", "G") and ptc.csv a bare "light" and "photons";
no HDF5 dataset said its unit."""

from __future__ import annotations

import csv
from pathlib import Path

import h5py
import numpy as np
import pytest

from ares import labels
from ares.cli import main

ROOT = Path(__file__).resolve().parents[1]
TEXT = {"name", "scene", "stage", "view", "part", "component", "description", "note", "status", "reason",
        "label", "verdict", "source", "unit"}


def test_naming_scheme_round_trips():
    for unit in ("DN", "DN^2", "DN/e-", "e-", "e-^2", "%", "dB", "s", "e-/s", "uV/e-"):
        assert labels.unit_of_column(labels.with_unit("x", unit)) == unit
    assert labels.with_unit("light", "photons/pixel/s") == "light_photons_per_pixel_per_s"
    assert labels.with_unit("reg:sf_bias", "V") == "reg:sf_bias_v"
    assert labels.with_unit("mean_dn", "DN") == "mean_dn"


@pytest.fixture(scope="module")
def run(tmp_path_factory, ptc_small_no_pdf) -> Path:
    out = tmp_path_factory.mktemp("units") / "run"  # (the CSVs' and HDF5's columns: no PDF read)
    assert main(["run", str(ptc_small_no_pdf), "--out", str(out), "--quiet"]) == 0
    return out


@pytest.mark.parametrize("table", ["summary.csv", "ptc.csv", "levels.csv"])
def test_every_numeric_csv_column_names_its_unit(run, table):
    with open(run / table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for col in rows[0]:
        if col in TEXT or col.endswith("_verdict"):  # (a figure's verdict beside it: text)
            continue
        numeric = any(r[col] not in ("", None) for r in rows)
        assert not numeric or labels.unit_of_column(col) or col.startswith("reg:") and "_" in col, \
            f"{table}: column '{col}' names no unit"
    head = list(rows[0])
    assert "Ps_dn2" in head or table != "summary.csv"
    assert "light_photons_per_pixel_per_s" in head if table != "levels.csv" else True


def test_every_numeric_hdf5_dataset_carries_its_unit(run):
    missing = []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu" and "unit" not in obj.attrs:
            missing.append(name)

    for f in [run / "report.h5", *sorted((run / "stages").glob("*.h5")), *sorted((run / "frames").glob("*.h5"))]:
        with h5py.File(f, "r") as h:
            for key in h:
                if key == "stages" and f.name == "report.h5":
                    continue  # external links to the stage files, checked themselves
                obj = h[key]
                if isinstance(obj, h5py.Dataset):
                    visit(key, obj)
                else:
                    obj.visititems(lambda n, o, f=f: visit(f"{f.name}:{key}/{n}", o))
    assert not missing, missing
    with h5py.File(run / "report.h5", "r") as h:
        assert h["ptc/mean_dn"].attrs["unit"] == "DN" and h["ptc/variance_dn2"].attrs["unit"] == "DN^2"
    with h5py.File(sorted((run / "stages").glob("*.h5"))[1], "r") as h:
        assert h["mean"].attrs["unit"] == "DN" and h["variance"].attrs["unit"] == "DN^2"
        assert np.isfinite(h["mean"][()]).all()
