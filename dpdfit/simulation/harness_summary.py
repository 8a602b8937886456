"""The harness's summary and report: confusion, false alarms, named correctly, pulls.

:func:`summarise` turns the run records of :func:`dpdfit.simulation.harness.run_one`
into the harness's summary (the keys of earlier harnesses, and the figures per kind of
run of :mod:`dpdfit.simulation.harness_kinds`), :func:`report` into its text and
:func:`write_report` into its JSON file.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from dpdfit.analyses.diagnosis.effects import get
from dpdfit.core.jsonable import to_jsonable
from dpdfit.simulation.closed_loop import loop_report_lines, loop_summary
from dpdfit.simulation.harness_kinds import (by_kind, empty_families, forms_table,
                                             kind_report_lines, label, named_correctly,
                                             run_kind)

__all__ = ["summarise", "write_report", "report"]


def _num(v) -> float:
    """A number from a run record (``None``, JSON's NaN, becomes NaN)."""
    return float("nan") if v is None else float(v)


def _pulls(rs: list, effect: str) -> dict:
    """Pulls ``(fitted - injected) / error`` of ``effect``'s main size over runs ``rs``."""
    m = get(effect).main
    d, pulls = [], []
    for r in rs:
        t = (r.get("truth_sizes") or {}).get(effect, {}).get(m)
        f = (r.get("fit_sizes") or {}).get(effect, {}).get(m)
        if t is None or f is None or f.get("value") is None:
            continue
        v, e = _num(f["value"]), _num(f.get("error"))
        d.append(v - t)
        if np.isfinite(e) and e > 0:
            pulls.append((v - t) / e)
    pulls = np.asarray(pulls)
    return {"quantity": m, "n": len(d), "bias": float(np.mean(d)) if d else None,
            "median_abs_error": float(np.median(np.abs(d))) if d else None,
            "pulls": [float(x) for x in pulls],
            "coverage_1sigma": float(np.mean(np.abs(pulls) <= 1)) if pulls.size else None,
            "coverage_2sigma": float(np.mean(np.abs(pulls) <= 2)) if pulls.size else None}


def summarise(results: list) -> dict:
    """Confusion matrix, false-alarm rate, named correctly (singles, and both effects
    of pairs), recovery of each effect's main size (bias, pulls, their 1-sigma
    coverage, over the runs that named it), fit improvement, ambiguity and the closed
    loop (:func:`~dpdfit.simulation.closed_loop.loop_summary`); failed runs
    (records with ``error``) are counted apart and kept in ``runs``.

    The keys of earlier harnesses describe the catalog-form singles (``singles``:
    ``named_correctly_overall``, ``recovery`` with the pairs) and the pairs; a left-out
    form's runs have rows of their own in ``confusion`` and ``named_correctly``
    (``"<effect> without <form>"``).  Added: ``by_kind`` (overall and per kind of run:
    exact set, confidently wrong, spurious extra, unexplained, false alarms, coverage
    per family), ``forms_left_out`` (per family and left-out form: exact set and the
    form named instead) and ``empty_families`` (families with nothing left to name),
    :mod:`dpdfit.simulation.harness_kinds`."""
    every, results = results, [r for r in results if "error" not in r]
    labels = sorted({label(r) for r in results})
    confusion = {c: {} for c in labels}
    for r in results:
        row = confusion[label(r)]
        key = "+".join(sorted(r.get("named") or [])) if "+" in r["concealed"] else r["verdict"]
        key = key or r["verdict"]
        row[key] = row.get(key, 0) + 1
    nulls = [r for r in results if r["concealed"] == "none"]
    far = (sum(r["verdict"] != "none" for r in nulls) / len(nulls)) if nulls else None
    singles = [r for r in results if run_kind(r) == "catalog"]
    pairs = [r for r in results if run_kind(r) == "pairs"]
    named = {}
    for c in labels:
        if c == "none":
            continue
        rs = [r for r in results if label(r) == c]
        named[c] = sum(named_correctly(r) for r in rs) / len(rs)
    recovery = {}
    for e in sorted({e for r in singles + pairs for e in r.get("effects", {})}):
        # the runs that named the effect (alone or among others)
        rs = [r for r in singles + pairs if e in r.get("effects", {})
              and e in (r.get("named") or [r["verdict"]])]
        main = _pulls(rs, e)
        within = [abs(x) <= 2 for x in main["pulls"]]
        recovery[e] = {"n_named": len(rs), "params": {main["quantity"]: main},
                       "all_params_within_2sigma": float(np.mean(within)) if within
                       else None}
    conc = singles + pairs
    return {"n_runs": len(results), "n_failed": len(every) - len(results),
            "confusion": confusion, "false_alarm_rate": far,
            "named_correctly": named,
            "named_correctly_overall": (sum(named_correctly(r) for r in singles)
                                        / len(singles)) if singles else None,
            "pairs_both_named": (sum(named_correctly(r) for r in pairs) / len(pairs))
            if pairs else None,
            "pairs_one_named": (sum(len(set(r.get("named") or []) & set(r["effects"])) >= 1
                                    for r in pairs) / len(pairs)) if pairs else None,
            "recovery": recovery, **loop_summary(results),
            "by_kind": by_kind(results), "forms_left_out": forms_table(results),
            "empty_families": empty_families(results),
            "median_redchi_before": float(np.median([r["redchi_before"] for r in conc]))
            if conc else None,
            "median_redchi_after": float(np.median([r["redchi_after"] for r in conc]))
            if conc else None,
            "median_seconds_diagnosis": float(np.median([r["seconds_diagnosis"]
                                                         for r in results]))
            if results else None,
            "max_seconds_diagnosis": float(np.max([r["seconds_diagnosis"] for r in results]))
            if results else None,
            "median_seconds_per_run": float(np.median([r["seconds_simulation"]
                                                       + r["seconds_diagnosis"]
                                                       for r in results])) if results else None,
            "runs": every}


def write_report(summary: dict, path) -> None:
    """Write the harness summary as JSON (atomically)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(to_jsonable(summary), indent=1, sort_keys=True) + "\n")
    os.replace(tmp, path)


def report(s: dict) -> str:
    """Readable harness summary."""
    def num(v):
        return "n/a" if v is None else f"{v:.3g}"

    lines = [f"Injection-recovery harness: {s['n_runs']} campaigns in {s['seconds']:.0f} s",
             f"  named correctly (single effects): {num(s['named_correctly_overall'])}",
             f"  pairs, both named: {num(s.get('pairs_both_named'))}, at least one: "
             f"{num(s.get('pairs_one_named'))}",
             f"  false-alarm rate (nulls): {num(s['false_alarm_rate'])}",
             *loop_report_lines(s),
             f"  diagnosis seconds: median {num(s.get('median_seconds_diagnosis'))}, max "
             f"{num(s.get('max_seconds_diagnosis'))}",
             f"  median reduced chi2 before -> after: {num(s['median_redchi_before'])} -> "
             f"{num(s['median_redchi_after'])}", "", "  confusion (concealed -> named):"]
    for r in (r for r in s["runs"] if "error" in r):
        lines.insert(1, f"  FAILED: {r['concealed']} seed {r['seed']}: {r['error']}")
    for c, row in s["confusion"].items():
        lines.append(f"    {c:>40s}: " + ", ".join(f"{k} {v}" for k, v in sorted(row.items())))
    lines += ["", "  recovery of each effect's main size (runs that named it):"]
    for c, r in s["recovery"].items():
        for q, m in r["params"].items():
            lines.append(f"    {c:>26s} {q:>20s}: n={m['n']} bias={num(m['bias'])} "
                         f"cov1={num(m['coverage_1sigma'])} cov2={num(m['coverage_2sigma'])}")
    lines += kind_report_lines(s)
    return "\n".join(lines)
