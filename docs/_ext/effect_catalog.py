"""``.. effect-catalog::``: the diagnosis's catalog of effects, generated from the registry.

Every row is read from :data:`dpdfit.analyses.diagnosis.effects.registry.EFFECTS` at
build time -- the effects in registry order, and for each what its
:class:`~dpdfit.analyses.diagnosis.effects.base.Effect` declares: ``name``, ``side``,
``meaning``, its forms (:meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.forms_for`),
its parameters (:class:`~dpdfit.analyses.diagnosis.effects.base.Param`), ``main`` with
the unit :meth:`~dpdfit.analyses.diagnosis.effects.base.Effect.size_values` gives it,
the hooks it overrides (and so the observables it can move), and from its injection
(:func:`dpdfit.simulation.injections.get`) the harness's strengths and the simulator
hooks.  An effect added to the registry appears here with no second list to keep.

Usage (MyST)::

    ```{effect-catalog}
    ```

    ```{effect-catalog}
    :table: parameters
    ```

``:table:`` is ``effects`` (default: one row per effect), ``parameters`` (one row per
parameter of each family) or ``injection`` (the harness's strengths -- the catalog
harness's and, per form, the leave-one-form-out harness's -- the simulator's hooks and
the ``simulate-campaign --effects`` knob of the same name).
"""

from __future__ import annotations

from typing import NamedTuple

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx import addnodes
from sphinx.util.docutils import SphinxDirective

#: the tone-side hooks of an Effect: hook -> what it changes
TONE_HOOKS = {
    "coefficients": "the static transfer's coefficients",
    "table_curve": "the calibration the predistortion table was built from",
    "transfer": "the field after the static transfer",
    "drive_filter": "a linear filter of the drive envelope",
    "power_memory": "a gain following the filtered drive power",
    "run_drift": "the calibration runs taken after the recordings",
}
#: the gate-side hooks: hook -> what it changes
GATE_HOOKS = {
    "knob_coefficients": "linear responses of the gate engine",
    "coherence": "the final state's coherences",
    "power_offset_db": "the optical power at gate time",
    "preparation": "preparation and detection errors",
}
#: the simulator's hooks of an Injection (dpdfit.simulation.injections): hook -> where it
#: injects
INJECT_HOOKS = {
    "inject_drive": "drive envelope",
    "inject_field": "optical field",
    "inject_photodiode": "calibration photodiode",
    "inject_aom": "AOM between runs",
    "inject_rf_gain": "RF gain ahead of the AOM between runs",
    "inject_table": "calibration behind the table",
    "inject_engine": "gate engine",
    "inject_coherence": "final state's coherences",
}
TABLES = ("effects", "parameters", "injection")


# ------------------------------------------------------------------ cell content
class Code(NamedTuple):
    """Inline literal text."""

    text: str


class ModRef(NamedTuple):
    """A link to a module's API page, shown as a literal."""

    target: str
    text: str


def _overrides(effect, hook: str) -> bool:
    from dpdfit.analyses.diagnosis.effects.base import Effect
    return getattr(type(effect), hook) is not getattr(Effect, hook)


def _injects(injection, hook: str) -> bool:
    from dpdfit.simulation.injections import Injection
    return getattr(type(injection), hook) is not getattr(Injection, hook)


def _join(items, sep=", ") -> list:
    out = []
    for i, item in enumerate(items):
        if i:
            out.append(sep)
        out.extend(item if isinstance(item, list) else [item])
    return out


def _num(x: float) -> str:
    return f"{x:g}"


def main_size(effect):
    """``(unit, meaning)`` of the effect's main size at its catalog form's starting values,
    or None when the effect states it only for a campaign (its ``size_values`` needs one)."""
    form = effect.forms_for()[0]
    p = {effect.key(q.name): float(form.fixed.get(q.name, q.start))
         for q in effect.parameters()}
    try:
        sizes = effect.size_values(None, p)
    except (AttributeError, TypeError, KeyError, ValueError):
        return None
    if effect.main not in sizes:
        return None
    _, unit, meaning = sizes[effect.main]
    return unit, meaning


def observables_of(effect) -> list:
    """The cell "acts through": each overridden hook and what it changes, then the
    observables of its side."""
    from dpdfit.analyses.diagnosis.observables.tone_features import TONE_FEATURES
    from dpdfit.analyses.diagnosis.evidence.mismatches import GATE_OBSERVABLES
    hooks = TONE_HOOKS if effect.side == "tones" else GATE_HOOKS
    paras = []
    for hook, what in hooks.items():
        if not _overrides(effect, hook):
            continue
        line = [Code(hook), f": {what}"]
        if hook == "knob_coefficients":
            line += [" (knobs "] + _join([Code(k.key) for k in effect.knobs()]) + [")"]
        paras.append(line)
    if effect.side == "tones":
        obs = [Code(n) for n in TONE_FEATURES]
        if _overrides(effect, "run_drift"):
            obs.append(Code("calibration_after"))
        paras.append(["observables: "] + _join(obs) + ["; the gates through its field"])
    else:
        paras.append(["observables: "] + _join([Code(n) for n in GATE_OBSERVABLES]))
    if effect.sign_sensitive:
        paras.append(["red/blue asymmetric: fitted under both phase-sign conventions"])
    return paras


# ------------------------------------------------------------------ the rows
def effect_rows() -> tuple[list, list]:
    """Header and rows of the ``effects`` table: one row per registered effect."""
    from dpdfit.analyses.diagnosis.effects.registry import EFFECTS
    header = ["effect", "side", "what it models", "forms (catalog first)",
              "size reported", "acts through"]
    rows = []
    for e in EFFECTS.values():
        name = [ModRef(type(e).__module__, e.name)]
        if not e.default:
            name.append(" (not considered by default)")
        size = [Code(e.main)]
        ms = main_size(e)
        if ms is not None:
            size += [f" ({ms[0]}): {ms[1]}"]
        rows.append([[name], [[e.side]], [[e.meaning]],
                     [_join([Code(f.name) for f in e.forms_for()])], [size],
                     observables_of(e)])
    return header, rows


def parameter_rows() -> tuple[list, list]:
    """Header and rows of the ``parameters`` table: one row per parameter of each
    effect's family (a campaign may have fewer, e.g. fewer drift modes)."""
    from dpdfit.analyses.diagnosis.effects.registry import EFFECTS
    header = ["effect", "parameter", "unit", "flat prior", "start", "meaning"]
    rows = []
    for e in EFFECTS.values():
        for p in e.parameters():
            rows.append([[[Code(e.name)]], [[Code(e.key(p.name))]], [[p.unit]],
                         [[f"[{_num(p.lo)}, {_num(p.hi)}]"]], [[_num(p.start)]],
                         [[p.meaning]]])
    return header, rows


def _ranges(e, ranges: dict) -> list:
    """``name ±[lo, hi] unit, ...`` of harness ranges, as one paragraph's pieces."""
    out = []
    for name, (lo, hi, signed) in ranges.items():
        rng = f"{'±' if signed else ''}[{_num(lo)}, {_num(hi)}]"
        unit = next((p.unit for p in e.params if p.name == name), "")
        out.append([Code(name), f" {rng} {unit}".rstrip()])
    return _join(out)


def _fixed(inj, form: str) -> list:
    """The values :meth:`form_values` sets for an injection in ``form`` where they differ
    from the injection's defaults (pieces)."""
    default = inj.injected({})
    vals = {k: v for k, v in inj.form_values(form).items() if default.get(k) != v}
    if not vals:
        return []
    return [" with "] + _join([[Code(f"{k}={_num(v)}")] for k, v in vals.items()])


def injection_rows() -> tuple[list, list]:
    """Header and rows of the ``injection`` table: one row per registered effect."""
    from dpdfit.analyses.diagnosis.effects.registry import EFFECTS
    from dpdfit.simulation import injections
    header = ["effect", "harness draws (uniform)", "per form (leave-one-form-out harness)",
              "simulator hooks", [Code("simulate-campaign --effects")]]
    rows = []
    for e in EFFECTS.values():
        inj = injections.get(e.name)
        draws = [_ranges(e, inj.harness)] if inj.harness else [["none"]]
        if inj.harness and not e.default:
            draws.append(["not concealed by default"])
        forms = [[Code(f), ": "] + _ranges(e, r) + _fixed(inj, f)
                 for f, r in inj.harness_table().items()] or [["none"]]
        hooks = [[Code(h), f" ({w})"] for h, w in INJECT_HOOKS.items() if _injects(inj, h)]
        param, unit, _ = inj.strength_of()
        knob = [[Code(f"{e.name}=STRENGTH"), " sets ", Code(param),
                 f" ({unit})" if unit else ""]]
        rows.append([[[Code(e.name)]], draws, forms, hooks or [["none"]], knob])
    return header, rows


ROWS = {"effects": effect_rows, "parameters": parameter_rows, "injection": injection_rows}


# ------------------------------------------------------------------ docutils nodes
def _inline(pieces) -> list:
    out = []
    for piece in pieces:
        if isinstance(piece, Code):
            out.append(nodes.literal(piece.text, piece.text))
        elif isinstance(piece, ModRef):
            ref = addnodes.pending_xref("", refdomain="py", reftype="mod",
                                        reftarget=piece.target, refexplicit=True,
                                        refwarn=False)
            ref += nodes.literal(piece.text, piece.text)
            out.append(ref)
        else:
            out.append(nodes.Text(str(piece)))
    return out


def _entry(cell) -> nodes.entry:
    entry = nodes.entry()
    for para in cell:
        p = nodes.paragraph()
        p.extend(_inline(para))
        entry += p
    return entry


def build_table(header: list, rows: list) -> nodes.table:
    """A docutils table: ``header`` (a str or a list of pieces per column), ``rows``
    (cells: lists of paragraphs, each a list of pieces: str, :class:`Code`,
    :class:`ModRef`)."""
    table = nodes.table(classes=["effect-catalog"])
    group = nodes.tgroup(cols=len(header))
    table += group
    for _ in header:
        group += nodes.colspec(colwidth=1)
    head = nodes.thead()
    row = nodes.row()
    for h in header:
        row += _entry([h if isinstance(h, list) else [h]])
    head += row
    group += head
    body = nodes.tbody()
    for cells in rows:
        row = nodes.row()
        for cell in cells:
            row += _entry(cell)
        body += row
    group += body
    return table


def table_effect_names(table: nodes.table) -> list[str]:
    """The effect names in the first column of a generated table (its body rows)."""
    body = next(iter(table.findall(nodes.tbody)))
    return [next(iter(row.children[0].findall(nodes.literal))).astext()
            for row in body.children]


class EffectCatalog(SphinxDirective):
    """Insert a table of the registered effects (see module doc)."""

    has_content = False
    option_spec = {"table": lambda arg: directives.choice(arg, TABLES)}

    def _note_sources(self) -> None:
        """Re-read the page when a registry, an effect's module or its injection's
        changes."""
        import inspect

        from dpdfit.analyses.diagnosis.effects import base, registry
        from dpdfit.analyses.diagnosis.effects.registry import EFFECTS
        from dpdfit.simulation import injections
        from dpdfit.simulation.injections import base as injection_base
        from dpdfit.simulation.injections import registry as injection_registry
        files = {inspect.getsourcefile(m) for m in (base, registry, injection_base,
                                                     injection_registry)}
        files |= {inspect.getsourcefile(type(e)) for e in EFFECTS.values()}
        files |= {inspect.getsourcefile(type(injections.get(n))) for n in EFFECTS}
        for f in sorted(x for x in files if x):
            self.env.note_dependency(f)

    def run(self) -> list[nodes.Node]:
        which = self.options.get("table", "effects")
        self._note_sources()
        header, rows = ROWS[which]()
        out = [build_table(header, rows)]
        return out


def setup(app):
    app.add_directive("effect-catalog", EffectCatalog)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
