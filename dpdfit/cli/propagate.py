"""``dpdfit propagate``: posterior and drift of the AOM calibration propagated into F_est.

The analysis is imported when the command runs, so that registering its options
(``dpdfit --help``) does not load it.
"""

from __future__ import annotations

import argparse
import json

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import fraction, int_at_least, nonneg_float, nonneg_int, positive_int
from dpdfit.core.defaults import AMPLITUDE_ORDER
from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError

__all__ = ["add_propagate_command", "cmd_propagate"]


def cmd_propagate(args) -> int:
    """``dpdfit propagate``: drift propagation into F_est (report or JSON)."""
    # here, not at the top: --help registers the options without loading the analysis
    from dpdfit.analyses.propagation import propagate, threshold_distribution
    from dpdfit.fits.calibration import calibrate_phase
    from dpdfit.recordings.tables import read_calibration, read_calibration_table
    df = read_calibration_table(args.calibration_runs, "amplitude")
    phase = None
    if args.phase:
        phase = calibrate_phase(read_calibration(args.phase, "phase", run="latest"))
    try:
        res = propagate(df, args.A, stale_days=args.stale_days, draws=args.draws, phase=phase,
                        order=args.order, run=args.run, seed=args.seed, n_walkers=args.walkers,
                        n_steps=args.steps, force=args.force, progress=args.progress,
                        recalibration_loss=args.loss)
    except InputError as exc:
        for api, opt in (("n_walkers", "--walkers"), ("n_steps", "--steps")):
            if str(exc).startswith(api):
                raise InputError(f"option {opt}: {exc}") from None
        raise
    d = res.to_dict()
    if args.thresholds:
        d["thresholds"] = threshold_distribution(
            df, stale_days=args.stale_days, draws=min(args.draws, 2000), phase=phase,
            order=args.order, run=args.run, seed=args.seed, n_walkers=args.walkers,
            n_steps=args.steps, force=args.force)
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        print(res.report())
        if args.thresholds:
            for flag in ("no_dpd", "dpd"):
                print(f"    eta_th {flag:7s}: " + ", ".join(
                    f"{lev}: " + ("-" if v.get("median") is None else
                                  f"{v['median']:.4f} [{v['q16']:.4f}, {v['q84']:.4f}]")
                    for lev, v in d["thresholds"][flag].items()))
    return 0


def add_propagate_command(subparsers) -> argparse.ArgumentParser:
    """Register ``dpdfit propagate`` on an argparse sub-parsers object.

    ``dpdfit propagate --calibration-runs runs.csv --A 0.5 [--stale-days D]
    [--draws N] [--json] [--force]``; the registered ``func`` returns an exit
    code and raises :class:`~dpdfit.errors.DpdfitError` on bad input.
    """
    s = subparsers.add_parser(
        "propagate", help=SUMMARIES["propagate"],
        description="Posterior (emcee) of the latest calibration run, run-to-run drift from "
                    "all runs, propagated through the Cardioid forward model at one amplitude "
                    "for both DPD flags: quantiles of F_est, R10 and eta_bar.")
    s.add_argument("--calibration-runs", required=True, metavar="RUNS.csv",
                   help="amplitude calibration runs: run, timestamp, A, power[, power_err]")
    s.add_argument("--A", type=fraction, required=True, help="RF-envelope peak amplitude (0..1]")
    s.add_argument("--stale-days", type=nonneg_float, default=0.0,
                   help="age of the calibration, days (0)")
    s.add_argument("--draws", type=positive_int, default=10000, help="predictive draws (10000)")
    s.add_argument("--run", help="run used as the calibration (default: latest)")
    s.add_argument("--phase", metavar="PHASE.csv", help="phase calibration (latest run; "
                   "default: AM-only forward model)")
    s.add_argument("--order", type=int_at_least(2), default=AMPLITUDE_ORDER,
                   help=f"amplitude polynomial order ({AMPLITUDE_ORDER})")
    s.add_argument("--walkers", type=positive_int, default=32, help="emcee walkers (32)")
    s.add_argument("--steps", type=positive_int, default=400, help="emcee steps per walker (400)")
    s.add_argument("--seed", type=nonneg_int, default=0, help="random seed (0)")
    s.add_argument("--loss", type=fraction, default=1e-4,
                   help="fidelity loss for the recalibration answer (1e-4)")
    s.add_argument("--thresholds", action="store_true",
                   help="also the distribution of the threshold efficiencies (40-point sweep "
                        "per draw; uses min(draws, 2000) draws)")
    s.add_argument("--force", action="store_true", help="report an unconverged chain")
    s.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar on stderr (default: when stderr is a terminal)")
    s.add_argument("--json", action="store_true", help="print JSON instead of a report")
    s.set_defaults(func=cmd_propagate)
    return s
