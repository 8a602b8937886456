"""The round trip every characterisation experiment's ARTIQ tests share: a campaign's own
table written as ARTIQ results files (``dpdfit write-artiq-results``) and imported back
(``dpdfit import``) exactly, the new files counted where a schedule's recordings continue."""

from __future__ import annotations

import pandas as pd

from dpdfit.cli.main import main
from dpdfit.simulation.campaign import simulate_campaign
from dpdfit.simulation.recorded_artiq import campaign_files_end, read_campaign_tables


def cli_ok(args, capsys) -> str:
    """``dpdfit <args>`` in this process, which must succeed; its stdout."""
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out


def own_table_round_trip(cfg, tmp_path, capsys, table: str, experiment: str,
                         dtype: dict | None = None, check_dtype: bool = True) -> None:
    """Simulate the campaign ``cfg`` (which records ``table``), write it as ARTIQ results
    files, import them: ``table`` comes back exactly (``check_dtype`` False where a whole
    number is written back as a float), its experiment's files (``experiment``, the class
    name in the file names) are the last ones, and the files a schedule's recordings
    continue after are all of them."""
    folder = tmp_path / "campaign"
    simulate_campaign(folder, config=cfg, progress=False)
    lab, imported = tmp_path / "lab", tmp_path / "imported"
    cli_ok(["write-artiq-results", folder, lab], capsys)
    cli_ok(["import", lab / "mapping.toml", "-o", imported], capsys)
    want = pd.read_csv(folder / f"{table}.csv", dtype=dtype)
    got = pd.read_csv(imported / f"{table}.csv", dtype=dtype)
    pd.testing.assert_frame_equal(got[list(want.columns)], want, check_exact=True,
                                  check_dtype=check_dtype)
    files = sorted(lab.glob("results/*/*/*.h5"))
    assert files[-1].name.endswith(f"-{experiment}.h5")
    tables, meta = read_campaign_tables(folder)
    assert campaign_files_end(tables, meta)[0] == len(files)
