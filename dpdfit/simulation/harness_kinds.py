"""The harness's figures by kind of run: catalog forms, left-out forms, pairs, triples, nulls.

A harness run (:func:`dpdfit.simulation.harness.run_one`) is one of

* ``catalog``: one effect concealed as the catalog harness draws it
  (:attr:`~dpdfit.simulation.injections.Injection.harness`);
* ``leave_one_form_out``: one effect concealed in one of its forms, diagnosed with
  that form left out of the catalog (``forms_left_out``): how the diagnosis does when
  a lab's physics takes a form the catalog does not have;
* ``pairs``, ``triples``: two or three distinct effects concealed at once;
* ``pairs_left_out``, ``triples_left_out``: the same, each effect in one of its forms
  left out of the catalog;
* ``nulls``: nothing concealed.

For each kind, and overall, :func:`by_kind` gives the fraction named as the exact
concealed set, confidently wrong (the named set wrong and the truth's set neither
named nor among the ``alternatives``, :func:`~dpdfit.simulation.harness_external.truth_in_reach`),
with a spurious extra effect (every concealed effect named, and more,
:func:`~dpdfit.simulation.harness_external.spurious_extra`) or ``unexplained``; the
false-alarm rate of the nulls; and per family the 1- and 2-sigma coverage of the
main size's pulls (:func:`coverage`).

A family with a single form has nothing left when that form is left out: such runs
cannot be named correctly, so they are kept out of the rates above and counted apart
(:func:`empty_families`): ``unexplained`` (the honest answer), ``none`` (missed) or
another effect named (confidently wrong, since the truth cannot be in reach).
"""

from __future__ import annotations

import numpy as np

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.simulation import injections
from dpdfit.simulation.harness_external import spurious_extra, truth_in_reach

__all__ = ["KINDS", "run_kind", "label", "named_correctly", "is_empty_family", "outcome",
           "coverage",
           "kind_summary", "by_kind", "empty_families", "forms_table", "kind_report_lines"]

#: the kinds of run, in the order the report gives them
KINDS = ("catalog", "leave_one_form_out", "pairs", "triples", "pairs_left_out",
         "triples_left_out", "nulls")


def run_kind(r: dict) -> str:
    """The kind of a run record or job (module doc)."""
    n = len(r.get("effects") or {})
    if n == 0:
        return "nulls"
    if r.get("forms_left_out"):
        return {1: "leave_one_form_out", 2: "pairs_left_out"}.get(n, "triples_left_out")
    return {1: "catalog", 2: "pairs"}.get(n, "triples")


def label(r: dict) -> str:
    """The confusion matrix's row of a run: ``concealed``, and for a left-out form
    ``"<effect> without <form>"``."""
    left = r.get("forms_left_out") or {}
    if not left:
        return r["concealed"]
    return r["concealed"] + " without " + ",".join(f for forms in left.values() for f in forms)


def named_correctly(r: dict) -> bool:
    """A run record's ``named_correctly`` (older records: the verdict is the concealed)."""
    if "named_correctly" in r:
        return bool(r["named_correctly"])
    return r["verdict"] == r["concealed"]


def is_empty_family(r: dict) -> bool:
    """A left-out-form run whose concealed family has no form left to fit (recorded by
    :func:`~dpdfit.simulation.harness.run_one` as ``family_left_empty``; older records:
    the family has a single form)."""
    if "family_left_empty" in r:
        return bool(r["family_left_empty"])
    left = r.get("forms_left_out") or {}
    return any(len(EFFECTS[e].forms_for()) <= len(forms) for e, forms in left.items()
               if e in EFFECTS)


def outcome(r: dict) -> dict:
    """``exact_set``, ``confidently_wrong``, ``spurious_extra``, ``unexplained`` of one
    run record (what :func:`~dpdfit.simulation.harness.run_one` records)."""
    truth = sorted(r.get("effects") or {})
    named = sorted(r.get("named") or [])
    exact = named == truth if truth else r.get("verdict") == "none"
    return {"exact_set": exact,
            "confidently_wrong": not exact and not truth_in_reach(r, truth),
            "spurious_extra": spurious_extra(r, truth),
            "unexplained": r.get("verdict") == "unexplained"}


def _flag(r: dict, key: str) -> bool:
    return bool(r[key]) if key in r else outcome(r)[key]


def _num(v) -> float:
    return float("nan") if v is None else float(v)


def coverage(rs: list) -> dict:
    """Per family: the pulls ``(fitted - injected) / error`` of the main size of the form
    it was injected in (:meth:`~dpdfit.simulation.injections.Injection.main_size`) over
    the runs ``rs`` that named it, with their 1- and 2-sigma coverage; ``quantity`` lists
    the sizes compared (forms of one family may have different main sizes; a pull is in
    units of its error either way).  A run whose fit does not report that size (another
    form) gives no pull."""
    acc: dict = {}
    for r in rs:
        named = set(r.get("named") or [r.get("verdict")])
        forms = r.get("injected_form") or {}
        for e in r.get("effects") or {}:
            if e not in named or e not in EFFECTS:
                continue
            q = injections.get(e).main_size(forms.get(e))
            t = ((r.get("truth_sizes") or {}).get(e) or {}).get(q)
            f = ((r.get("fit_sizes") or {}).get(e) or {}).get(q)
            a = acc.setdefault(e, {"quantities": set(), "n_named": 0, "pulls": []})
            a["n_named"] += 1
            a["quantities"].add(q)
            if t is None or f is None or f.get("value") is None:
                continue
            err = _num(f.get("error"))
            if np.isfinite(err) and err > 0:
                a["pulls"].append((_num(f["value"]) - float(t)) / err)
    out = {}
    for e, a in sorted(acc.items()):
        p = np.asarray(a["pulls"], dtype=float)
        out[e] = {"quantity": ", ".join(sorted(a["quantities"])), "n_named": a["n_named"],
                  "n": int(p.size),
                  "coverage_1sigma": float(np.mean(np.abs(p) <= 1)) if p.size else None,
                  "coverage_2sigma": float(np.mean(np.abs(p) <= 2)) if p.size else None,
                  "pulls": [float(x) for x in p]}
    return out


def kind_summary(rs: list) -> dict:
    """Counts and rates of runs ``rs`` of one kind (or all): ``n``; over the runs with
    something concealed ``n_concealed``, ``exact_set``, ``confidently_wrong``,
    ``spurious_extra``, ``unexplained`` (fractions, None without such runs); over the
    nulls ``n_nulls`` and ``false_alarm`` (any verdict but ``none``); ``coverage``."""
    conc = [r for r in rs if r.get("effects")]
    nulls = [r for r in rs if not r.get("effects")]

    def rate(key):
        return (sum(_flag(r, key) for r in conc) / len(conc)) if conc else None

    return {"n": len(rs), "n_concealed": len(conc),
            "exact_set": rate("exact_set"), "confidently_wrong": rate("confidently_wrong"),
            "spurious_extra": rate("spurious_extra"), "unexplained": rate("unexplained"),
            "n_nulls": len(nulls),
            "false_alarm": (sum(r.get("verdict") != "none" for r in nulls) / len(nulls))
            if nulls else None,
            "coverage": coverage(conc)}


def by_kind(results: list) -> dict:
    """:func:`kind_summary` overall and per kind present (runs of a family left without
    forms are left out of both: :func:`empty_families`)."""
    kept = [r for r in results if not is_empty_family(r)]
    out = {"overall": kind_summary(kept)}
    for k in KINDS:
        rs = [r for r in kept if run_kind(r) == k]
        if rs:
            out[k] = kind_summary(rs)
    return out


def empty_families(results: list) -> dict:
    """Per family with no form left when its form is left out: ``n``, ``unexplained``,
    ``none``, ``named_other`` (another effect named: confidently wrong) and
    ``named_other_effects`` (what was named, counts)."""
    out: dict = {}
    for r in results:
        if run_kind(r) != "leave_one_form_out" or not is_empty_family(r):
            continue
        for e in r.get("effects") or {}:
            row = out.setdefault(e, {"n": 0, "unexplained": 0, "none": 0, "named_other": 0,
                                     "named_other_effects": {}})
            row["n"] += 1
            v = r.get("verdict")
            if v in ("unexplained", "none"):
                row[v] += 1
            else:
                row["named_other"] += 1
                key = "+".join(sorted(r.get("named") or [v]))
                row["named_other_effects"][key] = row["named_other_effects"].get(key, 0) + 1
    return out


def forms_table(results: list) -> dict:
    """Left-out-form runs per family and left-out form: ``n``, ``exact_set`` and
    ``confidently_wrong`` (counts) and ``named_forms`` (the form the family was named in
    instead, counts; ``-`` when it was not named)."""
    out: dict = {}
    for r in results:
        if run_kind(r) != "leave_one_form_out" or is_empty_family(r):
            continue
        for e, forms in (r.get("forms_left_out") or {}).items():
            row = out.setdefault(e, {}).setdefault(",".join(forms), {
                "n": 0, "exact_set": 0, "confidently_wrong": 0, "named_forms": {}})
            row["n"] += 1
            row["exact_set"] += _flag(r, "exact_set")
            row["confidently_wrong"] += _flag(r, "confidently_wrong")
            f = (r.get("named_forms") or {}).get(e, "-")
            row["named_forms"][f] = row["named_forms"].get(f, 0) + 1
    return out


def kind_report_lines(s: dict) -> list:
    """The report's lines on the kinds (empty for a summary without ``by_kind``)."""
    kinds = s.get("by_kind")
    if not kinds:
        return []

    def share(frac, n):
        return "n/a" if frac is None or not n else f"{round(frac * n)}/{n}"

    lines = ["", "  by kind (exact set; confidently wrong; spurious extra; unexplained; "
                 "false alarms):"]
    for k in ("overall",) + KINDS:
        if k not in kinds:
            continue
        m = kinds[k]
        n = m["n_concealed"]
        parts = []
        if n:
            parts.append(f"exact set {share(m['exact_set'], n)}, confidently wrong "
                         f"{share(m['confidently_wrong'], n)}, spurious extra "
                         f"{share(m['spurious_extra'], n)}, unexplained "
                         f"{share(m['unexplained'], n)}")
        if m["n_nulls"]:
            parts.append(f"false alarms {share(m['false_alarm'], m['n_nulls'])}")
        lines.append(f"    {k:>20s}: " + "; ".join(parts))
        for e, c in m["coverage"].items():
            cov1 = "n/a" if c["coverage_1sigma"] is None else f"{100 * c['coverage_1sigma']:.0f} %"
            cov2 = "n/a" if c["coverage_2sigma"] is None else f"{100 * c['coverage_2sigma']:.0f} %"
            lines.append(f"    {'':>20s}  {e:>26s}: named {c['n_named']}, pulls {c['n']} "
                         f"({c['quantity']}), 1 sigma {cov1}, 2 sigma {cov2}")
    table = s.get("forms_left_out") or {}
    if table:
        lines += ["", "  left-out forms (exact set / runs; named instead in form):"]
        for e, rows in table.items():
            for f, row in rows.items():
                named = ", ".join(f"{k} {v}" for k, v in sorted(row["named_forms"].items()))
                what = f"{e} without {f}"
                lines.append(f"    {what:>46s}: {row['exact_set']}/{row['n']}, "
                             f"confidently wrong {row['confidently_wrong']}; {named}")
    empty = s.get("empty_families") or {}
    if empty:
        lines += ["", "  families with nothing left when their form is left out:"]
        for e, row in empty.items():
            other = ", ".join(f"{k} {v}" for k, v in sorted(row["named_other_effects"].items()))
            lines.append(f"    {e:>26s}: n={row['n']}, unexplained {row['unexplained']}, "
                         f"none {row['none']}, another effect named (confidently wrong) "
                         f"{row['named_other']}" + (f" ({other})" if other else ""))
    return lines
