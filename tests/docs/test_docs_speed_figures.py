"""No speed figure is typed into the documentation, the README or ``--help``.

Timings, rates, speed ratios and memory figures change with every release and every
machine; typed by hand they go stale and contradict each other.  The documentation
cites them from the benchmark records with the ``benchmark`` role
(``docs/_ext/benchmark_values.py``), read when the site is built.  This module

* scans ``docs/**/*.md`` (not the changelog), the Markdown cells of the notebooks in
  ``docs/examples/``, ``README.md`` and every ``dpdfit ... --help`` text for a number with a unit of time, rate or memory, a speed ratio or a
  clock time, and fails on any not in ``ALLOWED`` (each listed with its reason:
  physics quantities, fixed parameters, targets -- none is a measurement of dpdfit's
  speed);
* checks that every ``benchmark`` role in the pages names a value that exists;
* checks the README's time range for its first command against the newest record of
  that command (``benchmarks/analyze_wall.json``, written by
  ``benchmarks/analyze_wall.py``).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from tests.helpers.paths import ROOT

DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

from benchmark_values import lookup, parse  # noqa: E402

ROLE = re.compile(r"\{benchmark\}`([^`]*)`")
_NUM = r"(?<![\w.])\d[\d,.]*(?:\s*(?:-|–|to)\s*\d[\d,.]*)?"
_WORDS = (r"\b(?:(?:one|two|three|four|five|ten|a few|several)\s+(?:seconds?|minutes?|hours?)"
          r"|(?:a|an|half an)\s+(?:minute|hour))\b")
SPEED_FIGURE = re.compile(
    "|".join([
        # a number with a unit of time or memory
        _NUM + r"\s*(?:s|sec|ms|µs|us|min|h|MB|GB|GiB|MiB|kB|KB)(?![\w/])",
        _NUM + r"\s*(?:seconds?|minutes?|hours?)\b",
        _WORDS,
        # a rate: something per second
        _NUM + r"\s*(?:[a-zA-Z]+\s+){0,3}(?:[a-zA-Z]+\s*)?/\s*s\b",
        _NUM + r"\s*(?:[a-zA-Z]+\s+){0,4}per second",
        # a speed ratio
        _NUM + r"\s*(?:x|×)(?![\w])",
        r"\b(?:\d[\d,.]*|two|three|ten|twenty|a hundred)\s+times\s+(?:faster|slower|as fast|as long)",
        # a clock time mm:ss or h:mm:ss
        r"(?<![\w.:'(+-])\d{1,2}:[0-5]\d(?::[0-5]\d)?(?![\d.:')])",
    ]))

#: a table row about speed (its first cell names a time, rate or memory) ...
SPEED_ROW = re.compile(r"seconds|\btime\b|speed|per second|wall|memory|\bcost\b|/s\b"
                       r"|\[(?:s|ms|us|MB|GB|MiB)\]")
#: ... must not show a measured number in another cell (a target, "<= 20", may stay)
ROW_NUMBER = re.compile(r"(?<![≤≥<>\w.-])(?<![≤≥<>] )\d+(?:[,.]\d+)*")

#: (file, text next to the figure, reason): figures that are not dpdfit's speed.  The
#: text must occur within 70 characters of the figure (whitespace collapsed); an entry
#: that matches nothing fails.
ALLOWED = [
    ("docs/getting-started.md", "no gate (at least `00` and `11`; a few minutes of lab time)",
     "the lab time of a characterisation experiment, not dpdfit's"),
    ("docs/getting-started.md", "(e.g. 10 drives, a few minutes of lab time)",
     "the lab time of a characterisation experiment, not dpdfit's"),
    ("docs/guide/schedule.md", "costs its two readings, 2 x `linearity_reading_s` (5 s each",
     "defaults of LabTimes: the lab's readings of a detector linearity point, not dpdfit's"),
    ("docs/guide/schedule.md", "(60 s) over the repeat's points: 10 drives take about 3 "
                               "minutes",
     "a default of LabTimes: the lab's time to put an attenuator in, not dpdfit's"),
    ("docs/getting-started.md", "8 waits up to 10 ms, each sideband 200 shots: about a minute "
                                "of lab time",
     "the lab time of a characterisation experiment (the sideband thermometry), not dpdfit's"),
    ("docs/getting-started.md", "above 1 s it is refused as a unit slip",
     "a plausibility limit of an input value (a thermometry wait)"),
    ("docs/guide/import.md", "a wait above 1 s is refused as a unit slip",
     "a plausibility limit of an input value (a thermometry wait)"),
    ("docs/guide/schedule.md", "(`thermometry_shot_s` + its wait) (2 ms a shot",
     "a default of LabTimes: the lab's time per thermometry shot, not dpdfit's"),
    ("docs/guide/schedule.md", "(8 waits up to 10 ms, both sidebands, 200 shots each: about "
                               "16 s)",
     "the lab time of a sideband thermometry from the LabTimes defaults, not dpdfit's"),
    ("docs/getting-started.md", "a phase run whose phases are more than 20x the other runs'",
     "a plausibility ratio of a phase run in degrees among runs in radians, not a speed"),
    ("docs/getting-started.md", "traced (about a minute of lab time)",
     "the lab time of a characterisation experiment (the AOM pulse response), not dpdfit's"),
    ("docs/getting-started.md", "up to about the coherence time, a few minutes of lab time",
     "the lab time of a characterisation experiment (the Ramsey scan), not dpdfit's"),
    ("docs/getting-started.md", "a time beyond 1000 µs is refused as a unit slip",
     "a plausibility limit of an input value (a pulse response's time axis)"),
    ("docs/guide/import.md", "a time beyond 1000 µs (a unit slip)",
     "a plausibility limit of an input value (a pulse response's time axis)"),
    ("docs/guide/schedule.md", "`ramsey_point_s` (2 ms a shot besides the wait",
     "defaults of LabTimes: the lab's time per Ramsey shot and point, not dpdfit's"),
    ("docs/guide/schedule.md", "takes about 2 minutes at T2 = 50 ms",
     "the lab time of a Ramsey scan from the LabTimes defaults, not dpdfit's"),
    ("docs/guide/schedule.md", "`pulse_trace_s` (60 s: a few seconds of averaging",
     "a default of LabTimes: the lab's time per averaged pulse-response trace, not dpdfit's"),
    ("docs/guide/schedule.md", "sampled every 10 ns or finer for about 40 us",
     "the scope trace of an AOM pulse response (the lab's instrument), not dpdfit's"),
    ("docs/guide/schedule.md", "lab time 300.0 s",
     "the proposal's lab time, printed by the page's snippet (the lab's, not dpdfit's)"),
    ("docs/guide/schedule.md", "`shot_s` (10 ms a shot)",
     "a default of LabTimes: the lab's time per shot, not dpdfit's"),
    ("docs/guide/schedule.md", "`spam_shot_s` (2 ms a shot",
     "a default of LabTimes: the lab's time per SPAM shot, not dpdfit's"),
    ("docs/guide/schedule.md", "`spectrum_trace_s` (60 s)",
     "a default of LabTimes: the lab's time per trace, not dpdfit's"),
    ("docs/guide/schedule.md", "(`amplitude_run_s`, 300 s, or",
     "defaults of LabTimes: the lab's time per amplitude and per phase run, not dpdfit's"),
    ("docs/guide/schedule.md", "phase runs 36 minutes apart",
     "the bundled campaign's spacing of phase runs (the lab's), not dpdfit's"),
    ("README.md", "between 15 and 60 seconds",
     "a range, checked against benchmarks/analyze_wall.json by the test below"),
    ("README.md", "between 5 and 30 seconds",
     "a range, checked against benchmarks/analyze_wall.json by the test below"),
    ("docs/benchmarks.md", "(campaigns 1x, 4x and 16x the bundled one",
     "campaign sizes of the scaling benchmark, not speed ratios"),
    ("docs/benchmarks.md", "With the diagnosis (1x and 4x)",
     "campaign sizes of the scaling benchmark, not speed ratios"),
    ("docs/diagnosis/evidence.md", "two-exponential kernel (0.9 µs and 3 µs)",
     "time constants of a simulated AOM memory (physics)"),
    ("docs/diagnosis/evidence.md", "$T_2$ = 10.4 ± 0.5 ms",
     "coherence times of the simulated ions (physics)"),
    ("docs/diagnosis/evidence.md", "$T_{2c}$ of 4.5 ms and 3.0 ms",
     "coherence times of the simulated ions (physics)"),
    ("docs/diagnosis/evidence.md", "`rate_per_s` | 6 | −16.3 /s",
     "bias of a fitted dephasing rate (physics)"),
    ("docs/diagnosis/how-it-decides.md", "Against a 16× oversampled",
     "oversampling factor of a reference calculation"),
    ("docs/getting-started.md", "a gate rate more than 10x above or below",
     "a plausibility range of an input value"),
    ("docs/getting-started.md", "default 16 GB or 80 %",
     "default of a memory limit the user sets (DPDFIT_MAX_MEMORY_GB)"),
    ("docs/guide/alignment.md", "overestimates the IM infidelity (about 2×",
     "ratio of two infidelities (physics)"),
    ("docs/guide/budget.md", "0.9 % at 100/s",
     "a motional heating rate in quanta/s (physics)"),
    ("docs/guide/budget.md", "gate times 150-310 us (mean 230 us)",
     "gate durations of the bundled campaign (physics), printed by dpdfit budget"),
    ("docs/guide/spectra.md", "found on a 16× finer grid",
     "refinement factor of a grid"),
    ("docs/guide/spectra.md", "digitised (1 GS/s",
     "sampling rate of the paper's digitiser"),
    ("docs/guide/stability.md", "scatter is 2.3x the mean fit error",
     "ratio of two statistical errors, printed by dpdfit stability"),
    ("docs/guide/stability.md", "the report says so (2.3x on the bundled campaign)",
     "ratio of two statistical errors, printed by dpdfit stability"),
    ("docs/guide/stability.md", "over 6 runs in about 3 hours",
     "time span of the paper's calibration runs (data, not speed)"),
    ("docs/guide/stability.md", "The bundled phase runs span 3 hours",
     "time span of the bundled calibration runs (data, not speed)"),
    ("dpdfit simulate-campaign --help", "dephasing (1/s)",
     "unit of a dephasing rate (physics)"),
]


def pages() -> list[Path]:
    """The documentation's Markdown pages and the README."""
    out = sorted(p for p in DOCS.rglob("*.md")
                 if "_build" not in p.parts and p.name != "changelog.md")
    return [*out, ROOT / "README.md"]


def help_texts() -> dict[str, str]:
    """``--help`` of ``dpdfit`` and of each of its commands."""
    import argparse

    from dpdfit.cli.main import build_parser

    parser = build_parser()
    out = {"dpdfit --help": parser.format_help()}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out[f"dpdfit {name} --help"] = sub.format_help()
    return out


def notebook_texts() -> dict[str, str]:
    """The Markdown cells of the site's notebooks, one text per notebook."""
    import json

    out = {}
    for nb in sorted((DOCS / "examples").glob("*.ipynb")):
        cells = json.loads(nb.read_text("utf-8"))["cells"]
        out[str(nb.relative_to(ROOT))] = "\n\n".join(
            "".join(c["source"]) for c in cells if c["cell_type"] == "markdown")
    return out


def sources() -> dict[str, str]:
    texts = {str(p.relative_to(ROOT)): p.read_text(encoding="utf-8") for p in pages()}
    texts.update(notebook_texts())
    texts.update(help_texts())
    return texts


def figures(text: str) -> list[tuple[str, str]]:
    """(figure, the text around it) of every typed speed figure in ``text``.

    Whitespace is collapsed first, so a figure broken over two lines is found; the
    ``benchmark`` roles (values read from a record) are left out.
    """
    flat = " ".join(ROLE.sub("ROLE", text).split())
    return [(m.group(0), flat[max(0, m.start() - 70):m.end() + 70])
            for m in SPEED_FIGURE.finditer(flat)]


def table_figures(text: str) -> list[tuple[str, str]]:
    """(number, row) of the numbers typed into Markdown table rows about speed.

    Such a row has the unit in its first cell or in the header, so the number stands
    alone (``| diagnosis seconds | median 31, max 110 |``).
    """
    out = []
    for line in text.splitlines():
        if not line.lstrip().startswith("|"):
            continue
        cells = [c.strip() for c in ROLE.sub("ROLE", line).strip().strip("|").split("|")]
        if SPEED_ROW.search(re.sub(r"`[^`]*`", "", cells[0])):
            out += [(m.group(0), line.strip()) for c in cells[1:]
                    for m in ROW_NUMBER.finditer(c)]
    return out


def _allowed(name: str, around: str) -> tuple | None:
    for entry in ALLOWED:
        if entry[0] == name and entry[1] in around:
            return entry
    return None


def test_the_scanner_finds_speed_figures():
    found = [f for f, _ in figures(
        "It took 2:09, 12 s, about 40 s, 0.99 s, 173 MB, 2,760-2,810 parity fits/s, "
        "20x, 6-8x an FFT, 2.8 ms, about two minutes, 16-24 min, 65,000 per second, "
        "20 times faster")]
    assert found == ["2:09", "12 s", "40 s", "0.99 s", "173 MB", "2,760-2,810 parity fits/s",
                     "20x", "6-8x", "2.8 ms", "two minutes", "16-24 min", "65,000 per second",
                     "20 times faster"]
    assert figures("see {benchmark}`sweep_speed.json::#0::value` s; 2026-11-26T08:36:40; "
                   "--amplitudes 0.3:0.9:61") == []
    rows = ("| check | target | measured |\n|---|---|---|\n"
            "| diagnosis seconds | slowest ≤ 120 | median 31, max 110 |\n"
            "| parity fits per second | ≥ 1000 | {benchmark}`counts_speed.json::#0::rate` |\n"
            "| `aom_memory` | `tau_ns` | 7 |\n")
    assert [f for f, _ in table_figures(rows)] == ["31", "110"]


def test_no_typed_speed_figure_in_the_docs_readme_or_help():
    typed, used = [], set()
    for name, text in sources().items():
        for fig, line in figures(text) + table_figures(text):
            entry = _allowed(name, line)
            if entry is None:
                typed.append(f"{name}: {fig!r} in: {line[:160]}")
            else:
                used.add(ALLOWED.index(entry))
    assert typed == [], (f"{len(typed)} typed speed figure(s); cite the record with "
                         "{benchmark}`FILE::ROW::COLUMN` or drop them:\n" + "\n".join(typed))
    unused = [ALLOWED[i] for i in range(len(ALLOWED)) if i not in used]
    assert unused == [], f"exceptions that match nothing any more: {unused}"


def test_every_benchmark_role_names_a_value_of_a_record():
    roles = [(p, m.group(1)) for p in pages() for m in ROLE.finditer(p.read_text("utf-8"))]
    assert roles, "no page cites a benchmark record"
    for page, text in roles:
        name, selector, column, _ = parse(text)
        value = lookup(ROOT / "benchmarks" / name, selector, column)
        assert value == value, f"{page}: {text} is not a number"


def test_every_cited_record_is_on_the_benchmarks_page():
    from fnmatch import fnmatch

    shown = re.findall(r"\.\./benchmarks/(\S+)", (DOCS / "benchmarks.md").read_text("utf-8"))
    cited = {parse(m.group(1))[0] for p in pages() for m in ROLE.finditer(p.read_text("utf-8"))}
    missing = sorted(name for name in cited if not any(fnmatch(name, g) for g in shown))
    assert missing == [], f"cited in prose but not tabulated on the Benchmarks page: {missing}"


def test_readme_time_ranges_for_the_first_command_hold_the_latest_record():
    readme = " ".join((ROOT / "README.md").read_text("utf-8").split())
    record = ROOT / "benchmarks" / "analyze_wall.json"
    for pattern, variant in (
            (r"between (\d+) and (\d+) seconds, the diagnosis included", "with the diagnosis"),
            (r"`--no-diagnosis`: between (\d+) and (\d+) seconds", "--no-diagnosis")):
        m = re.search(pattern, readme)
        assert m, f"the README gives no time range for `dpdfit analyze` ({variant})"
        low, high = float(m.group(1)), float(m.group(2))
        for column in ("min wall [s]", "max wall [s]"):
            value = lookup(record, f"variant={variant}", column)
            assert low <= value <= high, (f"README says {low:g}-{high:g} s ({variant}); "
                                          f"{record.name} has {column} = {value:.1f} s")


@pytest.mark.parametrize("citation, message", [
    ("missing.json::#0::value", "benchmark file not found"),
    ("sweep_speed.json::quantity~no such row::value", "matches 0 rows"),
    ("sweep_speed.json::quantity~::value", "matches 3 rows"),
    ("sweep_speed.json::#0::no such column", "has no column"),
    ("sweep_speed.json::#0::target", "not a number"),
    ("sweep_speed.json::#0", "expected FILE::ROW::COLUMN"),
])
def test_a_citation_of_no_value_fails_the_build(tmp_path, citation, message):
    from sphinx.cmd.build import build_main

    src, bench = tmp_path / "docs", tmp_path / "benchmarks"
    src.mkdir()
    bench.mkdir()
    (bench / "sweep_speed.json").write_text(
        (ROOT / "benchmarks" / "sweep_speed.json").read_text("utf-8"), "utf-8")
    (src / "conf.py").write_text(
        f"import sys\nsys.path.insert(0, {str(DOCS / '_ext')!r})\n"
        "extensions = ['benchmark_values']\n", "utf-8")
    (src / "benchmarks.rst").write_text("Benchmarks\n==========\n", "utf-8")
    good = "sweep_speed.json::quantity~peak resident memory::value::.0f"
    (src / "index.rst").write_text(
        f"Index\n=====\n\n.. toctree::\n\n   benchmarks\n\nGood :benchmark:`{good}` MB.\n",
        "utf-8")
    out = tmp_path / "html"
    assert build_main(["-W", "-q", "-b", "html", str(src), str(out)]) == 0
    peak = lookup(bench / "sweep_speed.json", "quantity~peak resident memory", "value")
    assert f">{peak:.0f}<" in (out / "index.html").read_text("utf-8")
    (src / "index.rst").write_text(
        f"Index\n=====\n\n.. toctree::\n\n   benchmarks\n\nBad :benchmark:`{citation}`.\n",
        "utf-8")
    warnings = tmp_path / "warnings.txt"
    status = build_main(["-W", "-q", "-E", "-b", "html", "-w", str(warnings),
                         str(src), str(out)])
    assert status != 0
    assert message in warnings.read_text("utf-8")
