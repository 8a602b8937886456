"""Sizes fitted on the independent simulator's campaigns against its truth.

Reads the reports of ``dpdfit harness --campaigns ... -o REPORT.json`` and the truth
files beside the campaign folders, and compares each named effect's size with the
truth wherever the independent simulator defines the same quantity (the table
``SAME_QUANTITY`` below says which, and how its terms map to dpdfit's; quantities
defined differently -- the AM-to-PM phase, the memory kernel, the common-mode
dephasing time -- are left out, see docs/diagnosis/evidence.md; so is a quantity the
named form holds fixed, e.g. the exponent of the linear detector form).  Prints each
comparison with its pull ``(fitted - truth) / error`` and the fraction of |pull|
<= 1 and <= 2.

    python benchmarks/validation_sizes.py benchmarks/validation_report.json \
        ../shared/validation_truth.json [PAIRS_REPORT.json PAIRS_TRUTH.json] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from record import add_json_option, summary_line, write_record  # noqa: E402

#: effect -> [(dpdfit size, how the truth's strength gives it)]
SAME_QUANTITY = {
    "gate_rate_miscalibration": [("rate_error", lambda s: s["eps"])],
    # the simulator reads P (1 - kappa u^p); dpdfit P (1 + k u^q)
    "detector_nonlinearity": [("k_det", lambda s: -s["kappa"]), ("q", lambda s: s["p"])],
    "spam_offset": [("spectator", lambda s: s["p_spectator"]),
                    ("flip", lambda s: s["p_flip"])],
    "motional_heating": [("heating_q_per_ms", lambda s: s["heating_q_per_ms"]),
                         ("mean_nbar", lambda s: s["mean_nbar"])],
    "stale_calibration": [("y1_drift", lambda s: s["step_y1"])],
}


def comparisons(report: dict, truth: dict) -> list:
    """One row per (campaign, effect, size) that both define the same way."""
    rows = []
    for r in report["runs"]:
        t = truth.get(r["campaign"], {})
        strengths = t.get("strengths") or {t.get("effect"): t.get("strength", {})}
        for effect, sizes in (r.get("sizes") or {}).items():
            if effect not in strengths or effect not in SAME_QUANTITY:
                continue
            for name, of in SAME_QUANTITY[effect]:
                if name not in sizes:
                    continue
                try:
                    want = float(of(strengths[effect]))
                except (KeyError, TypeError):
                    continue
                s = sizes[name]
                stat = s.get("error_statistical", s.get("error"))
                if not stat or not np.isfinite(stat):
                    continue              # held fixed by the named form: not a fitted size
                err = s.get("error")
                pull = ((s["value"] - want) / err) if err and np.isfinite(err) else None
                rows.append({"campaign": r["campaign"], "effect": effect, "size": name,
                             "fitted": s["value"], "error": err,
                             "error_statistical": s.get("error_statistical"),
                             "truth": want, "pull": pull})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", help="REPORT.json TRUTH.json [REPORT TRUTH ...]")
    add_json_option(ap)
    a = ap.parse_args(argv)
    if len(a.pairs) % 2:
        ap.error("give reports and truth files in pairs")
    rows = []
    for rep, tru in zip(a.pairs[::2], a.pairs[1::2]):
        rows += comparisons(json.loads(Path(rep).read_text()),
                            json.loads(Path(tru).read_text()))
    pulls = np.array([r["pull"] for r in rows if r["pull"] is not None])
    naive = np.array([(r["fitted"] - r["truth"]) / r["error_statistical"] for r in rows
                      if r.get("error_statistical")])
    for r in rows:
        p = "n/a" if r["pull"] is None else f"{r['pull']:+.2f}"
        print(f"{r['campaign']:>4s} {r['effect']:>26s} {r['size']:>18s} "
              f"{r['fitted']:+.4g} +/- {r['error']:.2g} (statistical "
              f"{r['error_statistical'] or float('nan'):.2g})  truth {r['truth']:+.4g}  "
              f"pull {p}")
    summary = {"n": int(pulls.size),
               "within_1sigma": float(np.mean(np.abs(pulls) <= 1)) if pulls.size else None,
               "within_2sigma": float(np.mean(np.abs(pulls) <= 2)) if pulls.size else None,
               "statistical_only_within_1sigma": (float(np.mean(np.abs(naive) <= 1))
                                                  if naive.size else None),
               "statistical_only_within_2sigma": (float(np.mean(np.abs(naive) <= 2))
                                                  if naive.size else None)}
    def pct(v):
        return "n/a" if v is None else f"{v:.0%}"

    print(f"{summary['n']} sizes: |pull| <= 1 in {pct(summary['within_1sigma'])}, <= 2 in "
          f"{pct(summary['within_2sigma'])} (statistical errors alone: "
          f"{pct(summary['statistical_only_within_1sigma'])}, "
          f"{pct(summary['statistical_only_within_2sigma'])})")
    write_record(a.json, "validation_sizes", rows + [{"table": "summary", **summary}],
                 description=summary_line(__doc__),
                 notes=[f"{k}: {v}" for k, v in summary.items()])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
