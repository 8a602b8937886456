"""How a result shows itself: short repr, text table, HTML table.

Rendering is kept apart from the physics, the way iminuit keeps its
``repr_text``/``repr_html``: a result class inherits :class:`Displayable`
and, at most, says *what* to show through two hooks,

* ``_display_rows()`` -> list of ``(name, value, error, unit)``,
* ``_display_diagnostics()`` -> dict of fit diagnostics (chi2, dof, p-value,
  model adequacy, ``"warnings"``: list of str),

both of which default to reading the result's own ``to_dict()``.  This module
turns them into text and HTML; it knows nothing of any result's meaning.

Numbers are formatted with fixed significant digits (:data:`VALUE_DIGITS`,
errors with :data:`ERROR_DIGITS`, the value then rounded to its error's last
digit), so the renderings are stable across platforms and serve as golden
files (``tests/golden``).
"""

from __future__ import annotations

import html
import math
from dataclasses import fields, is_dataclass

import numpy as np

from dpdfit.core.jsonable import to_jsonable

__all__ = ["VALUE_DIGITS", "ERROR_DIGITS", "MAX_ROWS", "Displayable", "format_number",
           "format_value_error", "rows_from_dict", "diagnostics_from_dict", "text_table",
           "html_table", "short_repr", "plain"]

#: significant digits of a value shown without an error
VALUE_DIGITS = 6
#: significant digits of an error (the value is rounded to the same decimal place)
ERROR_DIGITS = 2
#: rows shown before the table is cut ("... n more")
MAX_ROWS = 24

_DIAG_KEYS = ("chi2", "dof", "reduced_chi2", "redchi", "chi2_p_value", "model_adequate",
              "redchi_range_99", "birge_factor", "n_points", "converged", "monotone", "flag")
_ERR_SUFFIXES = ("_err", "_stderr")
_NOT_LISTED = {"powers", "stderr", "raw_coefficients", "harmonics", "gate"}
_DIAG_LABELS = {"reduced_chi2": "reduced chi2", "redchi": "reduced chi2",
                "chi2_p_value": "p-value", "model_adequate": "model adequate",
                "redchi_range_99": "99% range", "birge_factor": "Birge factor"}
_UNITS = {"khz": "kHz", "hz": "Hz", "db": "dB", "us": "us", "s": "s", "rad": "rad",
          "days": "d", "day": "1/d"}


def plain(value):
    """``value`` as plain python (numpy scalars/arrays and frames converted; NaN kept):
    :func:`dpdfit.core.jsonable.to_jsonable` for display."""
    return to_jsonable(value, finite_only=False)


def format_number(value, digits: int = VALUE_DIGITS) -> str:
    """A number with ``digits`` significant digits; ints, bools and strings as they are."""
    if value is None:
        return "-"
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if not math.isfinite(v):
            return str(v)
        return f"{v:.{digits}g}"
    return str(value)


def format_value_error(value, error) -> tuple[str, str]:
    """(value, error) as strings: the error to :data:`ERROR_DIGITS` significant digits,
    the value rounded to the error's last shown digit (plain :func:`format_number`
    without a finite positive error)."""
    try:
        v, e = float(value), float(error)
    except (TypeError, ValueError):
        return format_number(value), format_number(error)
    if not (math.isfinite(v) and math.isfinite(e) and e > 0):
        return format_number(value), format_number(error)
    last = math.floor(math.log10(e)) - (ERROR_DIGITS - 1)     # exponent of the last digit
    top = math.floor(math.log10(max(abs(v), e)))
    if top < 7 and (last >= -5 or (top >= -2 and last >= -10)):
        decimals = max(0, -last)
        v = round(v, decimals) + 0.0                           # no "-0.000"
        return f"{v:.{decimals}f}", f"{round(e, decimals):.{decimals}f}"
    digits = max(top - last, 0)
    return f"{v:.{digits}e}", f"{e:.{ERROR_DIGITS - 1}e}"


def _error_of(d: dict, key: str):
    for cand in [key + s for s in _ERR_SUFFIXES] + [
            f"{key.rsplit('_', 1)[0]}{s}_{key.rsplit('_', 1)[1]}" for s in _ERR_SUFFIXES
            if "_" in key]:
        if cand in d:
            return cand
    return None


def _unit(key: str) -> str:
    tail = key.rsplit("_", 1)[-1]
    return _UNITS.get(tail.lower(), "") if "_" in key else ""


def _is_scalar(v) -> bool:
    return isinstance(v, (int, float, bool, np.integer, np.floating, np.bool_)) or v is None


def rows_from_dict(d: dict, symbol: str = "c") -> list[tuple]:
    """Display rows ``(name, value, error, unit)`` read from a ``to_dict()``.

    Scalars (with their ``*_err``/``*_stderr`` partner as error), short strings,
    ``coefficients`` (with ``stderr`` and ``powers``) expanded one per row as
    ``<symbol>_<power>`` (the name the guide gives them, e.g. ``a_2``), and
    small dicts of scalars as ``key.sub``; diagnostics, long strings and big
    nested values are left to :meth:`Displayable.to_dict`.
    """
    errs = {k for k in d if _error_of(d, k)}
    err_keys = {_error_of(d, k) for k in errs}
    rows = []
    for key, val in d.items():
        if key in _DIAG_KEYS or key in err_keys or key.endswith("_birge"):
            continue
        if key == "coefficients" and isinstance(val, list) and _is_scalar(val[0] if val else 0):
            se = d.get("stderr") or [None] * len(val)
            pw = d.get("powers") or list(range(len(val)))
            rows += [(f"{symbol}_{p}", c, s, "") for p, c, s in zip(pw, val, se)]
        elif _is_scalar(val):
            e = d.get(_error_of(d, key)) if key in errs else None
            rows.append((key, val, e if _is_scalar(e) else None, _unit(key)))
        elif isinstance(val, str) and len(val) <= 40:
            rows.append((key, val, None, ""))
        elif isinstance(val, dict) and set(val) == {"estimate", "error"}:
            rows.append((key, val["estimate"], val["error"], _unit(key)))
        elif isinstance(val, dict) and 0 < len(val) <= 8 and all(map(_is_scalar, val.values())):
            rows += [(f"{key}.{k}", v, None, "") for k, v in val.items()]
        elif (isinstance(val, list) and 1 < len(val) <= 64 and key not in _NOT_LISTED
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in val)):
            rows.append((key, f"{len(val)} values, {format_number(min(val))} .. "
                              f"{format_number(max(val))}", None, _unit(key)))
    return rows


def diagnostics_from_dict(d: dict) -> dict:
    """Fit diagnostics read from a ``to_dict()`` plus ``"warnings"`` (a list of str)."""
    out = {k: d[k] for k in _DIAG_KEYS if k in d}
    warnings = []
    if d.get("model_adequate") is False:
        lo, hi = d.get("redchi_range_99") or (float("nan"), float("nan"))
        red = d.get("reduced_chi2", d.get("redchi"))
        what = ("model does not describe the data" if red > hi else
                "sigmas look too large")
        warnings.append(f"{what}: reduced chi2 {red:.3g} outside "
                        f"its 99 % range [{lo:.3g}, {hi:.3g}]; Birge factor "
                        f"{d.get('birge_factor', float('nan')):.3g}")
        scaled = [f"{k[:-6]} +/- {v:#.{ERROR_DIGITS}g}" for k, v in d.items()
                  if k.endswith(("_err_birge", "_stderr_birge")) and isinstance(v, float)]
        if scaled and red > hi:
            warnings.append("Birge-scaled errors (the errors above stay absolute): "
                            + ", ".join(scaled))
    if d.get("converged") is False:
        warnings.append("not converged")
    if d.get("monotone") is False:
        warnings.append("not monotone")
    if d.get("flag"):
        warnings.append(f"flag: {d['flag']}")
    warnings += [str(n) for n in d.get("notes", []) or [] if isinstance(n, str)]
    out["warnings"] = warnings
    return out


def _diag_items(diag: dict) -> list[tuple[str, str]]:
    """(label, text) pairs of the diagnostics, chi2 and dof merged."""
    items = []
    if "chi2" in diag and "dof" in diag:
        items.append(("chi2/dof", f"{format_number(diag['chi2'], 4)}/{diag['dof']}"))
    for k, v in diag.items():
        if k == "warnings" or v is None or (k in ("chi2", "dof") and items):
            continue
        if k == "redchi_range_99" and v is not None:
            v = f"[{format_number(v[0], 3)}, {format_number(v[1], 3)}]"
        items.append((_DIAG_LABELS.get(k, k), format_number(v, 4)))
    return items


def _cells(rows) -> list[tuple[str, str, str, str]]:
    out = []
    for name, value, error, unit in rows:
        v, e = format_value_error(value, error) if error is not None else (
            format_number(value), "")
        out.append((str(name), v, e, str(unit or "")))
    return out


def text_table(title: str, rows, diag: dict) -> str:
    """A plain-text table: the title, one line per row, diagnostics and warnings."""
    cells = _cells(rows[:MAX_ROWS])
    w = [max([len(c[i]) for c in cells] + [len(h)]) for i, h in enumerate(
        ("name", "value", "error", "unit"))]
    lines = [f"[[{title}]]"]
    if cells:
        lines.append(f"    {'name':<{w[0]}}  {'value':>{w[1]}}  {'error':>{w[2]}}  unit")
        lines += [f"    {n:<{w[0]}}  {v:>{w[1]}}  {e:>{w[2]}}  {u}".rstrip()
                  for n, v, e, u in cells]
    if len(rows) > MAX_ROWS:
        lines.append(f"    ... {len(rows) - MAX_ROWS} more")
    items = _diag_items(diag)
    if items:
        lines.append("    " + ", ".join(f"{k} = {v}" for k, v in items))
    lines += [f"    WARNING: {w_}" for w_ in diag.get("warnings", [])]
    return "\n".join(lines)


def html_table(title: str, rows, diag: dict) -> str:
    """A compact HTML table of the rows, diagnostics below; every string escaped."""
    esc = html.escape
    cells = _cells(rows[:MAX_ROWS])
    out = ['<table class="dpdfit-result">',
           f'<caption style="text-align:left"><b>{esc(title)}</b></caption>',
           "<thead><tr><th>name</th><th>value</th><th>error</th><th>unit</th></tr></thead>",
           "<tbody>"]
    out += [f'<tr><td style="text-align:left">{esc(n)}</td><td>{esc(v)}</td>'
            f"<td>{esc(e)}</td><td>{esc(u)}</td></tr>" for n, v, e, u in cells]
    if len(rows) > MAX_ROWS:
        out.append(f'<tr><td colspan="4">... {len(rows) - MAX_ROWS} more</td></tr>')
    out.append("</tbody></table>")
    items = _diag_items(diag)
    if items:
        out.append('<table class="dpdfit-diagnostics"><tr>'
                   + "".join(f"<th>{esc(k)}</th>" for k, _ in items) + "</tr><tr>"
                   + "".join(f"<td>{esc(v)}</td>" for _, v in items) + "</tr></table>")
    out += [f'<p style="color:#b00000">&#9888; {esc(w)}</p>' for w in diag.get("warnings", [])]
    return "\n".join(out)


def short_repr(name: str, rows, diag: dict, n: int = 3) -> str:
    """``Name(key=value+/-error, ..., chi2/dof=..)``: a few key numbers, no arrays."""
    parts = []
    for row_name, v, e, u in _cells(rows[:n]):
        parts.append(f"{row_name}={v}" + (f"+/-{e}" if e else "") + (f" {u}" if u else ""))
    parts += [f"{k}={v}" for k, v in _diag_items(diag)
              if k in ("chi2/dof", "reduced chi2", "model adequate")]
    if diag.get("warnings"):
        parts.append(f"warnings={len(diag['warnings'])}")
    return f"{name}({', '.join(parts)})"


class Displayable:
    """Mixin giving a result ``__str__`` (its report), ``__repr__`` (short),
    ``_repr_html_`` (Jupyter), a default ``report()`` and ``to_dict()``.

    A dataclass using it is declared with ``repr=False`` so that this
    ``__repr__`` is kept.  Override ``_display_rows``/``_display_diagnostics``
    to choose what is shown; ``_display_title`` names the table.
    """

    _display_title: str | None = None
    #: name of the polynomial coefficients in the rows, as the guide writes them
    _coefficient_symbol: str = "c"

    def _display_rows(self) -> list[tuple]:
        return rows_from_dict(self.to_dict(), self._coefficient_symbol)

    def _display_diagnostics(self) -> dict:
        return diagnostics_from_dict(self.to_dict())

    def _title(self) -> str:
        return self._display_title or type(self).__name__

    def display_text(self) -> str:
        """The compact text table (fixed significant digits)."""
        return text_table(self._title(), self._display_rows(), self._display_diagnostics())

    def report(self) -> str:
        """Readable report (default: :meth:`display_text`)."""
        return self.display_text()

    def to_dict(self) -> dict:
        """Public dataclass fields as plain python (default)."""
        if not is_dataclass(self):
            return {}
        return {f.name: plain(getattr(self, f.name)) for f in fields(self)
                if not f.name.startswith("_")}

    def __str__(self) -> str:
        return self.report()

    def __repr__(self) -> str:
        try:
            return short_repr(type(self).__name__, self._display_rows(),
                              self._display_diagnostics())
        except Exception as exc:        # a repr must not raise (debuggers, tracebacks)
            return f"<{type(self).__name__}: no summary ({type(exc).__name__})>"

    def _repr_html_(self) -> str:
        return html_table(self._title(), self._display_rows(), self._display_diagnostics())
