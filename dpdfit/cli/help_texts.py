"""The one-line summary, the one-paragraph description and the example of every ``dpdfit``
command's ``--help``.

The summaries are the list of ``dpdfit --help``: each command's module registers its
command with its summary, and :func:`dpdfit.cli.main.build_parser` lists the commands
that are not being run by name and summary alone.  :func:`describe` sets the
descriptions and examples on the sub-parsers after the command modules have registered
them (a description a module already gives is kept), with
:class:`argparse.RawDescriptionHelpFormatter` so that the examples keep their lines.
The examples run from a clone of the repository (``datasets/``).
"""

from __future__ import annotations

import argparse
import textwrap

__all__ = ["SUMMARIES", "DESCRIPTIONS", "EXAMPLES", "OVERVIEW_EXAMPLES", "OVERVIEW_NOTE",
           "describe"]

#: command -> its line in ``dpdfit --help``.
SUMMARIES = {
    "polyfit": "weighted polynomial least squares on a CSV file",
    "calibrate": "fit the AOM amplitude (and phase) transfer functions",
    "lut": "export the predistortion table (CSV + .npy + .json)",
    "sweep": "amplitude sweep: spectra, F_est, eta_bar, r_rel (S6)",
    "estimate": "fidelity estimate from tone powers of one sideband (S5)",
    "im-table": "required gate-to-IM power ratios (Table S1)",
    "thresholds": "eta_bar_corr and threshold efficiencies of a sweep",
    "spectrum": "tone powers and IM ratios from a heterodyne photodiode trace",
    "stability": "stability of a multi-run calibration over time (Figs. S1, S2)",
    "propagate": "posterior + drift of the AOM calibration propagated into F_est",
    "budget": "error budget of the fidelity offset delta (Table S2)",
    "diagnose": "locate simulation/recording mismatches and name the missing physics",
    "harness": "injection-recovery harness of the diagnosis (parallel)",
    "fidelity": "Bell fidelities from raw population and parity counts (S7)",
    "align": "fit alpha (kHz) and delta aligning photodiode curves to gate data",
    "simulate-campaign": "simulate a complete synthetic measurement campaign",
    "import": "import ARTIQ results files (ndscan scans) into a campaign folder",
    "write-artiq-results": "write a campaign folder as ARTIQ results files "
                           "(to try dpdfit import)",
    "add": "add further recordings to a copy of a campaign folder",
    "analyze": "run every analysis on a campaign folder (main job)",
}

#: command -> one paragraph (for commands whose module gives none).
DESCRIPTIONS = {
    "polyfit": "Weighted linear least squares of a polynomial with any set of powers to two "
               "columns of a CSV file, solved in a way that stays accurate for "
               "ill-conditioned bases; prints coefficients, standard errors (absolute when "
               "--sigma is given), covariance and fit statistics.",
    "calibrate": "Fit the AOM's static transfer functions: the amplitude y(A) from the "
                 "recorded photodiode power, P(A) = (sum_k b_k A^k)^2, and optionally the "
                 "phase phi(A) on a window of amplitudes; writes calibration.json and, "
                 "with --plot, the panels of Fig. 1.  --all-runs fits every run of the files.",
    "lut": "Export the predistortion table of a calibration.json (target optical amplitude "
           "-> RF amplitude, the inverse of y(A)) as CSV, .npy and .json with its provenance "
           "(input files and their hashes, run, A_corr).",
    "sweep": "Simulate the amplitude sweep of Supplement S6 from a calibration: tone spectra, "
             "the fidelity estimate F_est, the mean diffraction efficiency eta_bar and the "
             "relative gate rate r_rel per amplitude, with and without predistortion.",
    "estimate": "The spectrum-based Bell-fidelity estimate F_est (Supplement S5) of one "
                "sideband from its tone powers in dB (gate tone n = 1, IM tones n = 0, 2, 3).",
    "im-table": "The required gate-to-intermodulation power ratios (dB) for given "
                "infidelities, for the n = 0 and n = 3 tones (Table S1).",
    "thresholds": "The corrected mean efficiency eta_bar_corr and the threshold efficiencies "
                  "(where the infidelity crosses each level) of a sweep written by "
                  "'dpdfit sweep', with and without predistortion.",
    "fidelity": "Bell-state fidelities from raw counts (Supplement S7): population fidelity "
                "per setting pooled over scans, parity contrast from the fringe fit, their "
                "combination F with intervals; optionally joined with the gate rates.",
    "align": "Fit the gate-rate scale alpha (kHz) and the fidelity offset delta that align "
             "the photodiode-derived curves of a sweep with measured gate data "
             "(Supplement S6.3-S6.4); errors are absolute (not rescaled).",
    "simulate-campaign": "Simulate a complete synthetic measurement campaign (calibration "
                         "runs, spectra, raw traces, gate counts, gate rates, time scans) "
                         "with the given seed, optionally with concealed effects that the "
                         "diagnosis should find.",
    "analyze": "Run every analysis dpdfit has on a campaign folder -- calibration, "
               "stability, sweep, measured spectra, traces, gates and alignment, posterior "
               "propagation, error budget and the discrepancy diagnosis -- and write tables, "
               "JSON files, figures, summary.json and summary.md into the results folder.  "
               "A missing file skips an analysis, a malformed one fails it (exit status 2) "
               "and the others go on.",
}

#: command -> example command line(s).
EXAMPLES = {
    "polyfit": "dpdfit polyfit datasets/synthetic_aom/calibration_phase.csv --x A "
               "--y phase_rad --powers 1:5",
    "calibrate": "dpdfit calibrate --amplitude datasets/synthetic_aom/calibration_amplitude.csv \\\n"
                 "    --phase datasets/synthetic_aom/calibration_phase.csv "
                 "-o out/calibration.json --plot out/figures",
    "lut": "dpdfit lut out/calibration.json --points 1001 -o out/lut.csv",
    "sweep": "dpdfit sweep out/calibration.json -o out/sweep.csv --plot out/figures",
    "estimate": 'dpdfit estimate --powers-db "0:-40,1:0,2:0,3:-30" --nbar 0.1',
    "im-table": "dpdfit im-table --nbar 0.1 --formula exact",
    "thresholds": "dpdfit thresholds out/sweep.csv --json",
    "spectrum": "dpdfit spectrum datasets/synthetic_campaign/traces/trace_A0.500_dpd1.npz \\\n"
                "    --fs 1e9 --fdet 2e7 --nu 1.84e6 --xi0 2e4",
    "stability": "dpdfit stability datasets/synthetic_campaign/calibration_amplitude.csv "
                 "--plot out/figures",
    "propagate": "dpdfit propagate --calibration-runs "
                 "datasets/synthetic_campaign/calibration_amplitude.csv \\\n"
                 "    --A 0.5 --stale-days 30",
    "budget": "dpdfit budget --delta -0.002 --delta-err 0.0004 "
              "--gate-rates datasets/synthetic_campaign/gate_rates.csv",
    "diagnose": "dpdfit diagnose datasets/concealed_campaign --plot out/diagnosis",
    "harness": "dpdfit harness --per-effect 2 --nulls 2 --workers 2 -o out/harness.json",
    "fidelity": "dpdfit fidelity --populations datasets/synthetic_campaign/populations.csv \\\n"
                "    --parity datasets/synthetic_campaign/parity.csv "
                "--gate-rates datasets/synthetic_campaign/gate_rates.csv -o out/gate.csv",
    "align": "dpdfit align --gate out/gate.csv --sweep out/sweep.csv --sigma-db 0.2",
    "simulate-campaign": "dpdfit simulate-campaign out/campaign --seed 7 "
                         "--effects aom_memory=0.5",
    "analyze": "dpdfit analyze datasets/synthetic_campaign -o results --no-diagnosis",
    "import": "pip install 'dpdfit[artiq]'                        # h5py, to read HDF5\n"
              "dpdfit simulate-campaign out/campaign --seed 7     # or your campaign "
              "folder\n"
              "dpdfit write-artiq-results out/campaign out/lab --shape ndscan\n"
              "dpdfit import out/lab/mapping.toml -o out/imported_campaign",
    "write-artiq-results": "dpdfit write-artiq-results out/campaign out/lab --shape "
                           "per-shot",
    "add": "dpdfit add datasets/synthetic_campaign out/further_lab/mapping.toml "
           "-o out/campaign_plus",
}


#: the examples at the bottom of ``dpdfit --help``; each line pastes as it is
OVERVIEW_EXAMPLES = (
    "dpdfit analyze datasets/synthetic_campaign -o results     # every analysis of a campaign\n"
    "dpdfit calibrate --amplitude datasets/synthetic_aom/calibration_amplitude.csv "
    "-o out/calibration.json\n"
    "dpdfit calibrate --help                                   # a command's options and example")

#: the note after them
OVERVIEW_NOTE = ("Also runnable as 'python -m dpdfit'.  In Python: dpdfit.analyze(folder) returns "
                 "every\nresult and table in memory; the documentation (docs/) has the details.")


def describe(subparsers) -> None:
    """Give every registered command its description (unless set), example and formatter."""
    for name, parser in subparsers.choices.items():
        desc = parser.description or DESCRIPTIONS.get(name)
        if desc:  # wrapped here: the raw formatter keeps lines as they are
            parser.description = textwrap.fill(" ".join(desc.split()), 79)
        if name in EXAMPLES:
            parser.epilog = "example:\n  " + EXAMPLES[name].replace("\n", "\n  ")
        parser.formatter_class = argparse.RawDescriptionHelpFormatter
