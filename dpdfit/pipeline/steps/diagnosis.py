"""Step ``diagnosis`` of ``dpdfit analyze``: the discrepancy diagnosis (issue #7).

Locates where the simulation and the recordings disagree and names the
missing physics (:mod:`dpdfit.analyses.diagnosis`).  -> ``diagnosis.json``.
"""

from __future__ import annotations

from ..context import Context

__all__ = ["diagnosis_step"]


def diagnosis_step(ctx: Context, fits=None):
    """Discrepancy diagnosis (issue #7): verdict, mismatches, ranking -> diagnosis.json.

    ``fits``: the calibration step's :class:`CalibrationFits`; its amplitude run
    fits are handed to the diagnosis when made at the campaign's order (each run
    is fitted once per ``analyze``)."""
    res, folder = ctx.results, ctx.folder
    if not (folder / "spectra.csv").exists():
        res.status("diagnosis", "skipped", "spectra.csv not found")
        return None
    from dpdfit.analyses.diagnosis.diagnose import diagnose
    from dpdfit.report.diagnosis_plots import DIAGNOSIS_DPI, diagnosis_figures
    order = int(ctx.meta["order"])
    d = diagnose(folder, run_fits=None if fits is None else fits.amplitude_fits(order))
    dd = d.to_dict()
    res.json_file("diagnosis.json", dd)
    res.summary["diagnosis"] = {k: dd[k] for k in ("verdict", "redchi_before", "redchi_after",
                                                   "baseline_p_value", "chosen")}
    res.summary["diagnosis"]["mismatches"] = dd["mismatches"][:10]
    res.summary["diagnosis"]["ranking"] = dd["ranking"][:5]
    ctx.figure(diagnosis_figures, d, dpi=DIAGNOSIS_DPI)
    res.status("diagnosis", "ok", f"verdict: {d.verdict}")
    return d
