"""The written summary of ``dpdfit analyze``: ``summary.md`` and the realism table.

:func:`summary_markdown` renders the summary dict of
:func:`dpdfit.pipeline.analyze.analyze` (the content of ``summary.json``) as
Markdown, one section per analysis that ran; :func:`realism_table` compares
the campaign's headline numbers with the paper's (:data:`PAPER`).
"""

from __future__ import annotations

import math

from dpdfit.core.version import __version__

__all__ = ["PAPER", "realism_table", "summary_markdown", "format_value"]

#: Headline numbers of the paper, for the realism table.
PAPER = {
    "A_corr": 0.5655,
    "R10_gain_dB": "3-5",
    "eta_th_ratio": {"1e-2": 1.5, "1e-3": 2.1, "1e-4": 1.9},
    "F_bell_A0.5": {"dpd": 0.9697, "no_dpd": 0.9542},
    "alpha_khz": 3.42,
    "delta": -0.018,
}
_LEVELS = ("1e-2", "1e-3", "1e-4")
_FLAGS = ("no_dpd", "dpd")


def format_value(v) -> str:
    """A table cell: ``-`` for None, 4 significant digits for a float, else ``str``."""
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


_fmt = format_value


# --------------------------------------------------------------------------- realism


def _threshold_ratio_rows(s: dict) -> list[dict]:
    th = (s.get("spectra") or {}).get("thresholds_measured") or {}
    rows = []
    for key, label in (("eta_th_paper_formula", "paper formula"),
                       ("eta_th", f"{th.get('formula', 'exact')} formula")):
        for lev, pv in PAPER["eta_th_ratio"].items():
            try:
                ratio = th[key]["dpd"][lev] / th[key]["no_dpd"][lev]
            except (KeyError, TypeError, ZeroDivisionError):
                ratio = None
            rows.append({"quantity": f"eta_th ratio DPD/no DPD at {lev} (measured spectra, "
                                     f"{label})", "paper": pv, "dpdfit": ratio})
    return rows


def _gate_rows(gates) -> list[dict]:
    """The Bell fidelities at A = 0.5 and the alignment, from the gates step's result."""
    rows = []
    for key, pv in PAPER["F_bell_A0.5"].items():
        rec = None if gates is None else gates.fidelity(0.5, 1 if key == "dpd" else 0)
        rows.append({"quantity": f"Bell fidelity at A=0.5, {key}", "paper": pv,
                     "dpdfit": None if rec is None else f"{rec['F']:.4f} +/- {rec['F_err']:.4f}"})
    al = None if gates is None else gates.alignment
    rows.append({"quantity": "alpha (kHz)", "paper": PAPER["alpha_khz"],
                 "dpdfit": None if al is None else f"{al.alpha_khz:.3f} +/- {al.alpha_khz_err:.3f}"})
    rows.append({"quantity": "delta", "paper": PAPER["delta"],
                 "dpdfit": None if al is None else f"{al.delta:+.4f} +/- {al.delta_err:.4f}"})
    return rows


def realism_table(summary: dict, gates=None) -> list[dict]:
    """Rows ``{"quantity", "paper", "dpdfit"}``: the paper's numbers next to this campaign's.

    ``summary``: the calibration and spectra sections of ``summary.json``; ``gates``: the
    gates step's typed result (:class:`~dpdfit.pipeline.steps.GateResults`:
    ``fidelity(A, dpd)`` and the ``alignment`` fit), None when the gates were not analysed.
    """
    s = summary
    cal = s.get("calibration") or {}
    rows = [{"quantity": "A_corr = y(1) (mean of runs)", "paper": PAPER["A_corr"],
             "dpdfit": cal.get("A_corr_runs_mean")},
            {"quantity": "sigma of y(1) over runs", "paper": 0.0091,
             "dpdfit": cal.get("A_corr_runs_std")},
            {"quantity": "phi(1) (mean of runs), rad", "paper": 0.2776,
             "dpdfit": cal.get("phi_at_1_runs_mean")},
            {"quantity": "sigma of phi(1) over runs, rad", "paper": 0.0009,
             "dpdfit": cal.get("phi_at_1_runs_std")}]
    g = (s.get("spectra") or {}).get("R10_gain_dB_below_A_corr") or {}
    rows.append({"quantity": "R10 gain with DPD below A_corr (dB, min..max)",
                 "paper": PAPER["R10_gain_dB"],
                 "dpdfit": None if g.get("min") is None else f"{g['min']:.1f}..{g['max']:.1f}"})
    return rows + _threshold_ratio_rows(s) + _gate_rows(gates)


# --------------------------------------------------------------------------- sections


def _calibration(cal: dict) -> list[str]:
    lines = ["", "## Calibration", "",
             f"- predistortion run {cal['lut_run']}: A_corr = {cal['A_corr']:.5f} "
             f"± {cal['A_corr_stderr']:.5f} (monotone: {cal['monotone']})",
             f"- {cal['n_amplitude_runs']} amplitude runs: mean y(1) = "
             f"{_fmt(cal['A_corr_runs_mean'])}, sd {_fmt(cal['A_corr_runs_std'])}"]
    if cal.get("phi_at_1") is not None:
        lines.append(f"- phase: phi(1) = {cal['phi_at_1']:.5f} ± {cal['phi_at_1_stderr']:.5f} rad; "
                     f"{cal['n_phase_runs']} runs, sd {_fmt(cal['phi_at_1_runs_std'])} rad")
    return lines


def _sweep_thresholds(th: dict) -> list[str]:
    lines = ["", "## Simulated sweep: threshold efficiencies", "",
             "| | eta_corr | 1e-2 | 1e-3 | 1e-4 |", "|---|---|---|---|---|"]
    for k in _FLAGS:
        lines.append(f"| {k} | {_fmt(th['eta_corr'][k])} | " + " | ".join(
            _fmt(th["eta_th"][k][lev]) for lev in _LEVELS) + " |")
    return lines


def _measured_thresholds(th: dict) -> list[str]:
    lines = ["", "## Measured spectra: threshold efficiencies", "",
             "| | 1e-2 | 1e-3 | 1e-4 |", "|---|---|---|---|"]
    for k in _FLAGS:
        lines.append(f"| {k} | " + " | ".join(_fmt(th["eta_th"][k][lev]) for lev in _LEVELS)
                     + " |")
    return lines


def _stability(st: dict) -> list[str]:
    lines = ["", "## Calibration stability", "",
             "| kind | runs | span (days) | mean | sd | relative sd | trend per day |",
             "|---|---|---|---|---|---|---|"]
    for kind, d in st.items():
        lines.append(f"| {kind} | {d['n_runs']} | {_fmt(d['span_days'])} | {_fmt(d['mean'])} | "
                     f"{_fmt(d['std'])} | {_fmt(d['relative_std'])} | "
                     f"{_fmt(d['trend_per_day'])} ± {_fmt(d['trend_per_day_err'])} |")
    return lines


def _gates(g: dict) -> list[str]:
    lines = ["", "## Gate fidelities from the counts", "", "| setting | F | ± | F_pop | F_par |",
             "|---|---|---|---|---|"]
    for key, d in g["fidelities"].items():
        lines.append(f"| {key} | {d['F']:.4f} | {d['F_err']:.4f} | {d['F_pop']:.4f} | "
                     f"{d['F_par']:.4f} |")
    al = g.get("alignment")
    if al:
        lines += ["", f"Alignment: alpha = {al['alpha_khz']:.3f} ± {al['alpha_khz_err']:.3f} kHz, "
                      f"delta = {al['delta']:+.4f} ± {al['delta_err']:.4f}, correlation "
                      f"{al['correlation']:+.2f}, reduced chi2 {al['redchi']:.2f}."]
        if al.get("model_adequate") is False:
            lo, hi = al["redchi_range_99"]
            lines += ["", f"**The model F = F_est + delta does not describe the data**: reduced "
                          f"chi2 {al['redchi']:.2f} lies outside its 99 % range [{lo:.2f}, "
                          f"{hi:.2f}] for {al['dof']} dof (chi2 parts: xi0 "
                          f"{al.get('chi2_horizontal', float('nan')):.1f}, F "
                          f"{al.get('chi2_vertical', float('nan')):.1f}).  Birge-scaled errors (x "
                          f"{al['birge_factor']:.2f}): alpha ± {al['alpha_khz_err_birge']:.3f} "
                          f"kHz, delta ± {al['delta_err_birge']:.4f}."]
    return lines


def _propagation(pr: dict) -> list[str]:
    lines = ["", f"## Calibration posterior and drift propagated into F_est (A = {pr['A']:g})",
             "", "| table age | flag | F_est median | 95 % interval | eta_th 1e-3 (median) |",
             "|---|---|---|---|---|"]
    for days, (k, v) in zip(pr["stale_days"], pr["results"].items()):
        for flag in ("dpd", "no_dpd"):
            th = (pr.get("thresholds") or {}).get(k, {}).get(flag, {}).get("1e-3")
            lines.append(f"| {days:g} days | {flag} | {v[flag]['F_est_median']:.6f} | "
                         f"[{v[flag]['F_est_q2.5']:.6f}, {v[flag]['F_est_q97.5']:.6f}] | "
                         f"{_fmt(th)} |")
    lines.append(f"\nChain: tau {_fmt(pr.get('tau'))} steps, {_fmt(pr.get('n_independent'))} "
                 "independent samples.")
    return lines


def _budget(b: dict) -> list[str]:
    lines = ["", "## Error budget (Table S2; loss of (F_pop + F_par)/2)", "",
             "| source | estimate | error |", "|---|---|---|"]
    for k, v in b.items():     # the terms and their order: the budget step's section
        if isinstance(v, dict):
            lines.append(f"| {k} | {v['estimate']:.5f} | {v['error']:.5f} |")
    return lines


def _mismatches(mismatches: list) -> list[str]:
    if not mismatches:
        return ["No interval of significant deviation in any observable."]
    lines = ["| observable | sideband | dpd | range | significance | shape |",
             "|---|---|---|---|---|---|"]
    for m in mismatches:
        lines.append(f"| {m['observable']} | {m['sideband']} | {m['dpd']} | "
                     f"{m['x']} {m['range'][0]:.4g}-{m['range'][1]:.4g} | "
                     f"{m['significance_sigma']:.1f} sigma | {m['shape']} |")
    return lines


def _finite(x) -> bool:
    """A number that is not nan/inf: a parameter the form holds fixed has no error."""
    return isinstance(x, (int, float)) and math.isfinite(x)


def _diagnosis(dg: dict) -> list[str]:
    lines = ["", "## Discrepancy diagnosis (simulation vs recordings)", "",
             f"Verdict: **{dg['verdict']}** (baseline chi2 p-value "
             f"{_fmt(dg['baseline_p_value'])}; `diagnosis.json` has everything).", ""]
    lines += _mismatches(dg["mismatches"])
    lines += ["", "| effect | delta BIC | LRT p | parameters |", "|---|---|---|---|"]
    for r in dg["ranking"]:
        par = ", ".join(f"{k} = {v:.4g} +/- {r['params_err'][k]:.2g}"
                        for k, v in r["params"].items() if _finite(r["params_err"].get(k)))
        lines.append(f"| {r['effect']} | {r['delta_bic']:.1f} | {r['p_value']:.2g} | {par} |")
    lines += ["", "| observable | reduced chi2 before | after |", "|---|---|---|"]
    for k, v in dg["redchi_before"].items():
        lines.append(f"| {k} | {v:.3g} | {dg['redchi_after'].get(k, float('nan')):.3g} |")
    return lines


def _realism(rows: list) -> list[str]:
    lines = ["", "## Realism: paper vs this campaign", "", "| quantity | paper | dpdfit |",
             "|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['quantity']} | {_fmt(r['paper'])} | {_fmt(r['dpdfit'])} |")
    return lines


def summary_markdown(summary: dict, folder, formula: str) -> str:
    """``summary.md``: the status of each analysis, then one section per analysis that ran."""
    s = summary
    lines = [f"# dpdfit analysis of `{folder}`", "",
             f"dpdfit {__version__}; fidelity formula `{formula}`.", "", "## Analyses", ""]
    for name, st in s["analyses"].items():
        lines.append(f"- **{name}**: {st['status']}" + (f" — {st['detail']}" if st["detail"] else ""))
    if s.get("calibration"):
        lines += _calibration(s["calibration"])
    if s.get("sweep"):
        lines += _sweep_thresholds(s["sweep"])
    sp = s.get("spectra")
    if sp and sp.get("thresholds_measured"):
        lines += _measured_thresholds(sp["thresholds_measured"])
    sections = (("stability", _stability), ("gates", _gates), ("propagation", _propagation),
                ("budget", _budget), ("diagnosis", _diagnosis))
    for key, section in sections:
        if s.get(key):
            lines += section(s[key])
    lines += _realism(s.get("realism", []))
    return "\n".join(lines) + "\n"
