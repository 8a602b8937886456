"""``dpdfit add``: further recordings merged into a copy of a campaign, by the merge rules.

The cross-check the schedule's round trip relies on: the small campaign plus the rows of
its further recordings (as a lab's CSV files, and as ARTIQ results files through the
import) is exactly the campaign the simulator draws with those recordings
(:func:`~dpdfit.simulation.further_recordings.extend_config`), every column of every
table; CAMPAIGN is never written.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.cli.main import main
from dpdfit.recordings.add_merge import continued_labels
from dpdfit.recordings.campaign_add import add_recordings
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.simulation.campaign import campaign_hashes
from tests.helpers.further_campaign import (FURTHER, added_rows, lab_numbered, simulate,
                                            write_new_folder)

SOURCE = ["source_file", "source_rid"]


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """(campaign, the campaign with FURTHER, the rows FURTHER added per table)."""
    d = tmp_path_factory.mktemp("further")
    base, ext = simulate(d / "base"), simulate(d / "ext", FURTHER)
    return base, ext, added_rows(base, ext)


def _table(folder, t) -> pd.DataFrame:
    return pd.read_csv(folder / f"{t}.csv", dtype=str, keep_default_na=False)


def _same_as_simulated(out, ext, tables, order=True):
    """Every column of the simulator's tables equal in OUT (OUT adds only the source
    columns); ``order`` False: equal as sets of rows (the import groups some by file)."""
    for t in tables:
        want, got = _table(ext, t), _table(out, t)
        assert list(got.columns) == list(want.columns) + SOURCE, t
        got = got[list(want.columns)]
        if not order:
            want, got = (df.sort_values(list(df.columns)).reset_index(drop=True)
                         for df in (want, got))
        num = want.apply(pd.to_numeric, errors="coerce")
        pd.testing.assert_frame_equal(got.apply(pd.to_numeric, errors="coerce"), num,
                                      check_exact=True, obj=t)
        if "sideband" in want:
            assert got["sideband"].tolist() == want["sideband"].tolist()
        if "run" in want:
            assert got["run"].tolist() == want["run"].tolist()


def test_csv_rows_added_give_the_simulated_further_recordings_exactly(pair, tmp_path,
                                                                      capsys):
    base, ext, rows = pair
    new = write_new_folder(tmp_path / "new", lab_numbered(rows))
    before = campaign_hashes(base)
    out = tmp_path / "out"
    assert main(["add", str(base), str(new), "-o", str(out)]) == 0
    assert campaign_hashes(base) == before                 # CAMPAIGN untouched
    text = capsys.readouterr().out
    assert "+16 rows" in text and "dropped: truth.json" in text
    assert "scan labels continued at A=0.4, dpd=0: 1 -> 2, 2 -> 3" in text
    _same_as_simulated(out, ext, rows)
    # the campaign's own rows: the same text, in the same order, sources empty
    for t in rows:
        old = _table(base, t)
        got = _table(out, t)
        assert got.iloc[:len(old)][list(old.columns)].equals(old)
        assert (got.iloc[:len(old)][SOURCE] == "").all().all()
        assert (got.iloc[len(old):]["source_file"] == f"{t}.csv").all()
    # every other file copied unchanged; truth.json dropped
    copied = {k: v for k, v in before.items() if not k.endswith(".csv") or
              k[:-4] not in rows}
    copied.pop("campaign.json")
    assert copied.pop("truth.json")
    after = campaign_hashes(out)
    assert "truth.json" not in after and all(after[k] == v for k, v in copied.items())
    meta, old_meta = (json.loads((f / "campaign.json").read_text()) for f in (out, base))
    entry = meta.pop("added")[0]
    assert meta == old_meta
    assert entry["kind"] == "csv" and entry["from"] == str(new)
    n = len(_table(base, "parity"))
    assert entry["rows"]["parity"] == [n + 1, n + 16]
    src = {s["file"]: s for s in entry["sources"]}
    assert src["parity.csv"]["rows"] == {"parity": [[n + 1, n + 16]]}
    assert len(src["parity.csv"]["sha256"]) == 64 and src["parity.csv"]["rid"] is None


def test_artiq_results_files_added_give_the_simulated_recordings(pair, tmp_path):
    """NEW as ndscan results files (write_ndscan_campaign) and a mapping of the tables it
    holds: the import's rows, scans numbered 1, 2, ... by the import, continued by add."""
    pytest.importorskip("h5py")
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    base, ext, rows = pair
    gates = {t: rows[t] for t in ("spectra", "populations", "parity", "time_scans",
                                  "gate_rates")}
    src = tmp_path / "lab_tables"
    write_new_folder(src, lab_numbered(gates))
    for t in ("calibration_amplitude", "calibration_phase"):
        _table(base, t).iloc[:0].to_csv(src / f"{t}.csv", index=False)
    (src / "campaign.json").write_text((base / "campaign.json").read_text())
    lab = tmp_path / "lab"
    mapping = write_ndscan_campaign(src, lab)
    text = mapping.read_text()
    for t in ("calibration_amplitude", "calibration_phase"):     # no such files: unmapped
        head = text.index(f"\n[[{t}]]\n")
        text = text[:head] + text[text.index("\n\n", head):]
    mapping.write_text(text)
    before = campaign_hashes(base)
    added = add_recordings(base, mapping, added_at="2026-01-02T03:04:05")
    out = added.write(tmp_path / "out")
    assert campaign_hashes(base) == before
    _same_as_simulated(out, ext, ["parity", "time_scans", "gate_rates"])
    _same_as_simulated(out, ext, ["spectra", "populations"], order=False)
    entry = json.loads((out / "campaign.json").read_text())["added"][0]
    assert entry["kind"] == "mapping" and entry["added_at"] == "2026-01-02T03:04:05+00:00"
    assert len(entry["mapping_sha256"]) == 64
    files = sorted(p.relative_to(lab).as_posix() for p in lab.rglob("*.h5"))
    assert sorted(s["file"] for s in entry["sources"]) == files
    assert all(s["rid"] and s["start_time"] and s["rows"] for s in entry["sources"])
    par = _table(out, "parity")
    n = len(_table(base, "parity"))
    assert (par["source_rid"].iloc[n:] != "").all() and (par["source_rid"].iloc[:n] == "").all()
    assert added.to_dict()["rows_added"] == {t: len(gates[t]) for t in gates}


def test_a_run_already_there_is_skipped_and_said(pair, tmp_path, capsys):
    base, _, rows = pair
    old = _table(base, "calibration_amplitude")
    first = old[old["run"] == old["run"].iloc[0]]
    new = write_new_folder(tmp_path / "new", {"calibration_amplitude": pd.concat(
        [first, rows["calibration_amplitude"]], ignore_index=True)})
    out = tmp_path / "out"
    assert main(["add", str(base), str(new), "-o", str(out)]) == 0
    report = capsys.readouterr().out
    assert f"skipped: calibration_amplitude run {first['run'].iloc[0]} (41 rows)" in report
    got = _table(out, "calibration_amplitude")
    assert len(got) == len(old) + 41
    entry = json.loads((out / "campaign.json").read_text())["added"][0]
    assert entry["skipped"] and entry["rows"]["calibration_amplitude"] == [len(old) + 1,
                                                                           len(got)]
    # the new run gave the rows after the campaign's; the skipped run none
    assert entry["sources"][0]["rows"] == {"calibration_amplitude": [[len(old) + 1,
                                                                      len(got)]]}


def test_added_twice_the_scans_go_on_and_added_lists_both(pair, tmp_path):
    base, _, rows = pair
    new = write_new_folder(tmp_path / "new", {"populations": lab_numbered(rows)["populations"]})
    once = add_recordings(base, new).write(tmp_path / "once")
    twice = add_recordings(once, new).write(tmp_path / "twice")
    pop = CampaignFolder(twice).populations
    at = pop[(pop["A"] == 0.4) & (pop["dpd"] == 0)]
    assert at["scan"].tolist() == ["1", "2", "3", "4", "5"]
    assert len(json.loads((twice / "campaign.json").read_text())["added"]) == 2


def test_spectra_repeat_column_continues_per_tone(pair, tmp_path):
    base, _, rows = pair
    camp = tmp_path / "camp"
    import shutil
    shutil.copytree(base, camp)
    sp = _table(camp, "spectra")
    sp["repeat"] = (sp.groupby(["A", "dpd", "sideband", "n"]).cumcount() + 1).astype(str)
    sp.to_csv(camp / "spectra.csv", index=False)
    new = write_new_folder(tmp_path / "new", {"spectra": rows["spectra"]})
    out = add_recordings(camp, new).write(tmp_path / "out")
    got = CampaignFolder(out).spectra.iloc[len(sp):]
    assert set(got[got["A"] == 0.6]["repeat"]) == {"2"}       # 0.6 recorded before
    assert set(got[got["A"] == 0.3]["repeat"]) == {"1"}       # a new amplitude


def test_scan_labels_continue_property():
    """For random campaigns and new labels: every new label lies above the campaign's
    largest at its setting, a new scan keeps one label, distinct scans get the next
    labels m+1..m+k in their numeric order."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        keys = [(0.4, 0), (0.4, 1), (0.5, 0)]
        old_k = [keys[i] for i in rng.integers(0, 3, rng.integers(0, 8))]
        old_l = [str(v) for v in rng.integers(1, 9, len(old_k))]
        new_k = [keys[i] for i in rng.integers(0, 3, rng.integers(1, 12))]
        new_l = [str(v) for v in rng.integers(1, 6, len(new_k))]
        got = continued_labels(old_k, old_l, new_k, new_l)
        for key in set(new_k):
            m = max([int(x) for k, x in zip(old_k, old_l) if k == key], default=0)
            mine = sorted({int(x) for k, x in zip(new_k, new_l) if k == key})
            ren = {int(x): int(g) for k, x, g in zip(new_k, new_l, got) if k == key}
            assert len(ren) == len(mine)                       # one label per new scan
            assert [ren[x] for x in mine] == list(range(m + 1, m + 1 + len(mine)))


def test_the_report_names_a_few_renamed_scans_per_setting(pair, tmp_path, capsys):
    """A thousand scans added at one setting: the note names the first eight renamed and
    counts the others, one short line (a million rows stay a readable report)."""
    base, _, _ = pair
    new = tmp_path / "new"
    new.mkdir()
    (new / "populations.csv").write_text("A,dpd,scan,n00,n01_10,n11,n_even,shots\n" + "".join(
        f"0.4,0,{k},139,0,161,300,300\n" for k in range(1, 1001)))
    assert main(["add", str(base), str(new), "-o", str(tmp_path / "out")]) == 0
    notes = [line for line in capsys.readouterr().out.splitlines()
             if "scan labels continued at A=0.4, dpd=0" in line]
    assert len(notes) == 1
    assert notes[0].endswith(": 1 -> 2, 2 -> 3, 3 -> 4, 4 -> 5, 5 -> 6, 6 -> 7, 7 -> 8, "
                             "8 -> 9, ... and 992 more scans")
