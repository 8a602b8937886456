#!/usr/bin/env python
"""Regenerate the bundled synthetic campaign and its realism report.

    python scripts/make_campaign.py

1. ``dpdfit simulate-campaign datasets/synthetic_campaign --seed 20260329``
   (the folder is replaced; the test suite checks that the simulator
   reproduces it bit for bit);
2. ``dpdfit analyze`` on it (into a temporary folder);
3. ``datasets/synthetic_campaign/REALISM.md``: the paper's headline numbers
   beside dpdfit's analysis of the campaign, plus the simulator's own truth
   for quantities dpdfit cannot analyse yet (read from truth.json here, in a
   report script; no analysis code reads truth.json).
"""

import json
import shutil
import sys
import tempfile
from pathlib import Path

from dpdfit.analyze import analyze
from dpdfit.campaign import simulate_campaign

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "datasets" / "synthetic_campaign"
SEED = 20260329


def fmt(v):
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def main():
    if OUT.exists():
        shutil.rmtree(OUT)
    simulate_campaign(OUT, seed=SEED)
    with tempfile.TemporaryDirectory() as tmp:
        summary = analyze(OUT, Path(tmp) / "results", plots=False)
    truth = json.loads((OUT / "truth.json").read_text())
    lines = ["# Realism of the bundled synthetic campaign", "",
             "Produced by `scripts/make_campaign.py`: the paper's headline numbers beside "
             "`dpdfit analyze` on this campaign.", "",
             "| quantity | paper | dpdfit on this campaign |", "|---|---|---|"]
    for r in summary["realism"]:
        lines.append(f"| {r['quantity']} | {fmt(r['paper'])} | {fmt(r['dpdfit'])} |")
    g = truth.get("gates") or {}
    if g:
        lines += ["", "## Simulator truth of the gate experiments", "",
                  "Exact Bell-state fidelity of the simulated two-ion state (mean over the scans, "
                  "with SPAM, dephasing, heating and laser-power fluctuation), and the true and "
                  "calibrated gate rates:", "",
                  "| A | dpd | xi0 true (kHz) | xi0 calibrated (kHz) | Bell fidelity |",
                  "|---|---|---|---|---|"]
        for s in g["settings"]:
            lines.append(f"| {s['A']} | {s['dpd']} | {s['xi0_true_hz'] / 1e3:.3f} | "
                         f"{s['xi0_cal_hz'] / 1e3:.3f} | {s['bell_fidelity_mean_over_scans']:.4f} |")
    (OUT / "REALISM.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT}", file=sys.stderr)


if __name__ == "__main__":
    main()
