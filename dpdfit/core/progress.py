"""Progress bars for long work (tqdm), on by default in a terminal.

Every ``progress`` argument of dpdfit (``analyze``, ``diagnose``, the harness,
``propagate``, ``simulate_campaign``) takes ``None`` (the default: a bar when
stderr is a terminal), ``True`` or ``False``.  Bars are ``tqdm.auto`` bars
(a plain text bar in a terminal, a widget in a notebook when ipywidgets is
installed) on stderr; tqdm is imported only when a bar is made.

:func:`progress_scope` sets the default for everything run inside it, so that
``analyze(..., progress=False)`` also silences the bars of the work it calls.
"""

from __future__ import annotations

import contextlib
import contextvars
import sys

__all__ = ["progress_enabled", "progress_bar", "progress_scope", "job_progress"]

_DEFAULT: contextvars.ContextVar = contextvars.ContextVar("dpdfit_progress", default=None)


def progress_enabled(progress: bool | None = None) -> bool:
    """Whether to show a bar: ``progress`` if given, else the enclosing
    :func:`progress_scope`'s setting, else whether stderr is a terminal."""
    if progress is None:
        progress = _DEFAULT.get()
    if progress is None:
        isatty = getattr(sys.stderr, "isatty", None)
        return bool(isatty and isatty())
    return bool(progress)


@contextlib.contextmanager
def progress_scope(progress: bool | None):
    """Within the block, ``progress=None`` means ``progress`` (``None``: no change)."""
    token = _DEFAULT.set(progress if progress is not None else _DEFAULT.get())
    try:
        yield
    finally:
        _DEFAULT.reset(token)


def progress_bar(iterable=None, *, total=None, desc: str | None = None,
                 progress: bool | None = None, disable: bool | None = None, **kws):
    """A ``tqdm.auto.tqdm`` bar on stderr (``leave=False`` unless given), shown when
    :func:`progress_enabled` says so (``disable=True`` hides it whatever ``progress``)."""
    import warnings
    from tqdm import TqdmExperimentalWarning, TqdmWarning
    with warnings.catch_warnings():
        # tqdm.auto warns when a notebook lacks ipywidgets, then falls back to the
        # text bar, which is what we want there: no warning for the user to chase
        warnings.simplefilter("ignore", (TqdmWarning, TqdmExperimentalWarning))
        from tqdm.auto import tqdm
    off = (not progress_enabled(progress)) or bool(disable)
    kws.setdefault("leave", False)
    kws.setdefault("file", sys.stderr)
    return tqdm(iterable, total=total, desc=desc, disable=off, **kws)


@contextlib.contextmanager
def job_progress(progress, total: int, desc: str, initial: int = 0):
    """Yields ``update(k, n)`` ("k of n jobs done"): ``progress`` itself when it is a
    callable (the callback form), else a :func:`progress_bar`'s (``progress`` None/bool)."""
    if callable(progress):
        yield progress
        return
    with progress_bar(total=total, initial=initial, desc=desc, progress=progress) as bar:
        def update(k, n):
            bar.update(k - bar.n)
        yield update
