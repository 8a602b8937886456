"""ARTIQ results files (ndscan scans) imported into a campaign folder by a mapping.

The files are written as ARTIQ and ndscan write them
(:mod:`dpdfit.simulation.artiq_results`) from the bundled campaign, in two
shapes; importing them back must give the bundled tables.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("h5py")

from dpdfit.recordings.artiq import read_results_file  # noqa: E402
from dpdfit.recordings.campaign_import import import_campaign  # noqa: E402
from dpdfit.simulation.artiq_results import (write_ndscan_campaign,  # noqa: E402
                                             write_per_shot_campaign)
from tests.helpers.paths import ROOT  # noqa: E402

BUNDLED = ROOT / "datasets" / "synthetic_campaign"
TABLES = ("calibration_amplitude", "calibration_phase", "spectra", "populations", "parity",
          "time_scans", "gate_rates")
#: the columns that identify a row of each table (rows may come in another order)
KEYS = {"calibration_amplitude": ["run", "A"], "calibration_phase": ["run", "A"],
        "spectra": ["A", "dpd", "sideband", "n"], "populations": ["A", "dpd", "scan"],
        "parity": ["A", "dpd", "scan", "phase_rad"], "time_scans": ["A", "dpd", "t_us"],
        "gate_rates": ["A", "dpd"]}


@pytest.fixture(scope="module")
def ndscan_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("ndscan_set")
    return write_ndscan_campaign(BUNDLED, out)


@pytest.fixture(scope="module")
def per_shot_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("per_shot_set")
    return write_per_shot_campaign(BUNDLED, out, seed=3)


def _bundled(table: str) -> pd.DataFrame:
    return pd.read_csv(BUNDLED / f"{table}.csv", comment="#")


def _same_rows(table: str, got: pd.DataFrame, want: pd.DataFrame, rtol: float = 0.0):
    assert len(got) == len(want), table
    keys = KEYS[table]
    got = got.sort_values(keys, kind="stable").reset_index(drop=True)
    want = want.sort_values(keys, kind="stable").reset_index(drop=True)
    for col in want.columns:
        g, w = got[col].to_numpy(), want[col].to_numpy()
        if w.dtype.kind in "fiu" and rtol:
            np.testing.assert_allclose(g, w, rtol=rtol, atol=0, err_msg=f"{table}.{col}")
        else:
            assert np.array_equal(g, w), f"{table}.{col} differs"


def test_ndscan_files_import_to_the_bundled_tables_bit_for_bit(ndscan_set, tmp_path):
    imp = import_campaign(ndscan_set)
    assert set(imp.tables) == set(TABLES) and not imp.warnings
    for t in TABLES:
        _same_rows(t, imp.tables[t], _bundled(t))
    meta = dict(imp.meta)
    meta.pop("imported")
    assert meta == json.loads((BUNDLED / "campaign.json").read_text())
    imp.write(tmp_path / "campaign")
    for t in TABLES:                         # and so does the written folder
        _same_rows(t, pd.read_csv(tmp_path / "campaign" / f"{t}.csv"), _bundled(t))


def test_per_shot_files_import_to_the_bundled_tables(per_shot_set):
    """Counts from per-shot outcomes, phases in turns, the amplitude an argument, gate
    rates as plain datasets, an old ndscan root: counts identical; phases to 1e-15."""
    imp = import_campaign(per_shot_set, complete_only=True)
    assert len(imp.skipped) == 1 and "did not complete" in imp.skipped[0]
    for t in TABLES:
        _same_rows(t, imp.tables[t], _bundled(t), rtol=1e-15 if t == "parity" else 0.0)


def test_an_interrupted_scan_is_imported_with_a_warning(per_shot_set, caplog):
    imp = import_campaign(per_shot_set)
    assert len(imp.warnings) == 1 and "did not complete" in imp.warnings[0]
    extra = len(imp.tables["parity"]) - len(_bundled("parity"))
    assert extra == 8                       # half of the 16 phases of one more scan
    last = imp.tables["parity"].iloc[-extra:]
    assert (last["scan"] == _bundled("parity")["scan"].max() + 1).all()
    # the library only returns it: the command line prints it once, after writing
    assert "did not complete" not in caplog.text


def test_every_row_names_its_results_file_and_campaign_json_their_hashes(ndscan_set):
    imp = import_campaign(ndscan_set)
    sources = {s["file"]: s for s in imp.meta["imported"]["sources"]}
    for t, df in imp.tables.items():
        for f, rid in df[["source_file", "source_rid"]].drop_duplicates().itertuples(index=False):
            assert sources[f]["rid"] == rid and t in sources[f]["tables"]
    for f, s in sources.items():
        assert hashlib.sha256((ndscan_set.parent / f).read_bytes()).hexdigest() == s["sha256"]


def test_the_reader_gives_provenance_units_and_points(ndscan_set):
    path = sorted(ndscan_set.parent.glob("results/*/*/*TimeScan*.h5"))[0]
    rf = read_results_file(path)
    assert rf.run.rid is not None and rf.run.start_time.tzname() == "UTC"
    assert rf.run.expid["class_name"] and "amplitude" in rf.run.arguments
    scan = rf.scan()
    dur = scan.axis("duration")
    assert (dur.unit, dur.scale) == ("us", 1e-6)
    pts = scan.points(shown=True)
    assert pts["duration"].max() > 1                  # shown in us, stored in s
    assert scan.points()["duration"].max() < 1e-3
    assert len(pts) == scan.n_points and scan.completed is True


@pytest.mark.slow
def test_analyze_takes_the_mapping_and_matches_the_csv_campaign(ndscan_set, tmp_path, capsys):
    """``dpdfit analyze MAP.toml``: the same analysis outputs as the CSV campaign
    (compare_analyze's rules; the inputs' paths and hashes aside).  Traces are not
    imported, so the CSV campaign is taken without them."""
    import importlib.util
    import shutil

    from dpdfit.cli.main import main
    spec = importlib.util.spec_from_file_location("compare_analyze",
                                                  ROOT / "scripts" / "compare_analyze.py")
    compare_analyze = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(compare_analyze)
    ref = tmp_path / "csv"
    shutil.copytree(BUNDLED, ref, ignore=shutil.ignore_patterns("traces*"))
    opts = ["--no-plots", "--no-diagnosis", "--no-progress"]
    assert main(["analyze", str(ref), "-o", str(tmp_path / "res_csv"), *opts]) == 0
    assert main(["analyze", str(ndscan_set), "-o", str(tmp_path / "res_imp"), *opts]) == 0
    kept = tmp_path / "res_imp" / "imported_campaign"
    assert (kept / "campaign.json").exists()
    shutil.rmtree(kept)
    assert compare_analyze.compare(tmp_path / "res_csv", tmp_path / "res_imp",
                                   inputs_differ=True) == []


def test_a_spectrum_recorded_again_round_trips_as_repeated_rows(tmp_path):
    """A campaign whose spectra at A = 0.5 were recorded twice more, one time scan again
    with other shots and one gate rate calibrated again: written as ARTIQ results (a
    further run per repeat) and imported back, its tables have the same repeated rows in
    the same order of each setting, and the campaign folder pools them."""
    src = tmp_path / "camp"
    src.mkdir()
    for name in [f"{t}.csv" for t in TABLES] + ["campaign.json"]:
        (src / name).write_bytes((BUNDLED / name).read_bytes())
    sp = _bundled("spectra")
    again = []
    for j in (1, 2):
        r = sp[sp.A == 0.5].copy()
        r["P_dB"] = np.round(r["P_dB"] + 0.3 * j + 0.01 * np.arange(len(r)), 8)
        again.append(r)
    want = {"spectra": pd.concat([sp, *again], ignore_index=True)}
    ts = _bundled("time_scans")
    scan = ts[(ts.A == ts.A.iloc[0]) & (ts.dpd == ts.dpd.iloc[0])].copy()
    for c in ("n01_10", "n11"):                          # the same scan with 400 shots
        scan[c] = (scan[c] * 400 / scan["shots"]).round().astype(int)
    scan["n00"], scan["shots"] = 400 - scan["n01_10"] - scan["n11"], 400
    want["time_scans"] = pd.concat([ts, scan], ignore_index=True)
    rates = _bundled("gate_rates")
    again_rate = rates.iloc[[1]].assign(xi0_khz=rates["xi0_khz"].iloc[1] * 1.002)
    want["gate_rates"] = pd.concat([rates, again_rate], ignore_index=True)
    for table, df in want.items():
        df.to_csv(src / f"{table}.csv", index=False)
    for shape, write in (("ndscan", write_ndscan_campaign),
                         ("per_shot", lambda c, o: write_per_shot_campaign(c, o, seed=3))):
        imp = import_campaign(write(src, tmp_path / shape), complete_only=True)
        for table, df in want.items():                   # stable order: repeats in order
            _same_rows(table, imp.tables[table], df)
        from dpdfit.recordings.campaign_folder import CampaignFolder
        cf = CampaignFolder(imp.write(tmp_path / f"{shape}_campaign"))
        pooled = cf.pooled_spectra
        assert len(pooled) == len(sp)
        assert set(pooled.loc[pooled.A == 0.5, "n_repeats"]) == {3}
        assert len(cf.time_scans) == len(ts) and cf.time_scans["n_repeats"].max() == 2
        assert len(cf.gate_rates) == len(rates) and cf.gate_rates["n_repeats"].iloc[1] == 2
