"""The README's command table lists every option of every command (issue 38: seven were
missing), so a user reading it sees what `ares CMD --help` offers."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ares.cli import COMMANDS, build_parser

ROOT = Path(__file__).resolve().parents[1]


def _rows() -> dict[str, str]:
    rows = {}
    for line in (ROOT / "README.md").read_text().splitlines():
        m = re.match(r"\| `ares ([\w-]+)[ `]", line)
        if m:
            rows[m.group(1)] = line
    return rows


def _options(name: str) -> list[str]:
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    p = sub.choices[name]
    return [max(a.option_strings, key=len) for a in p._actions if a.option_strings and "--help" not in a.option_strings]


@pytest.mark.parametrize("name", COMMANDS)
def test_every_option_of_every_command_is_in_the_readme_table(name):
    rows = _rows()
    assert name in rows, f"README's command table has no row for `ares {name}`"
    missing = [o for o in _options(name) if not re.search(re.escape(o) + r"(?![\w-])", rows[name])]
    assert not missing, f"`ares {name}` options missing from README's table: {missing}"
