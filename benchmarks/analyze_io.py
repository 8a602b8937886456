"""How often `analyze` opens each recording file and fits each calibration run.

    python benchmarks/analyze_io.py [CAMPAIGN_DIR] [--diagnosis] [--json PATH]

Runs :func:`dpdfit.analyze` (no figures; the diagnosis only with
``--diagnosis``) on the campaign (default: the bundled one) with the opening
of files (``open``: a campaign folder is CSV, JSON and NPZ) and the amplitude fits (:func:`~dpdfit.fits.calibration.amplitude.fit_amplitude`)
counted (``numpy.load`` opens through ``open``: counted once), and prints per recording file the number of times it was opened and
the number of amplitude fits per (run, order).  Target: every file opened
once, every run fitted once per order it is analysed at.
"""

from __future__ import annotations

import argparse
import builtins
import collections
import os
import sys
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np

import dpdfit
from dpdfit.fits.calibration import amplitude as amplitude_module
from record import add_json_option, summary_line, write_record

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("campaign", nargs="?", default=ROOT / "datasets" / "synthetic_campaign",
                   type=Path)
    p.add_argument("--diagnosis", action="store_true")
    add_json_option(p)
    args = p.parse_args(argv)
    folder = args.campaign.resolve()
    opens = collections.Counter()
    fits = collections.Counter()
    real_open = builtins.open
    real_fit = amplitude_module.fit_amplitude

    def note(path):
        try:
            q = Path(os.fspath(path)).resolve()
        except TypeError:
            return
        if folder in q.parents:
            opens[str(q.relative_to(folder))] += 1

    def counting_open(file, *a, **kw):
        note(file)
        return real_open(file, *a, **kw)

    def counting_fit(A, power, *a, **kw):
        order = kw.get("order", a[1] if len(a) > 1 else None)
        fits[(len(A), round(float(np.sum(power)), 9), order)] += 1
        return real_fit(A, power, *a, **kw)

    with tempfile.TemporaryDirectory() as out, \
            mock.patch("builtins.open", counting_open), mock.patch("io.open", counting_open), \
            mock.patch.object(amplitude_module, "fit_amplitude", counting_fit):
        # the modules that imported fit_amplitude by name get the counting one too
        for mod in list(sys.modules.values()):
            if getattr(mod, "fit_amplitude", None) is real_fit and mod is not amplitude_module:
                mock.patch.object(mod, "fit_amplitude", counting_fit).start()
        dpdfit.analyze(folder, out, plots=False, diagnosis=args.diagnosis, progress=False)
        mock.patch.stopall()
    print(f"analyze {folder.name}{' (with the diagnosis)' if args.diagnosis else ''}")
    print("file opens:")
    for f, n in sorted(opens.items()):
        print(f"  {n:3d}  {f}")
    per_run = collections.Counter(fits.values())
    print(f"amplitude fits: {sum(fits.values())} for {len(fits)} distinct (run data, order); "
          "fits per (run, order): " + ", ".join(f"{k}x: {v}" for k, v in sorted(per_run.items())))
    title = f"{folder.name}{' (with the diagnosis)' if args.diagnosis else ''}"
    rows = [{"table": f"file opens, analyze {title}", "file": f, "opens": n, "target": 1}
            for f, n in sorted(opens.items())]
    rows += [{"table": "amplitude fits", "fits per (run data, order)": k,
              "(run data, order) pairs": v, "target": "1 fit each"}
             for k, v in sorted(per_run.items())]
    rows.append({"table": "amplitude fits", "fits per (run data, order)": "all",
                 "(run data, order) pairs": len(fits), "total fits": sum(fits.values())})
    write_record(args.json, "analyze_io", rows, description=summary_line(__doc__))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
