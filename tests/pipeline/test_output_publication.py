"""Outputs: one publication, checked before work, a rerun clears what it owned.

Every output of a command -- tables, JSON, figures -- is staged and published
in one step; Ctrl-C before or during that step leaves the previous results
exactly as they were; output paths are checked before any work; files are
created with the permissions the umask gives; a rerun of ``analyze`` into a
used results folder deletes what the previous run wrote and this one did not,
and nothing else.
"""

import json
import os
import signal
from pathlib import Path

import pandas as pd
import pytest

import dpdfit.recordings.outputs as outputs
from dpdfit.cli.main import main
from dpdfit.errors import InputError
from dpdfit.pipeline.analysis import Analysis, previous_outputs
from dpdfit.recordings.outputs import (atomic_write_text, check_output_file,
                                       check_output_folder, staged_outputs)
from tests.helpers.paths import ROOT

AMP = ROOT / "datasets" / "synthetic_aom" / "calibration_amplitude.csv"
CAMP = ROOT / "datasets" / "synthetic_campaign"


def _snapshot(folder: Path) -> dict:
    """Every file under ``folder`` (hidden temporaries included) -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _one_error_line(capsys, code):
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and err[0].startswith("dpdfit: error:"), err
    return err[0]


# ------------------------------------------------------------------ staging
def test_nested_stages_publish_together_at_the_outer_end(tmp_path):
    with staged_outputs() as outer:
        outer(tmp_path / "a.txt").write_text("a")
        atomic_write_text(tmp_path / "b.txt", "b")  # joins the outer publication
        assert not (tmp_path / "a.txt").exists() and not (tmp_path / "b.txt").exists()
    assert (tmp_path / "a.txt").read_text() == "a" and (tmp_path / "b.txt").read_text() == "b"


def test_interrupt_while_staging_leaves_nothing(tmp_path):
    (tmp_path / "old.txt").write_text("old")
    before = _snapshot(tmp_path)
    with pytest.raises(KeyboardInterrupt):
        with staged_outputs() as stage:
            stage(tmp_path / "old.txt").write_text("new")
            stage(tmp_path / "new" / "deep" / "x.txt").write_text("x")
            raise KeyboardInterrupt
    assert _snapshot(tmp_path) == before
    assert not (tmp_path / "new").exists()  # the folders made for the outputs are gone too


def test_sigint_during_publication_is_held_until_every_file_is_in_place(tmp_path, monkeypatch):
    real_replace = os.replace
    calls = []
    # the handler in place before (Python's default, or SIG_IGN when the test runner
    # was started in the background) is the one put back
    before = signal.getsignal(signal.SIGINT)

    def replace_then_interrupt(src, dst):
        real_replace(src, dst)
        calls.append(dst)
        if len(calls) == 1:
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C after the first of three files

    monkeypatch.setattr(outputs.os, "replace", replace_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        with staged_outputs() as stage:
            for name in ("a", "b", "c"):
                stage(tmp_path / name).write_text(name)
    assert len(calls) == 3
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == {"a": "a", "b": "b", "c": "c"}
    assert signal.getsignal(signal.SIGINT) is before


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_outputs_get_the_mode_the_umask_gives(tmp_path, mask, mode):
    old = os.umask(mask)
    try:
        atomic_write_text(tmp_path / "out.txt", "x")
    finally:
        os.umask(old)
    assert (tmp_path / "out.txt").stat().st_mode & 0o777 == mode


def test_output_paths_are_checked(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="existing file"):
        check_output_folder(tmp_path / "file")
    with pytest.raises(InputError, match="is a file"):
        check_output_folder(tmp_path / "file" / "sub")
    with pytest.raises(InputError, match="existing folder"):
        check_output_file(tmp_path)
    with pytest.raises(InputError, match="is a file"):
        check_output_file(tmp_path / "file" / "out.csv")
    check_output_folder(tmp_path / "new" / "deeper")  # may be made later
    check_output_file(tmp_path / "new" / "out.csv")
    assert not (tmp_path / "new").exists()  # a check makes nothing


# ------------------------------------------------------------------ analyze's results folder
class _Fig:
    """Stands in for a matplotlib Figure: writes its label, or raises."""

    def __init__(self, label, fail=None):
        self.label, self.fail = label, fail

    def savefig(self, path, dpi, format):
        if self.fail is not None:
            raise self.fail
        Path(path).write_text(f"{self.label} {dpi} {format}")


def _analysis(tmp_path, files, figures):
    summary = {"analyses": {"gates": {"status": "ok" if "gate.csv" in files else "skipped",
                                      "detail": ""}}, "failures": []}
    jobs = [(lambda: figures, 100)] if figures is not None else None
    return Analysis(tmp_path, summary, files, {}, "exact", figures=jobs)


GATE = ("csv", pd.DataFrame({"A": [0.5], "F": [0.99]}), {"source": "test"})


def test_rerun_deletes_what_the_previous_run_owned_and_nothing_else(tmp_path):
    out = tmp_path / "results"
    first = {"gate.csv": GATE, "alignment_points.csv": GATE, "budget.json": "{}\n"}
    _analysis(tmp_path, first, {"fig3": _Fig("3"), "fig4": _Fig("4")}).save(out)
    (out / "notes.txt").write_text("the user's")
    (out / "figures" / "mine.png").write_text("the user's")
    assert previous_outputs(out) == {"gate.csv", "alignment_points.csv", "budget.json",
                                     "figures/fig3.png", "figures/fig4.png",
                                     "summary.json", "summary.md"}
    _analysis(tmp_path, {"budget.json": "{}\n"}, {"fig4": _Fig("4")}).save(out)
    assert sorted(_snapshot(out)) == ["budget.json", "figures/fig4.png", "figures/mine.png",
                                      "notes.txt", "summary.json", "summary.md"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["analyses"]["gates"]["status"] == "skipped"
    assert summary["outputs"] == ["budget.json", "figures/fig4.png", "summary.json",
                                  "summary.md"]


def test_rerun_over_a_summary_without_outputs_deletes_nothing(tmp_path):
    """A results folder whose summary.json lists no outputs owns nothing: a rerun
    writes its files and leaves every other file alone."""
    out = tmp_path / "results"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"analyses": {}}))
    for name in ("gate.csv", "alignment_points.csv", "mine.csv"):
        (out / name).write_text("old")
    assert previous_outputs(out) == set()
    _analysis(tmp_path, {"budget.json": "{}\n"}, None).save(out)
    assert sorted(_snapshot(out)) == ["alignment_points.csv", "budget.json", "gate.csv",
                                      "mine.csv", "summary.json", "summary.md"]


def test_a_folder_without_a_dpdfit_summary_owns_nothing(tmp_path):
    out = tmp_path / "results"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"mine": 1, "outputs": ["gate.csv"]}))
    (out / "gate.csv").write_text("the user's")
    assert previous_outputs(out) == set()
    (out / "summary.json").write_text(json.dumps({"analyses": {}, "outputs": ["../x", "/etc/y"]}))
    assert previous_outputs(out) == set()


@pytest.mark.parametrize("where", ["drawing", "writing"])
def test_interrupted_save_leaves_the_previous_results_exactly(tmp_path, where):
    out = tmp_path / "results"
    first = {"gate.csv": GATE, "budget.json": "{}\n"}
    _analysis(tmp_path, first, {"fig3": _Fig("3"), "fig4": _Fig("4")}).save(out)
    before = _snapshot(out)
    if where == "drawing":
        def figures():
            raise KeyboardInterrupt
        second = Analysis(tmp_path, {"analyses": {}}, {"budget.json": "[]\n"}, {}, "exact",
                          figures=[(figures, 100)])
    else:
        second = _analysis(tmp_path, {"budget.json": "[]\n"},
                           {"fig3": _Fig("3b"), "fig4": _Fig("4b", fail=KeyboardInterrupt())})
    with pytest.raises(KeyboardInterrupt):
        second.save(out)
    assert _snapshot(out) == before


# ------------------------------------------------------------------ the command line
def test_analyze_into_an_input_file_fails_before_any_work(tmp_path, capsys, monkeypatch):
    import dpdfit.pipeline.analyze as an

    def no_work(*a, **k):
        raise AssertionError("analysis started")

    monkeypatch.setattr(an, "_analysis", no_work)
    before = (CAMP / "spectra.csv").read_bytes()
    line = _one_error_line(capsys, main(["analyze", str(CAMP), "-o", str(CAMP / "spectra.csv")]))
    assert "spectra.csv" in line and "existing file" in line
    assert (CAMP / "spectra.csv").read_bytes() == before
    (tmp_path / "figures").mkdir()
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "figures").write_text("a file")
    line = _one_error_line(capsys, main(["analyze", str(CAMP), "-o", str(tmp_path / "res")]))
    assert "figures" in line


def test_plot_pointing_at_a_file_fails_before_the_main_output(tmp_path, capsys):
    (tmp_path / "figs").write_text("a file")
    out = tmp_path / "c.json"
    line = _one_error_line(capsys, main(["calibrate", "--amplitude", str(AMP), "-o", str(out),
                                         "--plot", str(tmp_path / "figs")]))
    assert "--plot" in line and "figs" in line
    assert not out.exists()


def test_output_in_a_missing_place_fails_before_work(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    line = _one_error_line(capsys, main(["calibrate", "--amplitude", str(AMP),
                                         "-o", str(tmp_path / "f" / "c.json")]))
    assert "c.json" in line


def test_plot_command_publishes_output_and_figures_together(tmp_path, capsys, monkeypatch):
    import dpdfit.report.calibration_plots as cp

    def broken(*a, **k):
        raise InputError("figure failed")

    monkeypatch.setattr(cp, "calibration_figures", broken)
    out = tmp_path / "c.json"
    out.write_text("previous")
    line = _one_error_line(capsys, main(["calibrate", "--amplitude", str(AMP), "-o", str(out),
                                         "--plot", str(tmp_path / "figs")]))
    assert "figure failed" in line
    assert out.read_text() == "previous" and not (tmp_path / "figs").exists()
