"""The command line's view of dpdfit's log messages and progress bars.

The library logs through :mod:`logging` (logger ``dpdfit`` and its children)
and prints nothing itself; :func:`cli_logging` shows those messages on stderr
for the duration of a command, as the command line always showed them:
INFO lines and warnings as they are, errors as ``dpdfit: error: ...``.
Messages are written with ``tqdm.write`` so that they never tear a progress bar.
"""

from __future__ import annotations

import contextlib
import logging
import sys

__all__ = ["cli_logging", "CliFormatter", "TqdmHandler"]


class CliFormatter(logging.Formatter):
    """``message`` as it is; ``dpdfit: error: message`` for errors."""

    def format(self, record: logging.LogRecord) -> str:
        msg = record.getMessage()
        return f"dpdfit: error: {msg}" if record.levelno >= logging.ERROR else msg


class TqdmHandler(logging.Handler):
    """Writes each record to the current ``sys.stderr`` through ``tqdm.write``."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            from tqdm import tqdm
            tqdm.write(self.format(record), file=sys.stderr)
            sys.stderr.flush()
        except Exception:  # noqa: BLE001 -- logging must never raise
            self.handleError(record)


@contextlib.contextmanager
def cli_logging(level: int = logging.INFO):
    """Show dpdfit's messages (``level`` and above) on stderr within the block."""
    logger = logging.getLogger("dpdfit")
    handler = TqdmHandler(level)
    handler.setFormatter(CliFormatter())
    old = logger.level
    logger.addHandler(handler)
    logger.setLevel(level)
    try:
        yield handler
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old)
