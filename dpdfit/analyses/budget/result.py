"""Result of the error budget: per-source statistics, total, delta, the paper's column."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import pandas as pd

from dpdfit.core.display import Displayable

__all__ = ["SOURCES", "PAPER_TABLE", "BudgetResult"]

SOURCES = ("state_preparation", "dephasing", "heating", "detection")

#: Table S2 as printed (strings) for the side-by-side report.
PAPER_TABLE = {"state_preparation": "<~0.6%", "dephasing": "0.3-0.6%", "heating": "<0.01%",
               "detection": "<0.02%", "total": "<~0.9-1.2%", "delta": "1.8 +/- 0.3%"}


@dataclass(frozen=True, repr=False)
class BudgetResult(Displayable):
    """Error budget (fractions of fidelity; ``estimate`` = MC mean, ``error`` = MC sd).

    Attributes
    ----------
    sources : dict
        Per source: ``estimate``, ``error``, ``median``, ``interval_68``,
        ``upper_95``, ``at_T_min``, ``at_T_max`` (loss at the nominal inputs'
        MC mean for the shortest / longest gate time).
    total : dict
        Same statistics for the sum of the sources.
    delta : dict or None
        ``{"estimate": value, "error": error}`` as given.
    unexplained : dict or None
        Statistics of ``|delta| - total``.
    p_unexplained_positive : float or None
        Monte-Carlo ``P(|delta| - total > 0)``.
    paper : dict
        The paper's own method applied to these inputs (``2 (1-A)``,
        ``1 - exp(-T/T2)`` at T_min..T_max, ``2 p_det``, heating bound
        ``ndot T_max`` as Delta nbar) and its printed Table S2 strings.
    gate_times_us : tuple
        ``(T_min, T_mean, T_max)`` [us] used.
    inputs : dict
        The full validated configuration.
    """

    sources: dict
    total: dict
    delta: dict | None
    unexplained: dict | None
    p_unexplained_positive: float | None
    paper: dict
    gate_times_us: tuple
    inputs: dict = field(repr=False)

    def to_dict(self) -> dict:
        """JSON-ready dict; stable top-level keys (see module docstring)."""
        def ee(d):
            return None if d is None else {"estimate": d["estimate"], "error": d["error"]}
        out = {name: ee(self.sources[name]) for name in SOURCES}
        out["total"] = ee(self.total)
        out["delta"] = ee(self.delta)
        out["unexplained"] = ee(self.unexplained)
        out["p_unexplained_positive"] = self.p_unexplained_positive
        out["paper"] = copy.deepcopy(self.paper)
        det = {name: dict(self.sources[name]) for name in SOURCES}
        det["total"] = dict(self.total)
        if self.unexplained is not None:
            det["unexplained"] = dict(self.unexplained)
        det["gate_times_us"] = {"min": self.gate_times_us[0], "mean": self.gate_times_us[1],
                                "max": self.gate_times_us[2]}
        det["statistics"] = ("estimate = Monte-Carlo mean, error = standard deviation; "
                             "interval_68 = 16th-84th percentiles")
        out["details"] = det
        out["inputs"] = copy.deepcopy(self.inputs)
        return out

    def to_frame(self) -> pd.DataFrame:
        """The budget rows (sources, total, delta, unexplained): estimate, error, ..."""
        rows = {**self.sources, "total": self.total, "delta": self.delta,
                "unexplained": self.unexplained}
        return pd.DataFrame([{"source": k, **{q: v for q, v in d.items() if not isinstance(
            v, (list, tuple, dict))}} for k, d in rows.items() if d is not None])

    def report(self, paper: bool = True) -> str:
        """Table in the style of Table S2 (percent), optionally with the paper's column."""
        def pct(d):
            return f"{100 * d['estimate']:.3f} +/- {100 * d['error']:.3f}"

        def rng(d):
            return f"{100 * d['at_T_min']:.3f}-{100 * d['at_T_max']:.3f}"

        labels = {"state_preparation": "State preparation (optical pumping)",
                  "dephasing": "Qubit dephasing (T2)", "heating": "Motional heating",
                  "detection": "State detection (camera)"}
        head = f"{'Error source':<36} {'ours [%] mean +/- sd':>22} {'T_min-T_max [%]':>16}"
        if paper:
            head += f" {'paper method [%]':>17} {'Table S2':>12}"
        lines = [f"Error budget of the measured fidelity (F_pop + F_par)/2; gate times "
                 f"{self.gate_times_us[0]:.0f}-{self.gate_times_us[2]:.0f} us "
                 f"(mean {self.gate_times_us[1]:.0f} us)", head, "-" * len(head)]
        for name in SOURCES:
            d = self.sources[name]
            row = f"{labels[name]:<36} {pct(d):>22} {rng(d):>16}"
            if paper:
                row += f" {self.paper['method'][name]:>17} {PAPER_TABLE[name]:>12}"
            lines.append(row)
        lines.append("-" * len(head))
        row = f"{'Total (characterised)':<36} {pct(self.total):>22} {rng(self.total):>16}"
        if paper:
            row += f" {self.paper['method']['total']:>17} {PAPER_TABLE['total']:>12}"
        lines.append(row)
        if self.delta is not None:
            d = self.delta
            txt = f"{100 * abs(d['estimate']):.3f} +/- {100 * d['error']:.3f}"
            row = f"{'Measured offset |delta|':<36} {txt:>22}"
            lines.append(row + (f" {'':>16} {'':>17} {PAPER_TABLE['delta']:>12}" if paper else ""))
            u = self.unexplained
            lines.append(f"{'Unexplained |delta| - total':<36} {pct(u):>22}   "
                         f"68% [{100 * u['interval_68'][0]:.3f}, {100 * u['interval_68'][1]:.3f}]"
                         f", P(>0) = {self.p_unexplained_positive:.4f}")
        lines.append("Statistics: Monte-Carlo mean +/- sd over the input distributions "
                     f"({self.inputs['monte_carlo']['samples']} draws); upper limits as "
                     "uniform priors [0, limit].")
        lines.append("Ours: loss of (F_pop + F_par)/2 validated against dpdfit.models.gate_sim; "
                     "dephasing = 0.591 T/T2 (contrast loss T/T2 x 0.591), preparation "
                     "p - p^2/2 per-ion p, detection 3p(1-p), heating 0.25 ndot T.")
        return "\n".join(lines)
