"""``ares`` command line: a thin dispatcher over ``ares.commands.*`` (and ``ares.gui.command``).

Each command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``. User errors (``AresError``) print one sentence and exit with the
error's code; nothing else is caught here, so a real bug still shows its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys

from ares import __version__
from ares.errors import AresError

COMMANDS = ["run", "resume", "validate", "rerun", "analyze", "emva", "emva-compare", "ptc", "mtf", "photon-counting",
            "defects", "rtn", "dark-temperature", "fe55", "report", "batch", "lots", "bench", "gui"]


# where a command lives when not ``ares.commands.<name>`` (a hyphenated name; the window's command belongs to ``ares.gui``:
# nothing below the window imports it)
HOMES = {"gui": "ares.gui.command", "emva-compare": "ares.commands.emva_compare",
         "dark-temperature": "ares.commands.dark_temperature", "photon-counting": "ares.commands.photon_counting"}


def _modules():
    for name in COMMANDS:
        modname = HOMES.get(name, f"ares.commands.{name}")
        if importlib.util.find_spec(modname) is not None:
            yield importlib.import_module(modname)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="ares", description="Image-sensor characterization bench")
    parser.add_argument("--version", action="version", version=f"ares {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in _modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)
        p.set_defaults(_run=mod.run)
    return parser


BLAS_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def set_blas_threads() -> None:
    """BLAS/OpenMP threads are ARES's choice, not inherited by accident: 1 (the scan's small
    matrix work gains nothing from them and the frame loop loses to their spinning; the
    issue's measurement: 20 % slower with the defaults), or ``ARES_BLAS_THREADS``. Takes
    effect when called before numpy is imported, as ``main`` does."""
    import os

    n = os.environ.get("ARES_BLAS_THREADS", "1")
    for var in BLAS_VARS:
        os.environ[var] = n


def tune_malloc() -> None:
    """glibc's allocator settings for a command (see ``ares.malloc``)."""
    from ares import malloc

    malloc.tune()


# Commands that leave nothing behind when they return (no worker processes, no Qt, every
# file closed): the ``ares`` script ends them without the interpreter's teardown.
FAST_EXIT = {"run", "resume", "rerun", "validate", "analyze", "emva", "emva-compare", "ptc", "photon-counting", "defects",
             "report", "rtn", "dark-temperature", "fe55"}
_ran: list[str] = []  # the command main() ran, for console()


# Commands whose stop signals are theirs from the first instruction (``ares.commands.run_signals``)
SIGNAL_COMMANDS = {"run", "resume", "rerun"}


def main(argv: list[str] | None = None, keep_handlers: bool = False) -> int:
    """``keep_handlers``: the stop-signal handlers of a run stay until the process ends (the
    ``ares`` script); a caller in the same process (tests) gets its own back."""
    words = [a for a in (sys.argv[1:] if argv is None else argv) if not a.startswith("-")]
    early = bool(words) and words[0] in SIGNAL_COMMANDS
    if early:  # before anything else: a signal in the first second is not lost
        from ares.commands import run_signals

        run_signals.install_early()
    try:
        return _main(argv)
    finally:
        if early and not keep_handlers:
            run_signals.restore_early()


def _main(argv: list[str] | None) -> int:
    set_blas_threads()
    parser = build_parser()
    args = parser.parse_args(argv)
    _ran.append(args.command or "")
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    tune_malloc()
    from ares.rundir.state import quiet_unraisable_storage_errors

    quiet_unraisable_storage_errors()  # (h5py's echoes of a write the disk refused: the sentence says it)
    try:
        rc = int(args._run(args) or 0)
        if args.command in SIGNAL_COMMANDS:  # a stop that came when nothing was left to stop
            from ares.commands.run_signals import ended_anyway

            rc = ended_anyway(args.command, rc)
        return rc
    except AresError as exc:
        print(f"ares {args.command}: {exc}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print(f"ares {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `ares ... | head`: the reader left; not an error of ours
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 0
    except Exception as exc:  # a write the disk refused where no command guard caught it: still one sentence
        from ares.safefile import WRITE_ERRNOS, storage_error

        err = storage_error(exc, "an output file", WRITE_ERRNOS)
        if err is None:
            raise
        print(f"ares {args.command}: {err}", file=sys.stderr)
        return err.exit_code


def console() -> None:
    """The ``ares`` script: ``main``, then, for a FAST_EXIT command with no other thread
    left, the process ends at once -- the interpreter's teardown (freeing every module
    and object of numpy, scipy, numba, matplotlib, h5py) took 0.4 - 0.6 s after
    ``make run``'s last line, for nothing. stdout/stderr and the log are flushed first;
    the run directory's files are closed and fsynced by then."""
    import os
    import threading

    code = main(keep_handlers=True)
    if _ran and _ran[-1] in FAST_EXIT and threading.active_count() == 1:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except (OSError, ValueError):  # a closed pipe: the normal exit reports nothing more either
            pass
        logging = sys.modules.get("logging")  # flushed if anything used it (not imported for this)
        if logging is not None:
            logging.shutdown()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    console()
