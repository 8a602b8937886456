"""A SPAM characterisation through ARTIQ results files and back: a schedule's ``spam`` rows
recorded by the simulator standing in for the lab (``dpdfit write-artiq-results
--schedule``), imported by the shipped ndscan mapping's ``[[spam]]`` (``dpdfit import``)
into ``spam.csv``, every count as recorded; a campaign's own ``spam.csv`` the same way;
a SPAM mapping naming a state that does not exist refused in one line."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from dpdfit.cli.main import main
from dpdfit.errors import InputError
from dpdfit.recordings.mapping import read_mapping
from dpdfit.recordings.schedule import read_schedule, write_schedule
from dpdfit.simulation.artiq_results import MAPPINGS
from dpdfit.simulation.campaign import CampaignConfig, simulate_campaign
from dpdfit.simulation.further_recordings import (default_menu, random_menu_choice,
                                                  schedule_measurements)
from dpdfit.simulation.ndscan_lab import spam_code, spam_runs
from dpdfit.simulation.recorded_schedule import record_further
from tests.helpers.artiq_round_trip import cli_ok as _cli, own_table_round_trip
from tests.helpers.standin import SMALL

pytest.importorskip("h5py")

#: the spam rows of the schedule: two recordings of 400 shots a state, one of 900
_SPAM = [(1, 400), (2, 400), (3, 900)]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """The small campaign without gate recordings (fast), and a schedule of an amplitude
    run (so that the new recordings' mapping is a whole campaign's: ``dpdfit import``
    takes it) and three SPAM recordings."""
    root = tmp_path_factory.mktemp("spam_artiq")
    folder = root / "campaign"
    simulate_campaign(folder, config=SMALL, progress=False, include_gates=False)
    grid = np.round(np.linspace(0.0, 1.0, SMALL.cal_points), 10)
    rows = [{"kind": "amplitude_run", "repeat": 1, "point": i, "A": a, "lab_s": 1.0}
            for i, a in enumerate(grid)]
    rows += [{"kind": "spam", "repeat": r, "point": i, "A": 0.0, "shots": n,
              "prepared": s, "lab_s": 0.8} for r, n in _SPAM for i, s in enumerate(("00", "11"))]
    schedule = root / "schedule.csv"
    write_schedule(pd.DataFrame(rows), schedule)
    return folder, schedule


def test_scheduled_spam_recorded_as_artiq_results_imports_as_recorded(campaign, tmp_path,
                                                                     capsys):
    folder, schedule = campaign
    lab, imported = tmp_path / "lab", tmp_path / "imported"
    printed = _cli(["write-artiq-results", folder, lab, "--schedule", schedule], capsys)
    assert "6 spam rows" in printed
    files = sorted(p.name for p in lab.glob("results/*/*/*.h5"))
    # one run per recording of the prepared states, after the amplitude run
    assert [f.split("-", 1)[1] for f in files] == ["AmplitudeCalibration.h5"] + [
        "SpamCharacterisation.h5"] * 3
    mapping = read_mapping(lab / "mapping.toml")
    assert [s.table for s in mapping.sources] == ["calibration_amplitude", "spam"]
    _cli(["import", lab / "mapping.toml", "-o", imported], capsys)

    # what the simulator records with the schedule's measurements, to the last count
    cfg = CampaignConfig.from_truth(json.loads((folder / "truth.json").read_text()))
    want = record_further(cfg, schedule_measurements(read_schedule(schedule))).tables["spam"]
    got = pd.read_csv(imported / "spam.csv", dtype={"prepared": str})
    assert got["prepared"].tolist() == ["00", "11"] * 3
    assert got["shots"].tolist() == [n for _, n in _SPAM for _ in range(2)]
    pd.testing.assert_frame_equal(got[list(want.columns)], want, check_exact=True,
                                  check_dtype=False)
    # each recording's rows came from one results file, in the order recorded
    assert got["source_rid"].tolist() == [r for r in sorted(set(got["source_rid"]))
                                          for _ in range(2)]
    # the imported campaign reads its spam.csv: the three recordings pooled per state
    from dpdfit.recordings.campaign_folder import CampaignFolder
    pooled = CampaignFolder(imported).spam
    assert pooled["shots"].tolist() == [1700.0, 1700.0]
    assert pooled["n_repeats"].tolist() == [3, 3]


def test_a_campaigns_own_spam_written_whole_and_imported_back(tmp_path, capsys):
    """``dpdfit write-artiq-results`` of a campaign with spam.csv (its SPAM recordings after
    its gate runs) and ``dpdfit import``: spam.csv back exactly; the rids the new
    recordings of a schedule continue after count those files."""
    cfg = dataclasses.replace(SMALL, spam_shots=1000)
    own_table_round_trip(cfg, tmp_path, capsys, "spam", "SpamCharacterisation",
                         dtype={"prepared": str})


def test_the_mapping_written_for_a_campaign_without_spam_has_no_spam_source(tmp_path):
    """The shipped mapping's [[spam]] (its glob would match no file) is left out."""
    from dpdfit.simulation.artiq_results import write_ndscan_campaign
    from tests.helpers.bundled_data import CAMPAIGN
    import tomllib
    assert "spam" in tomllib.loads((MAPPINGS / "ndscan_campaign.toml").read_text())
    mapping = write_ndscan_campaign(CAMPAIGN, tmp_path / "lab")
    text = mapping.read_text()
    assert "spam" not in tomllib.loads(text) and "SpamCharacterisation" not in text
    assert text.endswith('xi0_err_khz = { channel = "xi0_err" }\n')     # as it ended before


def _spam_mapping(tmp_path, prepared: str):
    text = (MAPPINGS / "ndscan_campaign.toml").read_text()
    head, spam = text.split("\n[[spam]]")
    new = spam.replace(
        'prepared = { axis = "prepared", labels = { 0 = "00", 1 = "01", 2 = "10", 3 = "11" } }',
        prepared)
    assert new != spam
    path = tmp_path / "mapping.toml"
    path.write_text(head + "\n[[spam]]" + new)
    return path


def test_a_prepared_label_that_does_not_exist_is_one_line(tmp_path, capsys):
    path = _spam_mapping(tmp_path, 'prepared = { axis = "prepared", labels = { 0 = "00", '
                                   '3 = "12" } }')
    with pytest.raises(InputError) as exc:
        read_mapping(path)
    msg = str(exc.value)
    assert len(msg.splitlines()) == 1
    line = next(i for i, s in enumerate(path.read_text().splitlines(), 1)
                if s.startswith("prepared ="))
    assert f"key 'spam[1].columns.prepared.labels' (line {line})" in msg
    assert 'prepared state "12" does not exist' in msg and '"00", "01", "10", "11"' in msg
    # through the command line: exit 2, one line, nothing written
    assert main(["import", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "does not exist" in err, err
    assert not (tmp_path / "out").exists()
    # a constant state is checked as well; a number is not a state's text
    for bad, why in (('prepared = "2"', 'prepared state "2" does not exist'),
                     ('prepared = 11', "a prepared state is text")):
        with pytest.raises(InputError, match=why):
            read_mapping(_spam_mapping(tmp_path, bad))


def test_a_recorded_code_without_a_label_is_one_line(campaign, tmp_path, capsys):
    """The files hold |11> (code 3); a mapping labelling only 0 refuses it, naming the
    results file, not importing a row of no state."""
    folder, schedule = campaign
    lab = tmp_path / "lab"
    _cli(["write-artiq-results", folder, lab, "--schedule", schedule], capsys)
    text = (lab / "mapping.toml").read_text()
    full = '{ 0 = "00", 1 = "01", 2 = "10", 3 = "11" }'
    assert full in text
    (lab / "mapping.toml").write_text(text.replace(full, '{ 0 = "00" }'))
    assert main(["import", str(lab / "mapping.toml"), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "SpamCharacterisation.h5" in err and "code 3 has no label" in err, err


def test_spam_runs_split_where_a_lab_would_begin_a_run():
    rows = pd.DataFrame({"prepared": ["00", "11", "00", "11", "01", "00", "11"],
                         "shots": [5, 5, 5, 5, 5, 7, 7]})
    assert spam_code(["00", "01", "10", "11", "|11>", 0, 11]).tolist() == [0, 1, 2, 3, 3, 0, 3]
    runs = spam_runs(rows)
    assert [r.index.tolist() for r in runs] == [[0, 1], [2, 3, 4], [5, 6]]
    assert spam_runs(rows.iloc[:0]) == []


def test_spam_on_a_menu_is_drawn_the_default_menu_has_none():
    cfg = SMALL
    rng = np.random.default_rng(3)
    assert "spam" not in {m["what"] for m in default_menu(rng, cfg)}
    picks = [random_menu_choice(rng, {"what": "spam", "menu": ["spam", "phase_run"]}, cfg)
             for _ in range(200)]
    spam = [p for p in picks if p["what"] == "spam"]
    assert 60 < len(spam) < 140
    assert all(p["settings"] == {"shots": 625} for p in spam)
