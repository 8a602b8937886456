"""Step ``diagnosis`` of ``dpdfit analyze``: the discrepancy diagnosis (issue #7).

Locates where the simulation and the recordings disagree and names the
missing physics (:mod:`dpdfit.analyses.diagnosis`).  -> ``diagnosis.json``.
"""

from __future__ import annotations

from ..context import Context

__all__ = ["diagnosis_step"]


def diagnosis_step(ctx: Context):
    """Discrepancy diagnosis (issue #7): verdict, mismatches, ranking -> diagnosis.json."""
    res, folder = ctx.results, ctx.folder
    if not (folder / "spectra.csv").exists():
        res.status("diagnosis", "skipped", "spectra.csv not found")
        return None
    from dpdfit.analyses.diagnosis.diagnose import diagnose
    from dpdfit.report.diagnosis_plots import plot_diagnosis
    d = diagnose(folder)
    dd = d.to_dict()
    res.json_file("diagnosis.json", dd)
    res.summary["diagnosis"] = {k: dd[k] for k in ("verdict", "redchi_before", "redchi_after",
                                                   "baseline_p_value", "chosen")}
    res.summary["diagnosis"]["mismatches"] = dd["mismatches"][:10]
    res.summary["diagnosis"]["ranking"] = dd["ranking"][:5]
    ctx.figure(plot_diagnosis, d, folder, ctx.figdir)
    res.status("diagnosis", "ok", f"verdict: {d.verdict}")
    return d
