"""``dpdfit spectrum``: tone powers and IM ratios of a heterodyne trace, from the command line.

Reads the trace (:func:`dpdfit.recordings.traces.load_trace`), extracts the
tones (:func:`dpdfit.fits.tones.trace_tone_powers`), optionally adds the
fidelity estimate and the comparison with a reference trace
(:mod:`dpdfit.analyses.trace_estimate`), and prints a report or the JSON.  They are
imported when the command runs, so that registering its options (``dpdfit --help``)
does not load them.
"""

from __future__ import annotations

import argparse
import json
import sys

from dpdfit.cli.help_texts import SUMMARIES
from dpdfit.cli.options import finite_float, nonneg_float, positive_float
from dpdfit.core.defaults import FORMULA, FORMULAS, NBAR
from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import InputError
from dpdfit.recordings.outputs import atomic_write_json, refuse_overwriting_inputs

__all__ = ["cmd_spectrum", "add_spectrum_command"]


def _parse_int_list(spec: str, option: str) -> tuple[int, ...]:
    """The integers of a comma-separated option value (``0,1,2,3``)."""
    out = []
    for tok in str(spec).split(","):
        tok = tok.strip()
        if not tok:
            continue
        try:
            out.append(int(tok))
        except ValueError:
            raise InputError(f"{option}: '{tok}' is not an integer (use e.g. 0,1,2,3)") from None
    return tuple(out)


def _print_report(res, d: dict, args) -> None:
    """The readable report, with the estimate and the comparison if requested."""
    def fmt(v):
        return "-" if v is None else f"{v:.6f}"

    print(res.report())
    if args.estimate:
        e = d["estimate"]
        print(f"[[Estimate]] (S5, formula {e['formula']}, nbar {e['nbar']:g})"
              + ("  lower limits: an IM tone is at the noise floor" if e["limit"] else ""))
        print(f"    F_est red {fmt(e['red']['F_est'])}   blue {fmt(e['blue']['F_est'])}"
              f"   mean {fmt(e['F_est'])}")
    if args.compare:
        dp = d["dP_dB"]["mean"]
        print(f"[[dP vs {args.compare}]] mean over sidebands: "
              + ", ".join(f"dP{k} = {'-' if v is None else f'{v:+.3f}'} dB"
                          for k, v in dp.items()))
    if args.output:
        print(f"wrote {args.output}", file=sys.stderr)


def cmd_spectrum(args) -> int:
    """``dpdfit spectrum``: tone powers of a heterodyne trace (report or JSON)."""
    # here, not at the top: --help registers the options without loading the analyses
    from dpdfit.analyses.trace_estimate import delta_powers, trace_estimate
    from dpdfit.fits.tones import trace_tone_powers
    from dpdfit.recordings.traces import load_trace
    if args.output:
        refuse_overwriting_inputs([args.output], [args.trace, args.compare])
    harmonics = _parse_int_list(args.harmonics, "--harmonics")
    gate = _parse_int_list(args.gate, "--gate")

    def analyse(path):
        try:
            return trace_tone_powers(
                load_trace(path), args.fs, args.fdet, args.nu, args.xi0, harmonics=harmonics,
                gate=gate, search_hz=args.search_hz, max_freq_error_hz=args.max_freq_error_hz,
                min_snr_db=args.min_snr_db, im_min_snr_db=args.im_min_snr_db,
                swap_sidebands=args.swap_sidebands)
        except InputError as exc:
            if exc.file is None:
                raise InputError(str(exc), file=str(path)) from None
            raise

    res = analyse(args.trace)
    d = res.to_dict()
    d["source"] = str(args.trace)
    if args.estimate:
        d["estimate"] = trace_estimate(res, args.nbar, args.formula)
    if args.compare:
        ref = analyse(args.compare)
        d["dP_dB"] = delta_powers(res, ref)
        d["compare_source"] = str(args.compare)
    if args.output:
        atomic_write_json(args.output, d)
    if args.json:
        print(json.dumps(to_jsonable(d), indent=2))
    else:
        _print_report(res, d, args)
    return 0


def add_spectrum_command(subparsers) -> argparse.ArgumentParser:
    """Register the ``spectrum`` sub-command on an argparse sub-parsers object.

    ``dpdfit spectrum TRACE --fs HZ --fdet HZ --nu HZ --xi0 HZ [--json]
    [--harmonics 0,1,2,3] [--gate 1,2] [--swap-sidebands] [-o OUT.json]``.
    The registered ``func`` returns an exit code and raises
    :class:`~dpdfit.errors.DpdfitError` on bad input.
    """
    s = subparsers.add_parser(
        "spectrum", help=SUMMARIES["spectrum"],
        description="Gate and intermodulation tone powers (dB re a unit-amplitude sinusoid) "
                    "from a flat-top periodogram of a heterodyne beat trace (Supplement S4).")
    s.add_argument("trace", help=".npy (1-D), .npz (keys trace[, scale]) or one-column .csv")
    s.add_argument("--fs", type=positive_float, required=True, help="sample rate, Hz")
    s.add_argument("--fdet", type=finite_float, required=True, help="reference offset f_det, Hz")
    s.add_argument("--nu", type=positive_float, required=True, help="motional sideband nu, Hz")
    s.add_argument("--xi0", type=positive_float, required=True, help="harmonic spacing xi0, Hz")
    s.add_argument("--harmonics", default="0,1,2,3",
                   help="harmonics n to measure (0,1,2,3); negative values need '=', "
                        "e.g. --harmonics=-1,0,1,2,3,4")
    s.add_argument("--gate", default="1,2", help="gate-tone harmonics (1,2)")
    s.add_argument("--search-hz", type=positive_float, default=5e3,
                   help="gate-tone peak search half-width, Hz (5000)")
    s.add_argument("--max-freq-error-hz", type=positive_float, default=1e3,
                   help="gate-tone frequency tolerance, Hz (1000)")
    s.add_argument("--min-snr-db", type=finite_float, default=20.0,
                   help="gate-tone minimum SNR over the median noise floor, dB (20)")
    s.add_argument("--im-min-snr-db", type=finite_float, default=10.0,
                   help="IM tones below this SNR are upper limits, dB (10)")
    s.add_argument("--swap-sidebands", action="store_true",
                   help="blue group at f_det - (nu + n xi0), red at f_det + ...")
    s.add_argument("--estimate", action="store_true",
                   help="add the spectrum-based fidelity estimate F_est (S5)")
    s.add_argument("--nbar", type=nonneg_float, default=NBAR, help=f"thermal phonon number ({NBAR:g})")
    s.add_argument("--formula", choices=list(FORMULAS), default=FORMULA,
                   help=f"Bell-fidelity expression for --estimate ({FORMULA})")
    s.add_argument("--compare", metavar="REF_TRACE",
                   help="reference trace (e.g. no DPD at the same A): adds dP_n = P_n - P_n(ref)")
    s.add_argument("--json", action="store_true", help="print the JSON instead of a report")
    s.add_argument("-o", "--output", help="also write the JSON to this file")
    s.set_defaults(func=cmd_spectrum)
    return s
