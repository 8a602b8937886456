#!/usr/bin/env python
"""Simulate the bundled campaign with a concealed effect (for the diagnosis walkthrough).

    python scripts/make_concealed_campaign.py

Writes ``datasets/concealed_campaign/`` (the recordings, as a lab would have
them: no truth inside) and ``datasets/concealed_campaign_truth.json`` (what
was concealed and the simulator's truth; the diagnosis never reads it).  The
concealed effect is a property of the modulator that a memoryless forward
model leaves out; which one is only in the truth file.
"""

import json
import shutil
from pathlib import Path

from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "datasets" / "concealed_campaign"
TRUTH = ROOT / "datasets" / "concealed_campaign_truth.json"
SEED = 20261122
EFFECTS = {"aom_memory": 60.0, "aom_memory.f_off": 2.0}     # tau in ns, f_off in MHz


def main():
    if OUT.exists():
        shutil.rmtree(OUT)
    cfg = CampaignConfig(seed=SEED, bundled_traces=())
    truth = simulate_campaign(OUT, seed=SEED, effects=EFFECTS, config=cfg)
    (OUT / "truth.json").unlink()
    TRUTH.write_text(json.dumps({"concealed": {"aom_memory": {"tau_ns": EFFECTS["aom_memory"],
                                                              "f_off_MHz": EFFECTS[
                                                                  "aom_memory.f_off"]}},
                                 "simulator_truth": truth}, indent=2, sort_keys=True,
                                default=float) + "\n")
    # the campaign README must not give the effect away
    readme = OUT / "README.md"
    text = readme.read_text()
    readme.write_text(text.replace(
        ", ".join(f"{k}={v:g}" for k, v in EFFECTS.items()), "concealed (see ../concealed_campaign_truth.json)"))
    print(f"wrote {OUT} and {TRUTH}")


if __name__ == "__main__":
    main()
