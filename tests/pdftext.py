"""PDF text for report tests with a pure-Python reader (pypdf, a test dependency): no
system package needed. ``page_texts`` gives one string per page, whitespace folded so
that assertions do not depend on how a reader lays out text."""

from __future__ import annotations

import re
from pathlib import Path

from pypdf import PdfReader


def page_texts(path: str | Path) -> list[str]:
    return [re.sub(r"\s+", " ", p.extract_text() or "") for p in PdfReader(str(path)).pages]


def pdf_text(path: str | Path) -> str:
    return "\n".join(page_texts(path))


def page_count(path: str | Path) -> int:
    return len(PdfReader(str(path)).pages)
