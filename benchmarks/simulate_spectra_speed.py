"""Speed of a harness campaign's spectra: the flat-top window's bandwidth computed once, not per tone readout.

    python benchmarks/simulate_spectra_speed.py [--repeats 7] [--json PATH]

Simulates the harness's reduced campaign (``harness_config``, tone powers taken
directly from the field: 39 amplitudes x 2 flags) without its gates -- the calibration
runs and the spectra -- REPEATS times with the flat-top window's equivalent noise
bandwidth computed once per process (as the simulator does), and REPEATS times with it
computed again at every tone readout (as it did before), alternating, and prints the
median CPU time of each and their ratio.  Both write the same files (checked).  The
gates (the engine, most of a whole campaign's time) are left out: they are unchanged,
and their time would only dilute the ratio.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import dpdfit.simulation.campaign.spectra as spectra
from dpdfit.simulation.campaign import campaign_hashes, simulate_campaign
from dpdfit.simulation.harness import harness_config
from record import add_json_option, summary_line, write_record

SEED = 4242


def _simulate(folder: Path) -> float:
    """CPU seconds of one simulation of the campaign (no gates) into ``folder``."""
    c = time.process_time()
    simulate_campaign(folder, seed=SEED, config=harness_config(SEED), progress=False,
                      include_gates=False)
    return time.process_time() - c


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeats", type=int, default=7)
    add_json_option(p)
    args = p.parse_args(argv)
    cached = spectra._flattop_enbw
    times = {"once": [], "per readout": []}
    with tempfile.TemporaryDirectory() as tmp:
        _simulate(Path(tmp) / "warm-up")                 # imports and caches out of the timing
        for i in range(args.repeats):
            for arm in times:
                spectra._flattop_enbw = cached if arm == "once" else cached.__wrapped__
                try:
                    times[arm].append(_simulate(Path(tmp) / f"{arm}{i}"))
                finally:
                    spectra._flattop_enbw = cached
        same = all(campaign_hashes(Path(tmp) / f"once{i}")
                   == campaign_hashes(Path(tmp) / f"per readout{i}") for i in range(args.repeats))
    med = {arm: statistics.median(t) for arm, t in times.items()}
    ratio = med["per readout"] / med["once"]
    print(f"harness campaign without gates, CPU over {args.repeats} runs each:")
    for arm, t in times.items():
        print(f"  bandwidth computed {arm:12s} median {med[arm]:.3f} s "
              f"(min {min(t):.3f}, max {max(t):.3f})")
    print(f"  ratio per readout / once: {ratio:.2f}; the same files: {same}")
    rows = []
    for arm, t in times.items():
        rows += [{"quantity": f"CPU, bandwidth computed {arm}, median of {args.repeats} [s]",
                  "value": med[arm]},
                 {"quantity": f"CPU, bandwidth computed {arm}, min [s]", "value": min(t)},
                 {"quantity": f"CPU, bandwidth computed {arm}, max [s]", "value": max(t)}]
    rows.append({"quantity": "ratio of the medians, per readout / once", "value": ratio})
    write_record(args.json, "simulate_spectra_speed", rows, description=summary_line(__doc__),
                 notes=[f"the two arms wrote the same files: {same}"])
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
