"""The simulator standing in for the lab: the rows further recordings add to a campaign.

A further recording (:func:`~dpdfit.simulation.further_recordings.extend_config`) is drawn
from random streams of its own, so the campaign extended by it has every row it had
before, and the new rows after them in each table (calibration runs after the runs,
trace amplitudes after the grid, further scans and time scans after the gate rows; a
new gate setting's rate after the rates).  :func:`record_further` simulates only what
those new rows need -- the calibration runs (cheap), the new traces only, the gate
settings replayed in order up to the last one a new scan records at (their rates and
scans share one random stream, so the earlier ones must be drawn), none of the
campaign's own time scans -- and returns exactly the rows that the whole extended
campaign has beyond the campaign's (:func:`difference_rows` computes them the long way,
by simulating both; the tests hold the two equal).

The config is the one a campaign's ``truth.json`` records
(:meth:`~dpdfit.simulation.campaign.CampaignConfig.from_truth`); the rows replayed on the
way (calibration runs, the replayed gate settings) are checked against the campaign's
own tables when they are given (:func:`check_replayed`), so that a campaign whose
recordings its ``truth.json`` does not generate (edited, or merged) is refused rather
than continued with numbers that are not its own.
"""

from __future__ import annotations

import io
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from dpdfit.core.display import Displayable
from dpdfit.errors import InputError
from dpdfit.simulation.campaign import CampaignConfig
from dpdfit.simulation.campaign.calibration_runs import calibration_runs
from dpdfit.simulation.campaign.detector_linearity_runs import linearity_table
from dpdfit.simulation.campaign.folder import csv_text
from dpdfit.simulation.campaign.gate_runs import further_gate_rows, gate_references, gate_tables
from dpdfit.simulation.campaign.optics import dpd_lut
from dpdfit.simulation.campaign.pulse_runs import pulse_table
from dpdfit.simulation.campaign.ramsey_runs import ramsey_table
from dpdfit.simulation.campaign.spam_runs import spam_table
from dpdfit.simulation.campaign.thermometry_runs import thermometry_table
from dpdfit.simulation.campaign.spectra import spectra_tables
from dpdfit.simulation.further_recordings import extend_config

__all__ = ["TABLES", "CHARACTERISATION_TABLES", "StandInRecording", "extended_config", "record_further", "as_written",
           "simulated_tables", "difference_rows", "check_replayed"]

#: The campaign tables a further recording can add rows to, in the campaign's order.
TABLES = ("calibration_amplitude", "calibration_phase", "spectra", "populations", "parity",
          "gate_rates", "time_scans")
#: the lab's characterisation tables a further recording can add (a campaign may have none)
CHARACTERISATION_TABLES = ("spam", "pulse_response", "ramsey", "detector_linearity",
                           "thermometry")
#: agreement of a replayed value with the campaign's table: truth.json and the CSVs keep
#: 10 significant digits, and the processor's BLAS kernel rounds differently in the last
#: bits, which moves a float by ~1e-8 relative through the calibration fit and the
#: gate-time root-find (the bundled campaign's gate rates here), a tone power in dB by
#: < 0.001 dB: the tolerances tests/helpers/same_campaign.py allows; counts exactly
_REPLAY_RTOL = 1e-6
_DB_ATOL = 1e-3


class _Quiet:
    def __init__(self, *args):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, *args):
        pass


@dataclass(frozen=True)
class StandInRecording(Displayable):
    """The rows a campaign's further recordings added, as the simulator recorded them.

    ``tables``: table name -> the new rows (every column of the simulator's table; only
    tables that gained rows); ``measurements``: the ``{"what", "settings"}`` recorded;
    ``config``: the extended campaign config; ``seconds``: wall time of the simulation.
    """

    tables: dict
    measurements: tuple
    config: CampaignConfig = field(repr=False)
    seconds: float = 0.0

    def rows(self) -> dict:
        """Number of new rows per table."""
        return {t: int(len(df)) for t, df in self.tables.items()}

    def report(self) -> str:
        """One line per measurement, then the new rows per table."""
        lines = [f"recorded {m.get('what')}: {m.get('settings')}" for m in self.measurements]
        lines += [f"{t:22s} {n:6d} new rows" for t, n in self.rows().items()]
        return "\n".join(lines + [f"simulated in {self.seconds:.1f} s"])

    def to_dict(self) -> dict:
        """The measurements, new rows per table and the wall time (JSON-ready)."""
        return {"measurements": [dict(m) for m in self.measurements], "rows": self.rows(),
                "seconds": float(self.seconds)}


def extended_config(cfg: CampaignConfig, measurements) -> CampaignConfig:
    """``cfg`` with every measurement added in turn (:func:`extend_config`)."""
    for m in measurements:
        cfg = extend_config(cfg, m)
    return cfg


def _frame(rows: pd.DataFrame) -> pd.DataFrame:
    return rows.reset_index(drop=True)


def as_written(rows: pd.DataFrame) -> pd.DataFrame:
    """The rows as the simulator writes them into a campaign folder (its CSV text, 10
    significant digits: :func:`~dpdfit.simulation.campaign.folder.csv_text`) and reads
    them back: what a recording of the simulator holds, to the last digit."""
    # a prepared basis state is text (00, not the number 0)
    return pd.read_csv(io.StringIO(csv_text(rows)), dtype={"prepared": str})


def _new_runs(table: pd.DataFrame, old_runs: int) -> pd.DataFrame:
    """The rows of the runs after the first ``old_runs`` (runs come in their order)."""
    labels = list(dict.fromkeys(table["run"]))
    return _frame(table[table["run"].isin(labels[old_runs:])])


def _old_runs(cfg: CampaignConfig, what: str) -> int:
    base = cfg.n_amp_runs if what == "amplitude_run" else cfg.n_phase_runs
    return base + sum(1 for item in cfg.further if item[0] == what)


def record_further(cfg: CampaignConfig, measurements, *, original: dict | None = None,
                   progress=None) -> StandInRecording:
    """Simulate the further recordings ``measurements`` of the campaign ``cfg``: its new rows.

    Parameters
    ----------
    cfg : CampaignConfig
        The campaign's config (e.g. :meth:`CampaignConfig.from_truth` of its truth.json).
    measurements : list of dict
        ``{"what", "settings"}`` each (:func:`extend_config`), recorded in that order.
    original : dict, optional
        The campaign's tables (name -> DataFrame): the rows replayed on the way must be
        theirs (:func:`check_replayed`), else InputError.
    progress : callable, optional
        ``progress(label, total)`` as :func:`~dpdfit.simulation.campaign.simulate_campaign`
        takes it (default: none shown).

    Returns
    -------
    StandInRecording
        The new rows per table, as the simulator writes them (:func:`as_written`):
        exactly those of :func:`difference_rows`.
    """
    t0 = time.perf_counter()
    measurements = tuple(measurements)
    ext = extended_config(cfg, measurements)
    progress = progress or _Quiet
    new, replayed = {}, {}
    with threadpool_limits(limits=1, user_api="blas"):
        amp, ph, aom, tf, _ = calibration_runs(ext)
        new["calibration_amplitude"] = _new_runs(amp, _old_runs(cfg, "amplitude_run"))
        new["calibration_phase"] = _new_runs(ph, _old_runs(cfg, "phase_run"))
        replayed["calibration_amplitude"], replayed["calibration_phase"] = amp, ph
        lut = None
        if len(ext.trace_amplitudes) > len(cfg.trace_amplitudes):
            lut = dpd_lut(tf, ext.lut_points)
            new["spectra"] = _frame(spectra_tables(ext, aom, lut, progress,
                                                   first=len(cfg.trace_amplitudes))[0])
        if any(item[0] in ("scan", "time_scan") for item in ext.further[len(cfg.further):]):
            lut = dpd_lut(tf, ext.lut_points) if lut is None else lut
            pop, par, rates, ts, done = further_gate_rows(ext, aom, lut, len(cfg.further),
                                                          progress)
            new.update(populations=pop, parity=par, gate_rates=rates, time_scans=ts)
            replayed.update(populations=done["pop"], parity=done["par"],
                            gate_rates=done["rates"])
        new["spam"] = spam_table(ext, further_from=len(cfg.further))
        new["pulse_response"] = pulse_table(ext, aom, further_from=len(cfg.further))
        if any(item[0] == "ramsey" for item in ext.further[len(cfg.further):]):
            lut = dpd_lut(tf, ext.lut_points) if lut is None else lut
            new["ramsey"] = ramsey_table(ext, gate_references(ext, aom, lut),
                                         further_from=len(cfg.further))
        new["detector_linearity"] = linearity_table(ext, aom, further_from=len(cfg.further))
        new["thermometry"] = thermometry_table(ext, further_from=len(cfg.further))
    if original is not None:
        check_replayed(replayed, original, new)
    tables = {t: as_written(new[t]) for t in (*TABLES, *CHARACTERISATION_TABLES)
              if t in new and len(new[t])}
    return StandInRecording(tables=tables, measurements=measurements, config=ext,
                            seconds=time.perf_counter() - t0)


def simulated_tables(cfg: CampaignConfig, *, include_spectra: bool = True,
                     include_gates: bool = True) -> dict:
    """Every table of the campaign ``cfg`` as the simulator draws it (no files written)."""
    with threadpool_limits(limits=1, user_api="blas"):
        amp, ph, aom, tf, _ = calibration_runs(cfg)
        out = {"calibration_amplitude": amp, "calibration_phase": ph}
        lut = dpd_lut(tf, cfg.lut_points)
        if include_spectra:
            out["spectra"] = spectra_tables(cfg, aom, lut, _Quiet)[0]
        if include_gates:
            pop, par, rates, ts, _ = gate_tables(cfg, aom, lut, _Quiet)
            out.update(populations=pop, parity=par, gate_rates=rates, time_scans=ts)
        spam = spam_table(cfg)
        if len(spam):
            out["spam"] = spam
        pulse = pulse_table(cfg, aom)
        if len(pulse):
            out["pulse_response"] = pulse
        if cfg.ramsey_shots or any(item[0] == "ramsey" for item in cfg.further):
            out["ramsey"] = ramsey_table(cfg, gate_references(cfg, aom, lut))
        linearity = linearity_table(cfg, aom)
        if len(linearity):
            out["detector_linearity"] = linearity
        thermo = thermometry_table(cfg)
        if len(thermo):
            out["thermometry"] = thermo
    return out


def difference_rows(cfg: CampaignConfig, measurements, before: dict | None = None,
                    **kw) -> dict:
    """The new rows the long way: the extended campaign's tables beyond the campaign's.

    Both campaigns are simulated whole (``kw``: :func:`simulated_tables`'s; ``before``:
    the campaign's tables if already simulated so); in every table the extended one must
    begin with exactly the campaign's rows (AssertionError otherwise), and the rows after
    them are returned (tables with new rows only).
    """
    before = simulated_tables(cfg, **kw) if before is None else before
    after = simulated_tables(extended_config(cfg, measurements), **kw)
    out = {}
    for t, rows in after.items():
        old = before.get(t, rows.iloc[:0])      # a table the campaign has not: all new
        head = rows.iloc[:len(old)].reset_index(drop=True)
        pd.testing.assert_frame_equal(head, old.reset_index(drop=True), check_exact=True)
        if len(rows) > len(old):
            out[t] = as_written(rows.iloc[len(old):])
    return out


def check_replayed(replayed: dict, original: dict, new: dict | None = None) -> None:
    """The replayed rows must be the first rows of the campaign's tables (floats up to the
    rounding of truth.json, the CSVs and the processor's BLAS kernel: relative 1e-6, 1e-3
    dB; counts and labels exactly).

    ``replayed``: table -> rows drawn again; ``original``: the campaign's tables;
    ``new``: the new rows (a calibration table's replay includes them at its end).
    Raises InputError naming the first table and row that differ.
    """
    for t, rows in replayed.items():
        rows = rows.iloc[:len(rows) - len((new or {}).get(t, ()))]
        have = original.get(t)
        where = f"{t}.csv"
        if have is None or len(have) < len(rows) or (
                t.startswith("calibration") and len(have) != len(rows)):
            raise InputError(f"{where}: has {0 if have is None else len(have)} rows where the "
                             f"campaign's truth.json generates {len(rows)}: only an unedited "
                             "simulated campaign can stand in for the lab")
        bad = _first_difference(rows.reset_index(drop=True),
                                have.iloc[:len(rows)].reset_index(drop=True))
        if bad is not None:
            raise InputError(f"{where} row {bad[0] + 1}, column {bad[1]}: not the value the "
                             "campaign's truth.json generates: only an unedited simulated "
                             "campaign can stand in for the lab")


def _first_difference(drawn: pd.DataFrame, have: pd.DataFrame):
    """(row, column) of the first value of ``drawn`` that ``have`` does not match."""
    for c in drawn.columns:
        if c not in have.columns:
            return 0, c
        a, b = drawn[c].to_numpy(), have[c].to_numpy()
        if a.dtype.kind in "fc" or b.dtype.kind == "f":
            atol = _DB_ATOL if c.lower().endswith("_db") else 0.0
            # an edited cell may hold text where truth.json generates a number: it differs
            bf = pd.to_numeric(pd.Series(b), errors="coerce").to_numpy(float)
            text = np.isnan(bf) & (pd.notna(b) if b.dtype.kind == "O" else False)
            af = pd.to_numeric(pd.Series(a), errors="coerce").to_numpy(float)
            same = np.isclose(af, bf, rtol=_REPLAY_RTOL, atol=atol)
            same |= np.isnan(af) & np.isnan(bf) & ~text
        else:
            same = np.asarray([str(x) == str(y) for x, y in zip(a, b)])
        if not same.all():
            return int(np.argmin(same)), c
    return None
