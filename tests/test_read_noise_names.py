"""Read noise in DN and in e- differ by definition (issue 34): the DN figure keeps the
quantization noise (sigma_y.dark), the e- figure removes it (sigma_d, EMVA 1288 4.0 Linear
Eq. 53), so DN / K is not the e- figure. Both carry distinct names and a definition."""

from __future__ import annotations

import json
import math
from pathlib import Path

from ares.cli import main
from ares.labels import PTC_LABELS

TABLE = Path(__file__).resolve().parents[1] / "fixtures" / "ptc" / "sim_photon_transfer.csv"


def test_names_and_definitions(capsys):
    assert main(["ptc", str(TABLE), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    dn, e, k = d["read_noise_dn"], d["read_noise_e"], d["gain_dn_per_e"]["value"]
    assert PTC_LABELS["read_noise_dn"] != PTC_LABELS["read_noise_e"]
    assert "quantization noise (1/12 DN^2) included" in dn["note"]
    assert "quantization noise removed" in e["note"]
    # the e- figure is sqrt(sigma_y.dark^2 - 1/12)/K, computed here from the DN figure
    assert math.isclose(e["value"], math.sqrt(dn["value"] ** 2 - 1 / 12) / k, rel_tol=1e-9)
    assert abs(dn["value"] / k - e["value"]) > e["se"]  # why the names must differ
    assert main(["ptc", str(TABLE)]) == 0
    out = capsys.readouterr().out
    assert PTC_LABELS["read_noise_dn"] in out and PTC_LABELS["read_noise_e"] in out
