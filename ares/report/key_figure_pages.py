"""The key-figure table of the PDF report: every key figure, on the title page and on as
many "Key figures (continued)" pages as the rest need (a lab signs the PDF, not
key_figures.csv), the same three columns on each. A cell longer than its column wraps
onto the lines below, never cut: a note ends with the figure's verdict.

The split is computed from the rows and the room the title page leaves, before any page
is drawn, so that ``pdf.page_plan`` knows the number of pages (deterministic from the run
directory, as ``pdf_parts`` needs)."""

from __future__ import annotations

from ares.report import page_tables, plots
from ares.report.plots import new_page, text_table

HEADER = ["key figure", "value ± SE", "definition / note"]
WIDTHS = [0.34, 0.22, 0.44]
MAX_CHARS = [42, 23, 54]  # (23: the monospace value column at 8 pt holds 24 characters; one spare before the next)
FONTSIZE = 8
TOP = 0.92  # a continuation page's table starts below its page title
BOTTOM = 0.05  # above the footer (and the title page's "continued" line)
EMPTY = [["(no key figures: the run holds no photon-transfer or analysis results)", "", ""]]
CONTINUED_TITLE = "Key figures (continued)"


def rows_of(kf: dict) -> list[list[str]]:
    """[label, value ± SE (or its verdict), definition / note] per key figure, in report order."""
    return [[v["label"], page_tables.fmt_value(v["value"], v["se"], v["unit"], v.get("verdict", ""),
                                               v.get("exact", "")),
             v.get("note") or ""]
            for v in kf.values()] or EMPTY


def split(rows: list[list[str]], first_top: float) -> list[list[list[str]]]:
    """``rows`` in page-sized chunks: the first below ``first_top`` on the title page (under its
    "Key figures" title), the rest from ``TOP`` on continuation pages; a row is never split."""
    return plots.paginate(rows, MAX_CHARS, plots.table_lines_between(first_top, BOTTOM, FONTSIZE, True),
                          plots.table_lines_between(TOP, BOTTOM, FONTSIZE, False))


def draw(fig, top: float, rows: list[list[str]], title: str, more: int) -> float:
    """The table on ``fig`` from ``top``; ``more``: key figures on the pages that follow.
    Returns the y below its last row."""
    y = text_table(fig, (0.06, top, 0.9), HEADER, rows, WIDTHS, fontsize=FONTSIZE, title=title,
                   max_chars=MAX_CHARS, wrap=True)
    if more:
        fig.text(0.06, 0.03, f"{more} more key figure(s) on the next page(s), \"{CONTINUED_TITLE}\" "
                 "(all of them also in key_figures.csv)", fontsize=8)
    return y


def continuation_page(rows: list[list[str]], number: int, pages: int, more: int):
    """Continuation ``number`` (1-based) of ``pages`` holding ``rows``."""
    fig = new_page(CONTINUED_TITLE, f"page {number} of {pages} of the key figures; columns as on the title page")
    draw(fig, TOP, rows, "", more)
    return fig
