"""Step ``diagnosis`` of ``dpdfit analyze``: the discrepancy diagnosis.

Locates where the simulation and the recordings disagree and names the
missing physics (:mod:`dpdfit.analyses.diagnosis`).  -> ``diagnosis.json``.
"""

from __future__ import annotations

from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.report.diagnosis_plots import DIAGNOSIS_DPI, diagnosis_figures

from ..context import Context

__all__ = ["diagnosis_step", "diagnosis_summary"]


def diagnosis_step(ctx: Context, fits=None):
    """Discrepancy diagnosis: verdict, mismatches, ranking -> diagnosis.json.

    The diagnosis reads the campaign folder already read (each file is opened once
    per ``analyze``) and gets the calibration step's fits (``fits``, a
    :class:`CalibrationFits`): its amplitude run fits when made at the campaign's
    order and the noise models it learnt from the runs, so that each run is fitted
    once."""
    res = ctx.results
    if not ctx.campaign.has("spectra.csv"):
        res.status("diagnosis", "skipped", "spectra.csv not found")
        return None
    order = int(ctx.meta["order"])
    d = diagnose(ctx.campaign, run_fits=None if fits is None else fits.amplitude_fits(order),
                 calibration=None if fits is None else fits.calibration,
                 noise=None if fits is None else (fits.noise, fits.phase_noise))
    res.json_file("diagnosis.json", d.to_dict())
    ctx.figure(diagnosis_figures, d, dpi=DIAGNOSIS_DPI)
    res.status("diagnosis", "ok", f"verdict: {d.verdict}")
    return d


def diagnosis_summary(d) -> dict:
    """The ``diagnosis`` section of ``summary.json``: verdict, fit before/after, the first
    mismatches and effects."""
    dd = d.to_dict()
    out = {k: dd[k] for k in ("verdict", "redchi_before", "redchi_after", "baseline_p_value",
                               "chosen")}
    out["mismatches"] = dd["mismatches"][:10]
    out["ranking"] = dd["ranking"][:5]
    return out
