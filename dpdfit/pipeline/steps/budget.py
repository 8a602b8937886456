"""Step ``budget`` of ``dpdfit analyze``: the error budget of the fidelity offset (Table S2).

The budget (S10) is computed from ``budget.toml`` in the campaign folder (or
the paper's inputs), with the gate times from ``gate_rates.csv`` and ``delta``
from the alignment fit of the ``gates`` step.  -> ``budget.json``.
"""

from __future__ import annotations

from dpdfit.analyses.budget import error_budget, load_budget_config

from ..context import Context
from .gates import GateResults

__all__ = ["budget_step", "budget_summary"]

#: the budget's terms in the ``budget`` section of ``summary.json``, in order (stated
#: here once: ``summary.md`` renders the section as it is)
_BUDGET_KEYS = ("state_preparation", "dephasing", "heating", "detection", "total", "delta",
                "unexplained")


def _budget_config(ctx: Context, alignment):
    """The budget's inputs: ``budget.toml`` (or None: the paper's), the fitted delta, the
    gate rates."""
    path = ctx.folder / "budget.toml"
    cfg = load_budget_config(path, within=ctx.folder) if path.exists() else None
    if alignment is not None:
        cfg = dict(cfg or {})
        cfg["delta"] = {"value": alignment.delta, "error": alignment.delta_err, "enabled": True}
    rates = ctx.campaign.gate_rates
    if rates is not None:
        cfg = dict(cfg or {})
        cfg["gate"] = {**(cfg.get("gate") or {}),
                       "rates_khz": [float(x) for x in rates["xi0_khz"]]}
    return cfg


def budget_step(ctx: Context, gates: GateResults | None):
    """Table S2 from the campaign's budget.toml (or the paper's inputs) and the fitted delta
    of the gates step."""
    res = ctx.results
    al = None if gates is None else gates.alignment
    b = error_budget(_budget_config(ctx, al))
    res.json_file("budget.json", b.to_dict())
    src = "budget.toml" if (ctx.folder / "budget.toml").exists() else "the paper's inputs"
    res.status("budget", "ok", f"inputs from {src}; delta from "
                               f"{'the alignment fit' if al else 'the inputs'}")
    return b


def budget_summary(b) -> dict:
    """The ``budget`` section of ``summary.json``."""
    d = b.to_dict()
    return {k: d[k] for k in _BUDGET_KEYS}
