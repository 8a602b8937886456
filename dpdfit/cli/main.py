"""The ``dpdfit`` command line: a thin layer over the Python API (also ``python -m dpdfit``).

Every sub-command validates its inputs through :mod:`dpdfit.recordings.tables`, calls the
API, and writes its outputs atomically.  Any :class:`~dpdfit.errors.DpdfitError`
is printed as one line ``dpdfit: error: ...`` on stderr with exit status 2; so is, as
a last line of defence, any other exception (:func:`main`), and no traceback is shown.
The library's log messages are shown on stderr while a command runs
(:mod:`dpdfit.cli.logs`); progress bars appear when stderr is a terminal.

Each command (or small family of commands) lives in its own module of
:mod:`dpdfit.cli` with an ``add_<command>_command(subparsers)`` that registers
it; this module only assembles the parser, in the order of ``dpdfit --help``
(:data:`COMMANDS`).  A command starts at once: :func:`main` imports only the module of
the command it runs (the others are listed by name and summary), and that module imports
the library when the command runs, not when its options are registered.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import re
import sys
from collections.abc import Collection

from dpdfit.cli.help_texts import OVERVIEW_EXAMPLES, OVERVIEW_NOTE, SUMMARIES, describe
from dpdfit.cli.logs import cli_logging
from dpdfit.core.version import __version__
from dpdfit.errors import DpdfitError, printable

__all__ = ["main", "build_parser", "check_outputs", "COMMANDS", "DESCRIPTION", "EPILOG",
           "INTERNAL_ERROR", "OUT_OF_MEMORY", "TOO_DEEP"]

log = logging.getLogger(__name__)

#: The top of ``dpdfit --help`` (plain text).
DESCRIPTION = ("dpdfit: analysis of digitally predistorted (DPD) trapped-ion entangling-gate "
               "experiments --\nAOM transfer-function fits, predistortion tables, spectra, "
               "fidelities, diagnosis.")
#: The bottom of ``dpdfit --help``.
EPILOG = ("examples:\n  " + OVERVIEW_EXAMPLES.replace("\n", "\n  ") + "\n\n" + OVERVIEW_NOTE)
#: command -> the module that registers it (``add_<command>_command``), in the order of
#: ``dpdfit --help``
COMMANDS = {
    **dict.fromkeys(("polyfit", "calibrate", "lut"), "dpdfit.cli.calibration"),
    **dict.fromkeys(("sweep", "estimate", "im-table", "thresholds"), "dpdfit.cli.spectral"),
    "spectrum": "dpdfit.cli.spectrum",
    "stability": "dpdfit.cli.stability",
    "propagate": "dpdfit.cli.propagate",
    "budget": "dpdfit.cli.budget",
    "diagnose": "dpdfit.cli.diagnose",
    "harness": "dpdfit.cli.harness",
    **dict.fromkeys(("fidelity", "align"), "dpdfit.cli.gates"),
    "simulate-campaign": "dpdfit.cli.campaign",
    **dict.fromkeys(("import", "write-artiq-results"), "dpdfit.cli.import_campaign"),
    "add": "dpdfit.cli.add",
    "analyze": "dpdfit.cli.campaign",
}

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


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The ``dpdfit`` parser: each command registered by its module in ``dpdfit.cli``.

    With ``commands``, only those are registered with their options; the others are
    listed by name and summary alone (all that ``dpdfit --help`` and a usage error
    show), so that their modules are not imported.
    """
    p = _OneLineParser(
        prog="dpdfit", description=DESCRIPTION, epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action="version", version=f"dpdfit {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module in COMMANDS.items():
        if commands is None or name in commands:
            register = f"add_{name.replace('-', '_')}_command"
            getattr(importlib.import_module(module), register)(sub)
        else:
            sub.add_parser(name, help=SUMMARIES[name])
    describe(sub)
    return p


def _command_named(argv: list[str]) -> list[str]:
    """The command an argument list runs: its first word that is not an option (the
    ``dpdfit`` parser's own options, ``-h`` and ``--version``, take no value)."""
    return [str(a) for a in argv if not str(a).startswith("-")][:1]


def check_outputs(args) -> None:
    """Check every output path of a command before it starts work (one line, exit 2).

    ``-o``/``--output`` and ``--log`` must be writable files (``analyze -o`` a
    results folder), ``--plot`` and ``simulate-campaign``'s folder writable folders.
    """
    # here, not at the top: dpdfit --help starts without numpy (which the outputs need)
    from dpdfit.recordings.outputs import check_output_file, check_output_folder
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
    # here, not at the top: dpdfit --help starts without numpy (which the outputs need)
    from dpdfit.recordings.outputs import staged_outputs
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
        argv = sys.argv[1:] if argv is None else list(argv)
        parser = build_parser(_command_named(argv))
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
