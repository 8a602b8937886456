"""The ``dpdfit`` command line: a thin layer over the Python API (also ``python -m dpdfit``).

Every sub-command validates its inputs through :mod:`dpdfit.recordings.tables`, calls the
API, and writes its outputs atomically.  Any :class:`~dpdfit.errors.DpdfitError`
is printed as one line ``dpdfit: error: ...`` on stderr with exit status 2; so is, as
a last line of defence, any other exception (:func:`main`), and no traceback is shown.
The library's log messages are shown on stderr while a command runs
(:mod:`dpdfit.cli.logs`); progress bars appear when stderr is a terminal.

Each command (or small family of commands) lives in its own module of
:mod:`dpdfit.cli` with an ``add_<command>_command(subparsers)`` that registers
it; this module only assembles the parser, in the order of ``dpdfit --help``.
"""

from __future__ import annotations

import argparse
import logging
import re
import sys

from dpdfit.cli.calibration import add_calibrate_command, add_lut_command, add_polyfit_command
from dpdfit.cli.campaign import add_analyze_command, add_simulate_campaign_command
from dpdfit.cli.gates import add_align_command, add_fidelity_command
from dpdfit.cli.help_texts import OVERVIEW_EXAMPLES, OVERVIEW_NOTE, describe
from dpdfit.cli.logs import cli_logging
from dpdfit.cli.spectral import (add_estimate_command, add_im_table_command, add_sweep_command,
                                 add_thresholds_command)
from dpdfit.core.version import __version__
from dpdfit.errors import DpdfitError, printable
from dpdfit.recordings.outputs import check_output_file, check_output_folder, staged_outputs

__all__ = ["main", "build_parser", "check_outputs", "DESCRIPTION", "EPILOG", "INTERNAL_ERROR",
           "OUT_OF_MEMORY", "TOO_DEEP"]

log = logging.getLogger(__name__)

#: The top of ``dpdfit --help`` (plain text).
DESCRIPTION = ("dpdfit: analysis of digitally predistorted (DPD) trapped-ion entangling-gate "
               "experiments --\nAOM transfer-function fits, predistortion tables, spectra, "
               "fidelities, diagnosis.")
#: The bottom of ``dpdfit --help``.
EPILOG = ("examples:\n  " + OVERVIEW_EXAMPLES.replace("\n", "\n  ") + "\n\n" + OVERVIEW_NOTE)

# The last line of defence (:func:`main`): how its messages start, after ``dpdfit: error:``.
# Each means that no check gave the input a message of its own; tests look for them.
#: an exception no check turned into a message (a bug to report)
INTERNAL_ERROR = "internal error"
#: a MemoryError: an input needed more memory than the machine has
OUT_OF_MEMORY = "out of memory"
#: a RecursionError: an input nested deeper than Python's recursion limit
TOO_DEEP = "input nested too deeply"
#: the longest exception message quoted in such a line
_MAX_DETAIL = 300


class _OneLineParser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line: ``dpdfit: error: ...``, exit 2.

    ``argument --nbar: must be >= 0, got -1`` becomes ``option --nbar: must be >= 0,
    got -1``; the sub-parsers of the commands are of this class too.
    """

    def error(self, message: str):
        if message.startswith("argument -"):
            message = "option " + message[len("argument "):]
        message = " ".join(str(message).split())
        self.exit(2, f"dpdfit: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``dpdfit`` parser: each command registered by its module in ``dpdfit.cli``."""
    p = _OneLineParser(
        prog="dpdfit", description=DESCRIPTION, epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"dpdfit {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    add_polyfit_command(sub)
    add_calibrate_command(sub)
    add_lut_command(sub)
    add_sweep_command(sub)
    add_estimate_command(sub)
    add_im_table_command(sub)
    add_thresholds_command(sub)

    from dpdfit.cli.spectrum import add_spectrum_command
    from dpdfit.cli.stability import add_stability_command
    from dpdfit.cli.budget import add_budget_command
    from dpdfit.cli.propagate import add_propagate_command
    add_spectrum_command(sub)
    add_stability_command(sub)
    add_propagate_command(sub)
    add_budget_command(sub)
    from dpdfit.cli.diagnose import add_diagnose_command
    from dpdfit.cli.harness import add_harness_command
    add_diagnose_command(sub)
    add_harness_command(sub)
    add_fidelity_command(sub)
    add_align_command(sub)
    add_simulate_campaign_command(sub)
    from dpdfit.cli.import_campaign import add_import_command, add_write_artiq_results_command
    add_import_command(sub)
    add_write_artiq_results_command(sub)
    from dpdfit.cli.add import add_add_command
    add_add_command(sub)
    add_analyze_command(sub)
    describe(sub)
    return p


def check_outputs(args) -> None:
    """Check every output path of a command before it starts work (one line, exit 2).

    ``-o``/``--output`` and ``--log`` must be writable files (``analyze -o`` a
    results folder), ``--plot`` and ``simulate-campaign``'s folder writable folders.
    """
    folders = {"plot": "--plot folder"}
    if args.command == "analyze":
        folders["output"] = "results folder (-o)"
    if args.command == "simulate-campaign":
        folders["outdir"] = "campaign folder"
    if args.command in ("import", "add"):
        folders["output"] = "campaign folder (-o)"
    for attr, what in folders.items():
        if getattr(args, attr, None):
            check_output_folder(getattr(args, attr), what)
    for attr, what in (("output", "output file (-o)"), ("log", "log file (--log)")):
        if attr not in folders and isinstance(getattr(args, attr, None), str):
            check_output_file(getattr(args, attr), what)


def _run(args) -> int:
    """The command; one with ``--plot`` publishes its output file and figures together."""
    if getattr(args, "plot", None) is None:
        return args.func(args)
    with staged_outputs():
        return args.func(args)


def main(argv: list[str] | None = None) -> int:
    """Run one ``dpdfit`` command; returns its exit status (2 on any input or file error).

    Every failure is one line on stderr, ``dpdfit: error: ...``, with exit status 2 (130
    for Ctrl-C), and leaves no output behind (each is staged and published only at the
    end).  A :class:`~dpdfit.errors.DpdfitError` says what is wrong with which input.  As
    a last line of defence, any other exception is reported as an internal error naming
    its type and message, a bug to report; running out of memory or recursion depth says
    so.  Their tracebacks are logged at DEBUG level, on the logger ``dpdfit.cli.main``.
    """
    command = "dpdfit"
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # a usage error (one line printed, status 2), --help, --version
            return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
        command = f"dpdfit {args.command}"
        check_outputs(args)
        with cli_logging():
            return _run(args)
    except DpdfitError as exc:
        return _refused(str(exc))
    except OSError as exc:
        return _refused(f"{exc.filename}: {exc.strerror or exc}" if exc.filename
                        else f"{exc.strerror or exc}")
    except KeyboardInterrupt:
        # each output is written atomically (staged), so no file is left half-written
        print("dpdfit: interrupted", file=sys.stderr)
        return 130
    except MemoryError as exc:
        log.debug("out of memory while running %r", command, exc_info=True)
        return _refused(f"{OUT_OF_MEMORY} while running '{command}' ({_described(exc)})")
    except RecursionError as exc:
        log.debug("recursion too deep while running %r", command, exc_info=True)
        return _refused(f"{TOO_DEEP} for '{command}' ({_described(exc)})")
    except Exception as exc:  # noqa: BLE001 -- the last line of defence: one line, not a traceback
        log.debug("internal error while running %r", command, exc_info=True)
        return _refused(f"{INTERNAL_ERROR} while running '{command}' ({_described(exc)}): "
                        "a bug in dpdfit; please report it with the command and its inputs")


def _refused(message: str) -> int:
    """Print ``dpdfit: error: message`` as one line on stderr; the exit status 2."""
    print(f"dpdfit: error: {printable(_one_line(message))}", file=sys.stderr)
    return 2


def _one_line(text: str) -> str:
    # a message is one line by convention; a line break from deep inside (a library's own
    # text) must not make it two
    return re.sub(r"\s*[\r\n]+\s*", " ", text).strip()


def _described(exc: BaseException) -> str:
    """``Type: message``, the message cut to :data:`_MAX_DETAIL` characters."""
    text = _one_line(str(exc))
    if len(text) > _MAX_DETAIL:
        text = text[:_MAX_DETAIL] + "..."
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
