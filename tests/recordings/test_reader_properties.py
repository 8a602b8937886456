"""Property-based tests of every reader.

A generated mutation of a valid file (see :mod:`tests.helpers.prop_mutations`) must give a
valid result (finite numbers where the reader promises them) or raise ONE
:class:`~dpdfit.errors.DpdfitError` whose message is one line naming the file;
any other exception, or a NaN/empty result, fails.  Harmless edits (CRLF line
endings, comment and blank lines, shuffled rows) must give the same result as
the original file.

Default profile ``ci`` (30 derandomized examples per test); the larger run is
``HYPOTHESIS_PROFILE=thorough python -m pytest tests/recordings/test_reader_properties.py``.
"""

import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import example, given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from tests.helpers.prop_mutations import (base_texts, csv_mutations, json_mutations,
                                          mutate_csv, mutate_json, outcome)

from dpdfit.analyses.budget import gate_rates_khz
from dpdfit.analyses.sweep import read_sweep_table
from dpdfit.fits.calibration import load_calibration
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.counts import read_parity, read_populations
from dpdfit.recordings.tables import read_calibration
from dpdfit.recordings.traces import load_trace


def _finite(df, cols):
    assert len(df) > 0, "empty table"
    for c in cols:
        if c in df.columns:
            v = np.asarray(df[c], dtype=float)
            assert np.isfinite(v).all(), f"non-finite values in column {c}"


def _check_calibration(res):
    assert res.A.size > 0 and res.A.size == res.value.size
    assert np.isfinite(res.A).all() and np.isfinite(res.value).all()
    assert ((res.A >= 0) & (res.A <= 1)).all()
    if res.error is not None:
        assert np.isfinite(res.error).all() and (res.error > 0).all()


def _check_counts(df):
    _finite(df, ["A", "dpd", "shots", "n_even", "phase_rad"])
    assert (df["shots"] > 0).all() and (df["n_even"] <= df["shots"]).all()
    assert (df["n_even"] >= 0).all()


def _campaign_reader(attr):
    def read(path):
        return getattr(CampaignFolder(Path(path).parent), attr)
    return read


def _check_sweep(df):
    _finite(df, [c for c in df.columns if c != "sideband"])


#: reader -> (base text key, file name, function of the path, check of the result)
READERS = {
    "calibration_amplitude.csv": ("amplitude", "calibration_amplitude.csv",
                                  lambda p: read_calibration(p, "amplitude", "latest"),
                                  _check_calibration),
    "calibration_phase.csv": ("phase", "calibration_phase.csv",
                              lambda p: read_calibration(p, "phase", "latest"),
                              _check_calibration),
    "populations.csv": ("populations", "populations.csv", read_populations, _check_counts),
    "parity.csv": ("parity", "parity.csv", read_parity, _check_counts),
    "gate_rates.csv (budget)": ("gate_rates", "gate_rates.csv", gate_rates_khz,
                                lambda r: (len(r) > 0 and np.isfinite(r).all()
                                           and (np.asarray(r) > 0).all()) or _no("rates")),
    "gate_rates.csv (campaign)": ("gate_rates", "gate_rates.csv", _campaign_reader("gate_rates"),
                                  lambda df: _finite(df, ["A", "dpd", "xi0_khz", "xi0_err_khz"])),
    "time_scans.csv": ("time_scans", "time_scans.csv", _campaign_reader("time_scans"),
                       lambda df: _finite(df, ["A", "dpd", "t_us", "n00", "n11", "shots"])),
    "spectra.csv": ("spectra", "spectra.csv", _campaign_reader("spectra"),
                    lambda df: _finite(df, ["A", "dpd", "n", "P_dB"])),
    "traces.csv": ("traces_csv", "traces.csv", _campaign_reader("traces"),
                   lambda df: _finite(df, ["A", "dpd", "fs", "fdet", "nu", "xi0"])),
    "trace file (.csv)": ("trace", "trace.csv", load_trace,
                          lambda x: (x.size > 0 and np.isfinite(x).all()) or _no("trace")),
    "sweep.csv": ("sweep", "sweep.csv", read_sweep_table, _check_sweep),
}


def _no(what):
    raise AssertionError(f"{what}: empty or not finite")


def _run_reader(reader, data: bytes, name=None):
    key, fname, read, check = READERS[reader]
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / (name or fname)
        (Path(d) / "campaign.json").write_text(base_texts()["campaign"])
        p.write_bytes(data)
        result = outcome(reader, p, lambda: read(p), check)
        assert p.read_bytes() == data, "the reader modified its input"
    return result


#: minimal failing examples found by these tests (each fixed at its source)
_FOUND = {
    # non-UTF-8 bytes: UnicodeDecodeError; a BOM-only one-column file: EmptyDataError
    "trace file (.csv)": [[("not_utf8", 0, 0, None)], [("cell", 0, 0, '"')],
                          [("drop_col", 0, 0, None), ("bom", 0, 0, None)]],
    # non-UTF-8 bytes in the '#' header of a sweep table: UnicodeDecodeError
    "sweep.csv": [[("not_utf8", 0, 1, None)]],
    # a quoted cell spanning lines: a message of two lines
    "spectra.csv": [[("cell", 0, 0, '"')], [("cell", 0, 5, "inf")]],  # 'valid' inf: IntCasting
    "time_scans.csv": [[("cell", 0, 0, '"')]],
}


def _csv_property(reader):
    @given(ops=csv_mutations())
    def test(ops):
        _run_reader(reader, mutate_csv(base_texts()[READERS[reader][0]], ops))
    test.__name__ = f"test_mutated_{READERS[reader][0]}"
    for ops in _FOUND.get(reader, []):
        test = example(ops=ops)(test)
    return test


test_mutated_calibration_amplitude = _csv_property("calibration_amplitude.csv")
test_mutated_calibration_phase = _csv_property("calibration_phase.csv")
test_mutated_populations = _csv_property("populations.csv")
test_mutated_parity = _csv_property("parity.csv")
test_mutated_gate_rates_budget = _csv_property("gate_rates.csv (budget)")
test_mutated_gate_rates_campaign = _csv_property("gate_rates.csv (campaign)")
test_mutated_time_scans = _csv_property("time_scans.csv")
test_mutated_spectra = _csv_property("spectra.csv")
test_mutated_traces_csv = _csv_property("traces.csv")
test_mutated_trace_csv = _csv_property("trace file (.csv)")
test_mutated_sweep = _csv_property("sweep.csv")


# ----------------------------------------------------------------------------- harmless edits

_HARMLESS = st.lists(st.tuples(st.sampled_from(["crlf", "comment", "blank", "shuffle"]),
                               st.integers(0, 10**6), st.integers(0, 10**6), st.none()),
                     min_size=1, max_size=3)
_ORDERED = {"trace file (.csv)"}        # a trace's samples are in time order


@given(reader=st.sampled_from(sorted(set(READERS) - _ORDERED)), ops=_HARMLESS)
def test_harmless_edits_give_the_same_result(reader, ops):
    """CRLF, comment and blank lines, shuffled rows: the result of the original file."""
    key, fname, read, _ = READERS[reader]
    text = base_texts()[key]
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "campaign.json").write_text(base_texts()["campaign"])
        p = Path(d) / fname
        p.write_text(text)
        want = read(p)
        p.write_bytes(mutate_csv(text, ops))
        got = read(p)
    assert _canonical(got) == _canonical(want)


def _canonical(res):
    if isinstance(res, pd.DataFrame):
        return sorted(map(repr, res.astype(str).itertuples(index=False)))
    if isinstance(res, list):
        return sorted(res)
    return sorted(zip(res.A.tolist(), res.value.tolist()))


# ----------------------------------------------------------------------------- JSON files


@given(ops=json_mutations())
@example(ops=[("not_utf8", 0, None)])          # UnicodeDecodeError
@example(ops=[("set", 3, float("nan"))])       # 'powers' a number: TypeError
@example(ops=[("set", 7, 10**400)])            # OverflowError
def test_mutated_calibration_json(ops):
    data = mutate_json(json.loads(base_texts()["calibration"]), ops)

    def check(cal):
        amp = cal.amplitude
        assert np.isfinite(np.asarray(amp.coefficients, dtype=float)).all()
        assert np.isfinite(np.asarray(amp.covariance, dtype=float)).all()
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "calibration.json"
        p.write_bytes(data)
        outcome("calibration.json", p, lambda: load_calibration(p), check)
        assert p.read_bytes() == data


@given(ops=json_mutations())
@example(ops=[("not_utf8", 0, None)])          # UnicodeDecodeError
@example(ops=[("del", 0, None), ("set", 0, float("nan"))])   # NaN accepted as a constant
@example(ops=[("set", 2250, 1.8446744073709552e+19)])        # order 1.8e19 accepted
def test_mutated_campaign_json(ops):
    data = mutate_json(json.loads(base_texts()["campaign"]), ops)

    def check(folder):
        for k in ("nu_hz", "xi0_spectra_hz", "nbar_assumed", "eta_ref", "eta_ld", "order"):
            assert np.isfinite(float(folder.meta[k])), f"campaign.json {k} = {folder.meta[k]}"
        folder.table_run, folder.phase_run, folder.left_out()
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "campaign.json"
        p.write_bytes(data)
        outcome("campaign.json", p, lambda: CampaignFolder(d), check)
        assert p.read_bytes() == data


# ----------------------------------------------------------------------------- binary traces


@given(arr=hnp.arrays(dtype=st.sampled_from(["<f8", "<f4", "<i2", "<c8", "|b1", "<U3"]),
                      shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4)),
       ext=st.sampled_from([".npy", ".npz"]),
       scale=st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True)))
@example(arr=np.array([4.8e291]), ext=".npz", scale=3.7e16)   # inf samples returned as valid
def test_generated_binary_trace(arr, ext, scale):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"trace{ext}"
        if ext == ".npy":
            np.save(p, arr)
        else:
            np.savez(p, trace=arr, **({} if scale is None else {"scale": scale}))
        before = p.read_bytes()
        outcome("trace file (.npy/.npz)", p, lambda: load_trace(p),
                lambda x: (x.size > 0 and np.isfinite(x).all()) or _no("trace"))
        assert p.read_bytes() == before
