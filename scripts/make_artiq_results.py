#!/usr/bin/env python
"""Write a campaign folder as ARTIQ/ndscan results files (HDF5) plus the mapping for the importer.

    python scripts/make_artiq_results.py CAMPAIGN_DIR OUT_DIR --shape ndscan|per-shot [--seed N]

``--shape ndscan``: every table as ndscan scans, reproduced bit for bit by the
import (examples/import/ndscan_campaign.toml).  ``--shape per-shot``: per-shot
outcome arrays, phases in turns, plain gate-rate datasets, an old-ndscan file
and an interrupted scan (examples/import/per_shot_campaign.toml).  OUT_DIR gets
``results/<date>/<hour>/<rid>-<Class>.h5`` and ``mapping.toml``.  Needs h5py.
"""

import argparse
import sys
import time
from pathlib import Path

from dpdfit.errors import DpdfitError
from dpdfit.simulation.artiq_results import write_ndscan_campaign, write_per_shot_campaign


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("campaign_dir", type=Path, help="campaign folder (CSVs, campaign.json)")
    parser.add_argument("out_dir", type=Path, help="output folder (results/ and mapping.toml)")
    parser.add_argument("--shape", choices=("ndscan", "per-shot"), required=True)
    parser.add_argument("--seed", type=int, default=0, help="seed of the per-shot shuffles")
    args = parser.parse_args(argv)
    if args.out_dir.exists() and any(args.out_dir.iterdir()):
        parser.error(f"{args.out_dir} exists and is not empty (the mapping's globs would "
                     "pick up its old files); choose a new folder")
    start = time.perf_counter()
    try:
        if args.shape == "ndscan":
            mapping = write_ndscan_campaign(args.campaign_dir, args.out_dir)
        else:
            mapping = write_per_shot_campaign(args.campaign_dir, args.out_dir, seed=args.seed)
    except (DpdfitError, OSError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    files = sorted(args.out_dir.glob("results/*/*/*.h5"))
    size = sum(f.stat().st_size for f in files)
    print(f"{len(files)} results files ({size / 1e6:.1f} MB) and {mapping} "
          f"in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
