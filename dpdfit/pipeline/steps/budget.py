"""Step ``budget`` of ``dpdfit analyze``: the error budget of the fidelity offset (Table S3).

The budget (S8) is computed from ``budget.toml`` in the campaign folder (or
the paper's inputs), with the gate times from ``gate_rates.csv`` and ``delta``
from the alignment fit of the ``gates`` step.  -> ``budget.json``.
"""

from __future__ import annotations

from dpdfit.analyses.budget import error_budget, load_budget_config, read_gate_rates

from ..context import Context

__all__ = ["budget_step"]

_BUDGET_KEYS = ("state_preparation", "dephasing", "heating", "detection", "total", "delta",
                "unexplained")


def _budget_config(ctx: Context):
    """The budget's inputs: ``budget.toml`` (or None: the paper's), the fitted delta, the
    gate rates."""
    folder, res = ctx.folder, ctx.results
    path = folder / "budget.toml"
    cfg = load_budget_config(path) if path.exists() else None
    al = (res.summary.get("gates") or {}).get("alignment")
    if al:
        cfg = dict(cfg or {})
        cfg["delta"] = {"value": al["delta"], "error": al["delta_err"], "enabled": True}
    rates = folder / "gate_rates.csv"
    if rates.exists():
        cfg = dict(cfg or {})
        cfg["gate"] = {**(cfg.get("gate") or {}), "rates_khz": read_gate_rates(rates)}
    return cfg


def budget_step(ctx: Context):
    """Table S3 from the campaign's budget.toml (or the paper's inputs) and the fitted delta."""
    res = ctx.results
    b = error_budget(_budget_config(ctx))
    d = b.to_dict()
    res.json_file("budget.json", d)
    res.summary["budget"] = {k: d[k] for k in _BUDGET_KEYS}
    src = "budget.toml" if (ctx.folder / "budget.toml").exists() else "the paper's inputs"
    al = (res.summary.get("gates") or {}).get("alignment")
    res.status("budget", "ok", f"inputs from {src}; delta from "
                               f"{'the alignment fit' if al else 'the inputs'}")
    return b
