"""Speed of `dpdfit add`: 1,000 ARTIQ results files merged into a copy of a campaign.

    python benchmarks/add_speed.py [--files 1000] [--repeats 3] [--json PATH]

Writes FILES ndscan results files of further gate recordings of the bundled campaign
(``datasets/synthetic_campaign``) into a temporary folder -- one population scan per
ten files (axis amplitude over the five gate amplitudes, channels n00, n01_10, n11,
n_even, shots, as ``write_ndscan_campaign`` writes them), the others parity scans
(axis phase over the 16 analysis phases, channels n_even and shots) -- with the
mapping that imports them, then runs the whole of `dpdfit add` but the interpreter's
start (import, checks, merge, writing the new folder and reading it back) REPEATS
times and prints the median wall time and its ratio to the 15 s target.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.recordings.campaign_add import add_recordings
from dpdfit.simulation.artiq_results_file import axis, channel, ndscan_datasets, write_results_file
from record import ROOT, add_json_option, summary_line, write_record

TARGET_S = 15.0
CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"
AMPLITUDES = (0.4, 0.5, 0.6, 0.7, 0.8)
MAPPING = '''\
[[populations]]
files = "results/*/*/*-PopulationScan.h5"
[populations.columns]
A = { axis = "amplitude" }
dpd = { argument = "dpd" }
n00 = { channel = "n00" }
n01_10 = { channel = "n01_10" }
n11 = { channel = "n11" }
n_even = { channel = "n_even" }
shots = { channel = "shots" }

[[parity]]
files = "results/*/*/*-ParityScan.h5"
[parity.columns]
A = { argument = "amplitude" }
dpd = { argument = "dpd" }
phase_rad = { axis = "phase" }
n_even = { channel = "n_even" }
shots = { channel = "shots" }
'''


def write_lab(folder: Path, n_files: int) -> None:
    """The results files (module doc): counts drawn near the campaign's fidelities."""
    rng = np.random.default_rng(1)
    phases = np.asarray(ERROR_MODEL.analysis_phases(), dtype=float)
    amps = np.asarray(AMPLITUDES)
    for k in range(n_files):
        rid, start, dpd = k + 1, 1.76e9 + 60 * k, k % 2
        if k % 10 == 0:
            n = rng.multinomial(625, [0.49, 0.02, 0.49], size=len(amps))
            ch = {c: channel(n[:, i]) for i, c in enumerate(("n00", "n01_10", "n11"))}
            ch.update(n_even=channel(n[:, 0] + n[:, 2]), shots=channel(np.full(len(amps), 625)))
            write_results_file(folder, rid, "PopulationScan", start, ndscan_datasets(
                rid, "lab.gates.PopulationScan", [axis("amplitude", amps)], ch),
                arguments={"dpd": dpd})
            continue
        p = 0.5 + 0.48 * np.cos(2 * phases)
        write_results_file(folder, rid, "ParityScan", start, ndscan_datasets(
            rid, "lab.gates.ParityScan", [axis("phase", phases, "rad")],
            {"n_even": channel(rng.binomial(625, p)), "shots": channel(np.full(16, 625))}),
            arguments={"amplitude": float(amps[k % 5]), "dpd": dpd})


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--files", type=int, default=1000)
    p.add_argument("--repeats", type=int, default=3)
    add_json_option(p)
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        lab = Path(tmp) / "lab"
        write_lab(lab, args.files)
        (lab / "map.toml").write_text(MAPPING)
        size = sum(f.stat().st_size for f in lab.rglob("*.h5"))
        times, added = [], None
        for i in range(args.repeats):
            t = time.perf_counter()
            added = add_recordings(CAMPAIGN, lab / "map.toml", progress=False)
            added.write(Path(tmp) / f"out{i}")
            times.append(time.perf_counter() - t)
    med = statistics.median(times)
    rows_added = sum(added.rows_added.values())
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{args.files} results files ({size / 1e6:.1f} MB), {rows_added} rows added")
    print(f"add (import, merge, write, read back): median {med:.2f} s over {args.repeats} "
          f"runs (min {min(times):.2f}, max {max(times):.2f}); "
          f"{1e3 * med / args.files:.1f} ms per file; ratio to the {TARGET_S:g} s target "
          f"{med / TARGET_S:.2f}")
    rows = [
        {"quantity": "results files", "value": args.files},
        {"quantity": "size of the files [MB]", "value": size / 1e6},
        {"quantity": "rows added", "value": rows_added},
        {"quantity": f"add, median of {args.repeats} runs [s]", "value": med,
         "target": f"<= {TARGET_S:g}"},
        {"quantity": "add, min [s]", "value": min(times)},
        {"quantity": "add, max [s]", "value": max(times)},
        {"quantity": "per file [ms]", "value": 1e3 * med / args.files},
        {"quantity": "ratio of the median to the target", "value": med / TARGET_S,
         "target": "<= 1"},
        {"quantity": "process maximum resident size [MB]", "value": rss},
    ]
    write_record(args.json, "add_speed", rows, description=summary_line(__doc__))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
