"""Step ``gates`` of ``dpdfit analyze``: fidelities from the counts and the alignment fit (S7).

Population and parity fidelities per setting pooled over scans (``gate.csv``,
joined with ``gate_rates.csv``), the alignment fit of ``alpha`` and ``delta``
against the simulated sweep (``alignment_points.csv``), Figs. 3, 4, S6, S7.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dpdfit.core.defaults import ERROR_MODEL, ErrorModel
from dpdfit.fits.alignment import AlignmentFit, align
from dpdfit.fits.counts import gate_fidelities, merge_parity
from dpdfit.report.gate_plots import gate_figures

from ..context import Context
from .spectra import SimulatedSweep

__all__ = ["gates_step", "closest_pair", "GateResults", "gates_summary", "power_jitter_db"]



def power_jitter_db(meta: dict) -> float:
    """The laser-power fluctuation (dB) of the alignment fit: the campaign's
    ``error_model.power_jitter_db`` when ``campaign.json`` states it, else the lab's
    (:data:`~dpdfit.core.defaults.ERROR_MODEL`); a bad value is an InputError naming
    the key."""
    em = meta.get("error_model")
    if not isinstance(em, dict) or "power_jitter_db" not in em:
        return ERROR_MODEL.power_jitter_db
    return ErrorModel.from_dict({"power_jitter_db": em["power_jitter_db"]}).power_jitter_db


@dataclass(frozen=True)
class GateResults:
    """What the gates step hands down: the gate table (fidelities per setting, with the
    gate rates) and the alignment fit (None without gate rates or sweep)."""

    table: pd.DataFrame
    alignment: AlignmentFit | None = None

    def fidelity(self, A: float, dpd: int) -> dict | None:
        """``{"F", "F_err", "F_pop", "F_par"}`` of the setting (``A``, ``dpd``), None when
        it was not measured."""
        t = self.table
        sel = t[np.isclose(t["A"].to_numpy(float), A, rtol=0, atol=5e-7)
                & (t["dpd"].to_numpy(int) == int(dpd))]
        return None if not len(sel) else _fidelities(sel.iloc[-1])


def _fidelities(row) -> dict:
    """The fidelities of one row of the gate table."""
    return {"F": row["F"], "F_err": row["F_err"], "F_pop": row["F_pop"], "F_par": row["F_par"]}


def gates_summary(g: GateResults) -> dict:
    """The ``gates`` section of ``summary.json``: fidelities per setting (keyed
    ``"A=<A>,dpd=<0|1>"``, written for readers, never parsed back), the alignment."""
    rec = {f"A={r['A']:g},dpd={int(r['dpd'])}": _fidelities(r) for _, r in g.table.iterrows()}
    out = {"fidelities": rec}
    if g.alignment is not None:
        out["alignment"] = g.alignment.to_dict()
    return out


def closest_pair(gate):
    """(DPD point, no-DPD point) with the most similar gate rates (Fig. 3 highlight)."""
    if "xi0_khz" not in gate.columns:
        return None
    d1, d0 = gate[gate.dpd == 1], gate[gate.dpd == 0]
    if not len(d1) or not len(d0):
        return None
    best = None
    for _, a in d1.iterrows():
        for _, b in d0.iterrows():
            gap = abs(a["xi0_khz"] - b["xi0_khz"]) / a["xi0_khz"]
            score = gap - 0.01 * (b["A"] - a["A"])       # prefer a large A contrast among ties
            if best is None or score < best[0]:
                best = (score, (float(a["A"]), 1), (float(b["A"]), 0))
    return best[1:]


def _parity_by_setting(par) -> dict:
    """``{(A, dpd): (phases, n_even, shots)}`` of the parity scans merged per setting."""
    merged = merge_parity(par)
    return {(float(A), int(d)): (g["phase_rad"].to_numpy(), g["n_even"].to_numpy(),
                                 g["shots"].to_numpy())
            for (A, d), g in merged.groupby(["A", "dpd"])}


def gates_step(ctx: Context, simulated: SimulatedSweep | None) -> GateResults:
    """Gate fidelities per setting and, with gate rates and the sweep, the alignment fit."""
    sweep = None if simulated is None else simulated.table
    cf, res = ctx.campaign, ctx.results
    if not (cf.has("populations.csv") and cf.has("parity.csv")):
        res.status("gates", "skipped", "populations.csv and parity.csv are both needed")
        return None
    par = cf.parity
    tab = gate_fidelities(cf.populations, par)
    rates = cf.gate_rates
    if rates is not None:
        cols = ["A", "dpd", "xi0_khz"] + (["xi0_err_khz"] if "xi0_err_khz" in rates else [])
        tab = tab.merge(rates[cols], on=["A", "dpd"], how="left")
        tab.attrs["rates_source"] = rates.attrs.get("source")  # named by the fit's errors
    res.table("gate.csv", tab)
    detail = f"{len(tab)} settings"
    fit = None
    if sweep is not None and "xi0_khz" in tab.columns and tab["xi0_khz"].notna().all():
        points = tab.copy(deep=False)  # where sigma_db comes from, for the fit's errors only
        points.attrs["sigma_db_name"] = "campaign.json error_model.power_jitter_db"
        fit = align(points, sweep, power_jitter_db(ctx.meta))
        res.table("alignment_points.csv", fit.points)
        detail += f"; alignment alpha = {fit.alpha_khz:.3f} +/- {fit.alpha_khz_err:.3f} kHz, " \
                  f"delta = {fit.delta:+.4f} +/- {fit.delta_err:.4f}"
        if fit.left_out:
            detail += " (without the gate rates' stated errors, xi0_err_khz)"
    ts = cf.time_scans
    if ctx.figures is not None and sweep is not None and "xi0_khz" in tab.columns:
        ctx.figure(gate_figures, tab, sweep, fit, _parity_by_setting(par), ts,
                   closest_pair(tab), ctx.meta["nbar_assumed"])
    res.status("gates", "ok", detail)
    return GateResults(table=tab, alignment=fit)
