"""The text of a diagnosis, kept apart from its data: the report
(:func:`report_text`, what :meth:`~dpdfit.analyses.diagnosis.result.Diagnosis.report` prints)
and the sentences it is made of."""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.proposal.next_measurement import replicated_clause

__all__ = ["report_text", "next_measurement_sentence", "alternatives_sentence",
           "upper_limits_sentence"]


def report_text(d) -> str:
    """The text report of a diagnosis ``d``
    (:meth:`~dpdfit.analyses.diagnosis.result.Diagnosis.report`)."""
    lines = [f"Diagnosis of {d.campaign}",
             f"  baseline chi2 = {d.baseline.chi2:.1f} for {d.baseline.dof} dof "
             f"(p = {d.baseline_p_value:.2g})",
             f"  verdict: {d.verdict}"
             + (f"   (named: {', '.join(d.named)})" if len(d.named) > 1 else "")]
    lines += [f"  {x}" for x in alternatives_sentence(d.verdict, d.alternatives)]
    lines += [f"  {x}" for x in upper_limits_sentence(getattr(d, "upper_limits", ()))]
    if d.null_range is not None:
        lines.append(f"  the baseline's global chi2 is above its dof, but nothing is "
                     f"located and every observable's reduced chi2 is at most "
                     f"{d.null_range:g} (the harness's null range): nothing missing")
    if d.proposal is not None:
        lines.append("  " + next_measurement_sentence(d.proposal.to_dict()))
    lines += ["", "  mismatches located:"]
    lines += _mismatch_lines(d.mismatches)
    lines += ["", "  ranking of single effects (delta_bic, LRT p):"]
    lines += _ranking_lines(d.ranking)
    for i, step in enumerate(d.steps):
        lines += ["", f"  added to the named effects, step {i + 1} (delta_bic vs them):"]
        lines += _ranking_lines(step[:4])
    if d.effects:
        lines += ["", "  named effects (size in a laboratory's terms, 1 sigma):"]
        for e in d.effects:
            cost = e["fidelity_cost"]
            lines.append(f"    {e['effect']} (form {e['form']}): cost in Bell fidelity "
                         f"{_pm(cost, e['fidelity_cost_err'])}")
            for k, s in e["sizes"].items():
                parts = ("" if "error_statistical" not in s else
                         f"   (statistical {_pm(s['error_statistical'], None)} x "
                         f"sqrt({s['tempering']:.3g}) for the misfit, form "
                         f"{_pm(s['error_form'], None)})")
                lines.append(f"      {k:>24s} = {_pm(s['value'], s['error'])} "
                             f"{s['unit']}{parts}")
    lines += _redchi_lines(d)
    if len(d.effects) > 1:
        lines += ["", "  what each effect explains (chi2 removed per observable group):"]
        lines += _explains_lines(d)
    if d.verdict_fit == "approximate":
        lines += ["", f"  the named effects' forms are approximate: they remove "
                      f"{d.explained_fraction:.1%} of the baseline's excess chi2 but "
                      "leave an unacceptable fit"]
    if d.generic:
        lines += ["", "  generic smooth discrepancy where the model fails:"]
        lines += _generic_lines(d.generic)
    if d.null_model is not None:
        lines += ["", "  null model (learnt from the campaign before any effect):"]
        lines += _null_model_lines(d.null_model.to_dict())
    if d.left_out:
        lines += ["", "  left out (absent from the folder):"]
        lines += [f"    {x}" for x in d.left_out]
    return "\n".join(lines)


def alternatives_sentence(verdict: str, alternatives: list) -> list[str]:
    """The report's words for the alternatives (:class:`Alternative`): one line per kind."""
    if not alternatives:
        return []
    lines = []
    swaps = [a for a in alternatives if a.is_swap]
    adds = [a for a in alternatives if not a.is_swap]
    for rep in dict.fromkeys(a.replaces for a in swaps):
        others = [a.effect for a in swaps if a.replaces == rep]
        lines.append(f"{rep}, or {', or '.join(others)}: these recordings do not "
                     f"separate them")
    if adds:
        lines.append(f"perhaps also {', '.join(a.effect for a in adds)}: these "
                     "recordings favour it, not decisively once the misfit the forms leave "
                     "is counted")
    return lines


def upper_limits_sentence(limits) -> list[str]:
    """The report's line for the upper limits
    (:class:`~dpdfit.analyses.diagnosis.decisions.upper_limits.UpperLimit`), e.g.
    ``"not seen, bounded: stale_calibration [table] |y1 drift| < 0.00031 (95 %)"``; none
    without them."""
    if not limits:
        return []
    return ["not seen, bounded: " + "; ".join(u.text() for u in limits)]


def next_measurement_sentence(nxt: dict) -> str:
    """One sentence: the recording that would decide, or why none could be proposed."""
    if not nxt.get("what"):
        return f"no further measurement could be proposed: {nxt.get('reason', 'unknown')}"
    if nxt.get("decisive") is False and nxt.get("reason"):
        return f"no single recording would decide: {nxt['reason']}"
    st = nxt.get("settings") or {}
    how = ", ".join(f"{k} = {v if not isinstance(v, list) else ', '.join(map(str, v))}"
                    for k, v in st.items())
    mins = nxt.get("lab_seconds")
    when = "" if mins is None else f", about {mins / 60:.0f} min of lab time"
    return (f"the measurement that would decide: {nxt['what'].replace('_', ' ')} ({how}"
            f"{when}), expected delta BIC {nxt.get('expected_delta_bic', float('nan')):.3g}"
            f"{replicated_clause(nxt.get('replicates') or {})} "
            f"between {' and '.join(nxt.get('separates') or [])}")


def _redchi_lines(d) -> list:
    """Reduced chi2 per observable: baseline, then with the first effect and the final fit
    where an effect was named (without one there is no such column to print, not a nan)."""
    cols = [("baseline", d.redchi_before)]
    if d.redchi_one is not None:
        cols.append(("first effect", d.redchi_one))
    if d.redchi_after and (d.redchi_one is not None or d.redchi_after != d.redchi_before):
        cols.append(("final", d.redchi_after))
    head = " -> ".join(name for name, _ in cols) + (
        "" if d.redchi_one is not None else "; no effect named")
    lines = ["", f"  reduced chi2 per observable ({head}):"]
    for k in d.redchi_before:
        vals = [c.get(k) for _, c in cols]
        lines.append(f"    {k:>28s} " + " -> ".join(
            "     n/a" if v is None or not np.isfinite(v) else f"{v:8.2f}" for v in vals))
    return lines


def _pm(v, e) -> str:
    if v is None or not np.isfinite(v):
        return "n/a"
    return f"{v:.4g}" + ("" if e is None or not np.isfinite(e) else f" +/- {e:.2g}")


def _explains_lines(d) -> list:
    """Chi2 each named effect removes, by observable group, in the order it was named."""
    return [f"    {e['effect']:>26s}: " + ", ".join(f"{g} {v:10.1f}"
                                                  for g, v in e["explains"].items())
            for e in d.effects if e.get("explains")]


def _mismatch_lines(mismatches: list) -> list:
    if not mismatches:
        return ["    none"]
    return [f"    {m['observable']:>22s} {m['sideband']:>5s} dpd={m['dpd']!s:>4} "
            f"{m['x']}=[{m['range'][0]:.4g}, {m['range'][1]:.4g}] "
            f"{m['significance_sigma']:.1f} sigma, {m['shape']}" for m in mismatches[:12]]


def _ranking_lines(ranking: list) -> list:
    lines = []
    for r in ranking[:8]:
        par = ", ".join(f"{k}={v:.4g}+/-{r['params_err'].get(k, float('nan')):.2g}"
                        for k, v in r["params"].items()
                        if np.isfinite(r["params_err"].get(k, np.nan)))
        form = f" [{r['variant']}]" if r.get("variant") else ""
        lines.append(f"    {r['effect'] + form:>44s} {r['delta_bic']:10.1f} "
                     f"{r['p_value']:9.2g}  {par}")
    return lines


def _generic_lines(g: dict) -> list:
    frac = g.get("fraction_of_excess")
    lines = [f"    {g['form']}: removes chi2 {g['chi2_removed']:.1f} with {g['dof_used']} "
             f"dof" + ("" if frac is None else f" ({frac:.1%} of the excess chi2)")]
    for r in g["series"][:10]:
        lines.append(f"    {r['observable']:>22s} {r['sideband']:>5s} dpd={r['dpd']!s:>4} "
                     f"{r['x']}=[{r['range'][0]:.4g}, {r['range'][1]:.4g}]: chi2 "
                     f"{r['chi2_before']:.1f} -> {r['chi2_after']:.1f} ({r['n_points']} "
                     f"points, {r['dof_used']} dof)")
    return lines


def _null_model_lines(nm: dict) -> list:
    tn = nm["tone_noise"]
    fl = tn["noise_floor"]
    err = "" if not np.isfinite(fl["floor_err_db"]) else f" +/- {fl['floor_err_db']:.2f}"
    lines = [f"    noise floor {fl['floor_db']:.2f}{err} dB ({fl['method']})",
             f"    tone repeatability {tn['tone_repeatability_db']:.4f} dB, "
             f"trace power jitter {tn['trace_power_jitter_db']:.4f} dB"]
    if nm.get("rate_scatter"):
        rs = nm["rate_scatter"]
        lines.append(f"    gate-rate calibration scatter {rs['rel']:.3%} "
                     f"(stated {rs['stated_rel']:.3%})")
    coh = nm.get("coherence") or {}
    if "T2_recorded_ms" in coh:
        lines.append(f"    coherence time T2 {coh['T2_recorded_ms']:.3g} +/- "
                     f"{coh['T2_recorded_err_ms']:.2g} ms recorded by ramsey.csv (stated "
                     f"{coh['T2_stated_ms']:.3g} ms)")
    if nm.get("phase_sign") is not None:
        lines.append(f"    phase-sign convention {nm['phase_sign']:+d}")
    fitted = nm.get("fitted") or {}
    if fitted:
        lines.append("    fitted: " + ", ".join(f"{k}={v:.4g}" for k, v in fitted.items()))
    for name, r in (nm.get("recorded_motion") or {}).items():    # with thermometry only
        what = {"nbar": "initial mean phonons", "heating_q_per_ms": "heating rate (quanta/ms)"}
        lines.append(f"    recorded {what.get(name, name)} {r['recorded']:.3g} +/- "
                     f"{r['error']:.2g} (stated {r['stated']:.3g})")
    return lines
