"""Recording times in campaign.json: bad values are refused in one line naming the key,
and nothing is written into the campaign folder."""

import json
import shutil
from pathlib import Path

import pytest

from dpdfit.cli.main import main
from tests.helpers.paths import ROOT

BUNDLED = ROOT / "datasets" / "synthetic_campaign"


def _snapshot(folder: Path) -> dict:
    return {p.relative_to(folder): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@pytest.mark.parametrize("times, key", [
    ({"spectra_recorded": "the day before yesterday"}, "spectra_recorded"),
    ({"gates_recorded": 20251122}, "gates_recorded"),
    ({"spectra_recorded": "2025-11-22T15:00:00+00:00",
      "gates_recorded": "2025-11-22T13:00:00+00:00"}, "gates_recorded"),
    ({"spectra_recorded": "2031-01-01T00:00:00+00:00",
      "gates_recorded": "2031-01-01T02:00:00+00:00"}, "spectra_recorded"),
])
def test_bad_recording_time_is_refused_naming_the_key(tmp_path, capsys, times, key):
    folder = tmp_path / "campaign"
    shutil.copytree(BUNDLED, folder, ignore=shutil.ignore_patterns("traces", "*.npz"))
    meta = json.loads((folder / "campaign.json").read_text())
    meta.pop("spectra_recorded", None)
    meta.pop("gates_recorded", None)
    meta.update(times)
    (folder / "campaign.json").write_text(json.dumps(meta))
    before = _snapshot(folder)
    assert main(["diagnose", str(folder)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert f"'{key}'" in err[0] and "campaign.json" in err[0]
    assert _snapshot(folder) == before
