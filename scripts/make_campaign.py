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

from dpdfit.report.summary import format_value as fmt
from dpdfit.pipeline.analyze import analyze
from dpdfit.simulation.campaign import simulate_campaign

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "datasets" / "synthetic_campaign"
SEED = 20260329


NOTES = """## Where the physics does not reach the paper's numbers

* **Bell fidelity at A = 0.5 (paper: 0.970 with DPD, 0.954 without).** With the
  error budget the paper states (state preparation 0.3 % per ion, T2 = 50 ms,
  heating < 0.01 quanta/ms, nbar = 0.1, detection < 1e-4, 0.2 dB power
  fluctuation) and the intermodulation this AOM produces, the exact dynamics
  give about 0.99 for both flags (see the table above): the DPD advantage at
  A = 0.5 is ~0.2 percentage points, not 1.6. The paper's own budget leaves
  0.6-0.9 % unexplained (Supplement S8); we do not inject an unexplained error
  into the nominal campaign. `dpdfit simulate-campaign --effects` can add
  named effects (dephasing, SPAM, heating, memory, ...) on purpose.
* **Threshold-efficiency ratios.** With the printed fidelity formula (as the
  paper used) the measured-spectra ratios are close to the paper's; with the
  validated exact formula (dpdfit's default) they differ, because the exact
  expression halves every infidelity and so moves each crossing.
* **The spread of phi(1)** over 6 runs is a single draw of a drift process with
  sigma 0.0009 rad; six samples scatter widely around it.
* **alpha ~ 3.4 kHz** is built in: the Rabi-frequency scale is chosen so the
  anchor (A = 0.4, no DPD) calibrates to xi0 = 3.42 kHz; the alignment fit
  recovers it from the counts and gate rates.
* **delta (paper: -0.018).** The fit gives about -0.002. Two reasons, both
  physics rather than tuning: the campaign carries only the stated error
  budget (no unexplained ~1 %), and the spectrum-based estimate F_PD assigns
  the IM tones the cubic-model phases, whereas the AOM's amplitude-to-phase
  conversion gives them other phases; against the exact dynamics F_PD
  overestimates the IM infidelity (by about 2x at A = 0.6), which offsets
  part of the SPAM and dephasing loss in delta.
"""


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
                  "Per setting, mean over its scans: the exact Bell-state fidelity of the "
                  "simulated two-ion state after the gate (best Bell phase; dephasing, heating, "
                  "IM tones, AM-to-PM and the scan's laser-power error included; ideal state "
                  "preparation and detection), and the fidelity the ideal measurement would "
                  "report, (F_pop + F_par)/2 from the exact outcome probabilities including "
                  "preparation and detection errors; true and calibrated gate rates.", "",
                  "| A | dpd | xi0 true (kHz) | xi0 calibrated (kHz) | Bell fidelity of the state "
                  "| (F_pop + F_par)/2, exact probabilities |",
                  "|---|---|---|---|---|---|"]
        for s in g["settings"]:
            lines.append(f"| {s['A']} | {s['dpd']} | {s['xi0_true_hz'] / 1e3:.3f} | "
                         f"{s['xi0_cal_hz'] / 1e3:.3f} | {s['bell_fidelity_mean_over_scans']:.4f} "
                         f"| {s['apparent_fidelity_mean_over_scans']:.4f} |")
    lines += ["", NOTES]
    (OUT / "REALISM.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT}", file=sys.stderr)


if __name__ == "__main__":
    main()
