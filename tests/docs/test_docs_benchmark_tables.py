"""The Benchmarks page's JSON files and the directive that renders them (fast).

``docs/_ext/benchmark_tables.py`` builds the tables of ``docs/benchmarks.md`` from
``benchmarks/*.json`` at documentation build time; ``benchmarks/record.py`` writes
those files.  These tests check that every file the page names can be rendered and
that the rendering of a record contains its rows -- without building the site.
"""

from __future__ import annotations

import datetime as dt
import glob
import importlib.util
import json
import re
from pathlib import Path

import pytest

from tests.helpers.paths import ROOT

DOCS = ROOT / "docs"
PAGE = DOCS / "benchmarks.md"
DIRECTIVE = re.compile(r"^```\{(benchmark-table|benchmark-history)\}\s+(\S+)\s*$", re.M)


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


bt = _load("benchmark_tables_under_test", DOCS / "_ext" / "benchmark_tables.py")
record = _load("benchmark_record_under_test", ROOT / "benchmarks" / "record.py")


def _page_files() -> list[Path]:
    files = []
    for kind, arg in DIRECTIVE.findall(PAGE.read_text(encoding="utf-8")):
        pattern = str((DOCS / arg).resolve())
        found = sorted(glob.glob(pattern)) if kind == "benchmark-history" else [pattern]
        assert found, f"{arg} matches no file"
        files += [Path(f) for f in found]
    return files


PAGE_FILES = _page_files()


def test_the_page_uses_the_directives():
    kinds = {k for k, _ in DIRECTIVE.findall(PAGE.read_text(encoding="utf-8"))}
    assert kinds == {"benchmark-table", "benchmark-history"}
    assert len(PAGE_FILES) >= 10


@pytest.mark.parametrize("path", PAGE_FILES, ids=lambda p: p.name)
def test_each_file_on_the_page_parses_and_has_what_the_directive_needs(path):
    assert path.is_file(), path
    raw = json.loads(path.read_text(encoding="utf-8"))
    rec = bt.load_record(path)
    assert rec["rows"] and all(isinstance(r, dict) for r in rec["rows"])
    assert rec["description"]
    if rec["kind"] == "record":
        for field in bt.RECORD_FIELDS:
            assert field in raw, f"{path.name}: no {field!r}"
        assert raw["benchmark"] == path.stem
        assert raw["command"].startswith(f"python benchmarks/{path.stem}.py")
        assert dt.datetime.fromisoformat(raw["date"]).utcoffset() == dt.timedelta(0)
        for key in ("platform", "processor", "cores", "python", "numpy", "dpdfit"):
            assert raw["machine"].get(key) is not None, f"{path.name}: machine lacks {key}"
    text = bt.record_nodes(rec, path.name)[0].astext()
    if rec["kind"] != "record" and not rec["machine"]:
        # an older report: says what it does not record, never invents it
        assert bt.NOT_RECORDED in text
    if rec["kind"] != "record":
        assert rec["date"] is None or "commit date" in text


def test_rendering_a_record_contains_its_rows_caption_and_tables(tmp_path):
    rows = [{"table": "speed", "method": "ours", "time [ms]": 1.23456, "ratio": 12.5,
             "target": "<= 2"},
            {"table": "speed", "method": "baseline", "time [ms]": 15.4, "ratio": None},
            {"table": "agreement", "quantity": "max |a - b|", "value": 1.1e-15}]
    rec = record.make_record("toy_bench", rows, description="A toy benchmark.",
                             notes=["a note"], argv=["benchmarks/toy_bench.py", "--json", "x"])
    path = record.write_json(tmp_path / "toy_bench.json", rec)
    loaded = bt.load_record(path)
    (box,) = bt.record_nodes(loaded, "benchmarks/toy_bench.json")
    text = box.astext()
    for needle in ("A toy benchmark.", "python benchmarks/toy_bench.py --json x",
                   "benchmarks/toy_bench.json", loaded["machine"]["processor"],
                   bt.format_date(rec["date"]), "ours", "baseline", "1.235", "15.4", "12.5",
                   "<= 2", "max |a - b|", "1.10e-15", "a note", "time [ms]"):
        assert needle in text, needle
    tables = list(box.findall(bt.nodes.table))
    assert [t.children[0].astext() for t in tables] == ["speed", "agreement"]
    # one body row per record row, one entry per column
    speed_rows = list(tables[0].findall(bt.nodes.row))
    assert len(speed_rows) == 3                      # header + 2
    assert all(len(r.children) == 4 for r in speed_rows)


def test_a_committed_record_renders_every_row():
    path = next((p for p in PAGE_FILES if p.name == "counts_speed.json"), None)
    if path is None:
        pytest.skip("counts_speed.json not on the page")
    rec = bt.load_record(path)
    text = bt.record_nodes(rec, path.name)[0].astext()
    for row in rec["rows"]:
        for key, value in row.items():
            if key != "table" and value is not None:
                assert bt.fmt(value) in text, (key, value)


def test_a_report_without_machine_or_date_says_so(tmp_path):
    report = {"named_correctly_overall": 0.5, "confusion": {"none": {"none": 2}},
              "n_runs": 2, "false_alarm_rate": 0.0}
    path = tmp_path / "harness_report_x.json"
    path.write_text(json.dumps(report))
    rec = bt.load_record(path)
    text = bt.record_nodes(rec, path.name)[0].astext()
    assert bt.NOT_RECORDED in text and "Command" in text and "not recorded" in text
    assert "50" in text                       # named correctly, in percent


def test_atomic_write_leaves_no_temporary_file(tmp_path):
    record.write_json(tmp_path / "r.json", {"x": float("nan"), "y": [1.5]})
    assert [p.name for p in tmp_path.iterdir()] == ["r.json"]
    assert json.loads((tmp_path / "r.json").read_text()) == {"x": None, "y": [1.5]}
