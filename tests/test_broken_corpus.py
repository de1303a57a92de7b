"""The broken-input corpus (fixtures/broken, issue 10): descriptors, images, stacks,
photon-transfer tables and run arguments, each with its expected message in
fixtures/broken/EXPECTED.tsv. Every case: the right exit code, its message in one
sentence, no traceback, never the file's text, and no run directory left behind."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from ares.cli import main

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "fixtures" / "broken"
HELPERS = {"images/ok.png", "stacks/ok.npy", "stacks/good.npz", "scans/sim_small.xml", "scans/sim_huge.xml",
           "scans/ptc_small.xml"}


def cases() -> list[tuple[str, str, int, str]]:
    out = []
    for ln in (CORPUS / "EXPECTED.tsv").read_text().splitlines():
        if ln.strip() and not ln.startswith("#"):
            f, cmd, code, frag = ln.split("\t")
            out.append((f, cmd, int(code), frag))
    return out


CASES = cases()


def test_every_corpus_file_has_an_expected_message():
    listed = {c[0] for c in CASES}
    files = {str(p.relative_to(CORPUS)) for d in ("descriptors", "images", "stacks", "tables", "scans")
             for p in (CORPUS / d).iterdir() if p.name != "img"}
    assert files - HELPERS <= listed, sorted(files - HELPERS - listed)
    xml = list((ROOT / "fixtures" / "xml" / "broken").glob("*.xml"))  # tests/test_protocol.py
    assert len(CASES) + len(xml) >= 100


@pytest.mark.parametrize("f, cmd, code, frag", CASES, ids=[f"{c[0]}|{c[1].split()[0]}" for c in CASES])
def test_broken_input_gives_one_sentence(f, cmd, code, frag, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(CORPUS)
    argv = [a.replace("{f}", f).replace("RUNDIR", str(tmp_path / "run")) for a in shlex.split(cmd)]
    rc = main(argv)
    out, err = capsys.readouterr()
    assert rc == code, (rc, err)
    assert frag in (err if code else out), err or out
    assert "Traceback" not in err and "SECRET" not in err + out
    if code:
        assert err.strip().count("\n") == 0, err
        assert not (tmp_path / "run").exists()  # a refused run leaves nothing behind
