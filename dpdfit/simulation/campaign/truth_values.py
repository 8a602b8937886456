"""The kinds of value a campaign's ``truth.json`` config holds, each with its range.

A campaign's ``truth.json`` may come from elsewhere (a collaborator's folder) or be
damaged; its config drives the simulator when the simulator stands in for the lab
(``dpdfit write-artiq-results --schedule``), which allocates and loops by its numbers.  So
each value is checked before anything is simulated, against one declared kind:
:class:`Number`, :class:`Integer`, :class:`Text`, :class:`Timestamp`, :class:`ListOf`,
:class:`Fixed`, :class:`Tagged`, :class:`Record` (a nested noise model), :class:`Modulus`
(a complex parameter truth.json keeps the modulus of), :class:`Effects` and
:class:`Injected` (effects of the diagnosis's registry).  The table of which field is of
which kind is :data:`dpdfit.simulation.campaign.config.TRUTH_CONTRACT`.

Each kind reads one value as :func:`json.loads` gives it (a dict, list, str, int, float,
bool or None; Python's reader also gives NaN and Infinity) into the config's value (a
tuple for a list), or raises :class:`BadValue` naming the key path (``scan_shots[0][1]``,
``photodiode.p_full``), what the value must be, and the value as a person reads it.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.simulation import injections

__all__ = ["BadValue", "shown", "Kind", "Number", "Integer", "Text", "Timestamp", "ListOf", "Fixed",
           "Tagged", "Record", "Modulus", "Effects", "Injected"]

#: longest piece of a text value quoted in a message
_QUOTED_CHARS = 40


def shown(value) -> str:
    """``value`` (as JSON gives it) as a message shows it: ``null``, ``true``, ``-1``,
    ``1e+308``, ``NaN``, ``'ten'`` (its first characters), ``a list of 2 items``, ``an
    object``; an integer of many digits by its number of digits."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        digits = len(str(abs(value))) if abs(value) < 10 ** 30 else None
        return str(value) if digits else "an integer of more than 30 digits"
    if isinstance(value, float):
        return ("NaN" if math.isnan(value) else "Infinity" if value > 0 else "-Infinity") \
            if not math.isfinite(value) else f"{value:.10g}"
    if isinstance(value, str):
        return repr(value if len(value) <= _QUOTED_CHARS else value[:_QUOTED_CHARS] + "...")
    if isinstance(value, list):
        return f"a list of {len(value)} item{'' if len(value) == 1 else 's'}"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _bound(x) -> str:
    """A bound as the contract writes it: ``2^24`` for a large power of two, ``1e+09``,
    ``0.5``."""
    if isinstance(x, int) and x >= 1024 and x & (x - 1) == 0:
        return f"2^{x.bit_length() - 1}"
    if isinstance(x, int):
        return str(x)
    return "inf" if math.isinf(x) else f"{x:g}"


class BadValue(Exception):
    """A value of a truth.json config that is not of its kind: the key path, what the
    value must be, and the value (:func:`shown`); or, with ``reason``, why it cannot be."""

    def __init__(self, key: str, expected: str = "", value=None, *, reason: str = ""):
        self.key = key
        text = reason or f"must be {expected}, not {shown(value)}"
        super().__init__(f"config key '{key}' {text}")

    @classmethod
    def together(cls, keys: tuple, reason: str) -> BadValue:
        """Values of the config keys ``keys`` that cannot be together, and why."""
        exc = cls(keys[0])
        names = [f"'{k}'" for k in keys]
        exc.args = (f"config keys {', '.join(names[:-1])} and {names[-1]}: {reason}",)
        return exc


def _number(v, key: str, expected: str) -> float:
    """``v`` as a float: a JSON number (not a flag), else BadValue."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise BadValue(key, expected, v)
    try:
        return float(v)
    except OverflowError:                      # an integer beyond every float
        raise BadValue(key, expected, v) from None


class Kind:
    """One kind of value of truth.json's config (the module doc): what :meth:`read` takes."""

    def expected(self) -> str:
        """What a value of this kind must be, as a message says it (``an integer in
        [2, 10001]``)."""
        raise NotImplementedError

    def read(self, v, key: str):
        """The config's value of the JSON value ``v`` at the key path ``key``; BadValue
        naming ``key`` when ``v`` is not of this kind."""
        raise NotImplementedError


@dataclass(frozen=True)
class Number(Kind):
    """A number in ``[lo, hi]`` (an end open when ``lo_open``/``hi_open``; ``hi`` may be
    infinite: ``Infinity`` is then taken unless open); NaN never.  Read as a float."""

    lo: float
    hi: float
    lo_open: bool = False
    hi_open: bool = False
    #: the bounds as the message writes them, when not as numbers (``"2/pi"``)
    lo_text: str = ""
    hi_text: str = ""

    def expected(self) -> str:
        if math.isinf(self.lo) and math.isinf(self.hi) and self.lo_open and self.hi_open:
            return "a finite number"
        return (f"a number in {'(' if self.lo_open else '['}{self.lo_text or _bound(self.lo)}, "
                f"{self.hi_text or _bound(self.hi)}{')' if self.hi_open else ']'}")

    def read(self, v, key: str) -> float:
        x = _number(v, key, self.expected())
        inside = ((x > self.lo if self.lo_open else x >= self.lo)
                  and (x < self.hi if self.hi_open else x <= self.hi))
        if not inside:                          # NaN is never inside
            raise BadValue(key, self.expected(), v)
        return x


@dataclass(frozen=True)
class Integer(Kind):
    """An integer in ``[lo, hi]`` (a JSON number without a fraction: ``5`` or ``5.0``; a
    flag is not an integer).  Read as an int."""

    lo: int
    hi: int

    def expected(self) -> str:
        return f"an integer in [{_bound(self.lo)}, {_bound(self.hi)}]"

    def read(self, v, key: str) -> int:
        if isinstance(v, float) and not (math.isfinite(v) and v == int(v)):
            raise BadValue(key, self.expected(), v)
        if isinstance(v, bool) or not isinstance(v, (int, float)) \
                or not self.lo <= v <= self.hi:
            raise BadValue(key, self.expected(), v)
        return int(v)


@dataclass(frozen=True)
class Text(Kind):
    """One of the texts ``choices``."""

    choices: tuple

    def expected(self) -> str:
        return "one of " + ", ".join(repr(c) for c in self.choices)

    def read(self, v, key: str) -> str:
        if not isinstance(v, str) or v not in self.choices:
            raise BadValue(key, self.expected(), v)
        return v


@dataclass(frozen=True)
class Timestamp(Kind):
    """A date and time in ISO 8601 (:meth:`datetime.datetime.fromisoformat`) in the years
    ``first_year`` to ``last_year``: the campaign's recordings are dated days and hours
    after it, within the calendar."""

    first_year: int
    last_year: int

    def expected(self) -> str:
        return (f"a date and time in ISO 8601 (e.g. '2025-08-04T08:30:00+00:00') in the years "
                f"{self.first_year} to {self.last_year}")

    def read(self, v, key: str) -> str:
        try:
            when = _dt.datetime.fromisoformat(v) if isinstance(v, str) else None
        except ValueError:
            when = None
        if when is None or not self.first_year <= when.year <= self.last_year:
            raise BadValue(key, self.expected(), v)
        return v


@dataclass(frozen=True)
class ListOf(Kind):
    """A list of ``min_items`` to ``max_items`` values of the kind ``item``, ``distinct``
    when asked, holding every value of ``holding``.  Read as a tuple."""

    item: object
    min_items: int
    max_items: int
    distinct: bool = False
    holding: tuple = ()

    def expected(self) -> str:
        text = (f"a list of {_bound(self.min_items)} to {_bound(self.max_items)}"
                f"{' distinct' if self.distinct else ''} items")
        return text + (f" holding {' and '.join(map(str, self.holding))}"
                       if self.holding else "")

    def read(self, v, key: str) -> tuple:
        if not isinstance(v, list) or not self.min_items <= len(v) <= self.max_items:
            raise BadValue(key, self.expected(), v)
        out = tuple(self.item.read(x, f"{key}[{i}]") for i, x in enumerate(v))
        if self.distinct and len(set(out)) < len(out):
            i = next(i for i, x in enumerate(out) if x in out[:i])
            raise BadValue(f"{key}[{i}]", reason=f"repeats {shown(v[i])}: '{key}' must be "
                           f"{self.expected()}")
        missing = [h for h in self.holding if h not in out]
        if missing:
            raise BadValue(key, self.expected(), reason=f"lacks {missing[0]}: it must be "
                           f"{self.expected()}")
        return out


@dataclass(frozen=True)
class Fixed(Kind):
    """A list of exactly the named values ``[name, ...]``, each of its kind.  Read as a
    tuple."""

    names: tuple
    kinds: tuple

    def expected(self) -> str:
        return f"a list [{', '.join(self.names)}]"

    def read(self, v, key: str) -> tuple:
        if not isinstance(v, list) or len(v) != len(self.kinds):
            raise BadValue(key, self.expected(), v)
        return tuple(k.read(x, f"{key}[{i}]") for i, (k, x) in enumerate(zip(self.kinds, v)))


@dataclass(frozen=True)
class Tagged(Kind):
    """A list whose first value, a text, names its shape: ``shapes`` maps each such tag to
    the :class:`Fixed` of the values after it.  Read as a tuple (the tag first)."""

    shapes: dict

    def expected(self) -> str:
        return " or ".join(f"[{', '.join((repr(t),) + f.names)}]" for t, f in self.shapes.items())

    def read(self, v, key: str) -> tuple:
        if not isinstance(v, list) or not v:
            raise BadValue(key, self.expected(), v)
        if not isinstance(v[0], str) or v[0] not in self.shapes:
            raise BadValue(f"{key}[0]", "one of " + ", ".join(map(repr, self.shapes)), v[0])
        rest = self.shapes[v[0]]
        if len(v) != 1 + len(rest.kinds):
            raise BadValue(key, self.expected(), v)
        return (v[0],) + tuple(k.read(x, f"{key}[{i}]")
                               for i, (k, x) in enumerate(zip(rest.kinds, v[1:]), 1))


@dataclass(frozen=True)
class Record(Kind):
    """An object of some of the fields of the frozen dataclass ``cls`` (a noise model),
    each of its kind in ``fields``; the fields it leaves out keep their defaults."""

    cls: type
    fields: dict

    def expected(self) -> str:
        return f"a {self.cls.__name__} object of {', '.join(self.fields)}"

    def read(self, v, key: str):
        if not isinstance(v, dict):
            raise BadValue(key, self.expected(), v)
        unknown = [k for k in v if k not in self.fields]
        if unknown:
            raise BadValue(key, reason=f"is not a {self.cls.__name__}: it has no key "
                           f"{shown(unknown[0])} (keys: {', '.join(self.fields)})")
        return dataclasses.replace(self.cls(), **{k: self.fields[k].read(x, f"{key}.{k}")
                                                  for k, x in v.items()})


@dataclass(frozen=True)
class Modulus(Kind):
    """A complex parameter of which truth.json keeps the modulus (10 significant digits):
    the modulus, a :class:`Number` in ``[lo, hi]``, with the phase of ``default``; the
    modulus of ``default`` as written gives ``default`` itself."""

    default: complex
    lo: float
    hi: float

    def expected(self) -> str:
        return Number(self.lo, self.hi).expected() + " (a modulus)"

    def read(self, v, key: str) -> complex:
        m = Number(self.lo, self.hi).read(v, key)
        if float(f"{abs(self.default):.10g}") == m:
            return self.default
        return complex(m * np.exp(1j * np.angle(self.default)))


@dataclass(frozen=True)
class Effects(Kind):
    """The effects ``--effects`` named: an object of ``NAME`` (a registered effect's
    strength) or ``NAME.PARAM`` (one of its parameters) to a finite number.  ``key_check``
    parses a key (an :class:`~dpdfit.errors.InputError` saying why it is not one)."""

    key_check: Callable
    value: Number

    def expected(self) -> str:
        return "an object of NAME or NAME.PARAM of registered effects to numbers"

    def read(self, v, key: str) -> dict:
        if not isinstance(v, dict):
            raise BadValue(key, self.expected(), v)
        out = {}
        for name, x in v.items():
            try:
                self.key_check(name)
            except ValueError as exc:           # InputError: unknown effect or parameter
                raise BadValue(f"{key}.{name}", reason=f"is not NAME or NAME.PARAM of a "
                               f"registered effect ({exc})") from None
            out[name] = self.value.read(x, f"{key}.{name}")
        return out


@dataclass(frozen=True)
class Injected(Kind):
    """Effects of the diagnosis's registry injected with their values:
    ``[[effect, [[parameter, value], ...]], ...]``, each effect registered, each
    parameter one its injection takes (once), each value of the kind ``value``, or of
    the kind ``by_unit`` gives the unit the effect declares for it (a probability in
    [0, 1]).  Read as ``((effect, ((parameter, value), ...)), ...)``."""

    max_items: int
    value: Number
    by_unit: dict = dataclasses.field(default_factory=dict)

    def expected(self) -> str:
        return (f"a list of at most {self.max_items} [effect, [[parameter, value], ...]] "
                "items")

    def read(self, v, key: str) -> tuple:
        if not isinstance(v, list) or len(v) > self.max_items:
            raise BadValue(key, self.expected(), v)
        return tuple(self._effect(x, f"{key}[{i}]") for i, x in enumerate(v))

    def _effect(self, v, key: str) -> tuple:
        if not isinstance(v, list) or len(v) != 2:
            raise BadValue(key, "a list [effect, [[parameter, value], ...]]", v)
        name, items = v
        if not isinstance(name, str) or name not in EFFECTS:
            raise BadValue(f"{key}[0]", "a registered effect (" + ", ".join(EFFECTS) + ")",
                           name)
        known = tuple(injections.get(name).injection_params())
        if not isinstance(items, list):
            raise BadValue(f"{key}[1]", "a list of [parameter, value] pairs", items)
        out: dict = {}
        for j, item in enumerate(items):
            where = f"{key}[1][{j}]"
            if not isinstance(item, list) or len(item) != 2:
                raise BadValue(where, "a list [parameter, value]", item)
            if not isinstance(item[0], str) or item[0] not in known:
                raise BadValue(f"{where}[0]", f"a parameter of {name} ({', '.join(known)})",
                               item[0])
            if item[0] in out:
                raise BadValue(where, reason=f"gives the parameter {item[0]} of {name} again")
            unit = next((p.unit for p in EFFECTS[name].parameters() if p.name == item[0]), "")
            out[item[0]] = self.by_unit.get(unit, self.value).read(item[1], f"{where}[1]")
        return name, tuple(out.items())
