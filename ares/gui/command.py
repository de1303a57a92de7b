"""``ares gui [SCAN]``: open the ARES window, optionally with a scan XML loaded."""

from __future__ import annotations

from pathlib import Path

from ares.errors import InputError

NAME = "gui"
HELP = "open the ARES window (live plots, regions of analysis, scan control)"


def add_arguments(parser) -> None:
    parser.add_argument("scan", nargs="?", help="scan XML to load (Start Scan runs it); "
                        "without it Start Scan runs a built-in demo on a simulated sensor")


def run(args) -> int:
    if args.scan:
        if not Path(args.scan).is_file():
            raise InputError(f"{args.scan}: no such scan file.")
        from ares.gui.engine import open_scan

        open_scan(args.scan)  # a broken scan ends here in one sentence, before any window
    from ares.gui.app import check_display

    check_display()
    from ares.gui.app import make_app, open_main_window  # Qt is imported here, not at module load

    app = make_app()
    window = open_main_window(args.scan)  # noqa: F841 -- keep the window alive
    return int(app.exec())
