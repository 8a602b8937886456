"""Every shell and Python snippet of the documentation runs on the bundled data, in the
order a reader meets it, and prints what the page says it prints.

One test per page: the page's snippets run in a fresh folder holding the repository's
``datasets/`` (the benchmarks page also a copy of ``benchmarks/``): shell blocks with
``bash -e``, ``dpdfit`` being this checkout's, the Python blocks in one namespace.  A
``text`` block after an executed snippet is the page's claim of the output (unless listed
below as an example message): each of its lines must be printed, its numbers within half
a unit of the last shown digit; so must a number that an expression's comment gives as
its value (``x.mean  # 0.5647``).  Snippets that cannot run here say so
on the page (``# lab-only: ...`` or ``# not run by the docs tests: ...``) and are listed
below by page and first line; the lists and the marks must agree.
"""

from __future__ import annotations

import shutil

import pytest

from tests.helpers.doc_snippets import (ROOT, SHELL_LANGS, Session, blocks, close, page_name,
                                        pages, run_shell, shell_script, snippets,
                                        unmatched_lines)

# Reads the lab's own files: shown with YOUR_LAB/ placeholder paths.
LAB_ONLY = {
    ("docs/guide/budget.md", "# lab-only: your own budget.toml and gate_rates.csv; not run on the bundled data"),
    ("docs/guide/budget.md", "# lab-only: your own budget.toml; not run on the bundled data"),
    ("docs/guide/counts.md", "# lab-only: your own populations and parity tables; not run on the bundled data"),
    ("docs/guide/propagation.md", "# lab-only: your own amplitude calibration runs; not run on the bundled data"),
    ("docs/guide/stability.md", "# lab-only: your own phase calibration runs; not run on the bundled data"),
}
# Hours of computing, or an edit of the package.
NOT_RUN = {
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: a new file of the package (test_docs_effect_skeleton runs it)"),
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: an edit of the package's registry"),
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: needs the lab's own modules"),
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: needs the new effect in the package"),
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: needs the new effect (minutes)"),
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: needs the new effect (a campaign)"),
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: needs the new effect (hours)"),
    ("docs/diagnosis/adding-an-effect.md", "# not run by the docs tests: hours, and an external campaign set"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: hours, on the validation campaigns (not bundled)"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: hours (the committed harness report 2612)"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: hours (the committed harness report 2611)"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: hours (every form of every effect, two campaigns each)"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: hours (campaigns with three effects concealed)"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: hours (the committed reports harness_report_2811, harness_report_lofo_2812, harness_report_loop_2814)"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: a harness run with the closed loop (the committed report harness_report_loop_2815)"),
    ("docs/diagnosis/evidence.md", "# not run by the docs tests: a harness run with the closed loop (the committed report harness_report_loop_2816)"),
    ("docs/guide/schedule.md", "# not run by the docs tests: a diagnosis (tens of seconds); the round trip page runs one"),
}
# Text blocks after a snippet that are examples of messages, not what the snippets print.
NOT_OUTPUT = {
    ("docs/getting-started.md", "dpdfit: error: campaign/gate_rates.csv, "),   # rates in Hz
    ("docs/guide/import.md", "dpdfit: error: map.toml: key 'parity[1]."),      # bad mappings
}
# Pages whose snippets run whole analyses or diagnoses (tens of seconds each).
SLOW = {"README.md", "docs/getting-started.md", "docs/diagnosis/how-it-decides.md",
        "docs/guide/propagation.md", "docs/guide/alignment.md", "docs/guide/import.md"}

PAGES = [p for p in pages() if snippets(p)]


def _param(path):
    name = page_name(path)
    marks = [pytest.mark.slow] if name in SLOW else []
    return pytest.param(path, id=name, marks=marks)


def _marked(path, kind):
    return {(page_name(path), b.first_line) for b in snippets(path) if b.marker == kind}


def test_the_snippets_left_out_are_the_listed_ones_and_say_so_on_their_page():
    assert set().union(*(_marked(p, "lab-only") for p in PAGES)) == LAB_ONLY
    assert set().union(*(_marked(p, "not run") for p in PAGES)) == NOT_RUN


def test_lab_only_snippets_use_placeholder_paths_not_real_looking_ones():
    for path in PAGES:
        for b in snippets(path):
            if b.marker == "lab-only":
                assert "YOUR_LAB/" in b.text, f"{page_name(path)}:{b.line}: {b.first_line}"


def test_only_installation_and_self_running_lines_are_dropped_from_shell_snippets():
    dropped = {part for p in PAGES for b in snippets(p) if b.lang in SHELL_LANGS
               and b.marker is None for part in shell_script(b.text)[1]}
    assert dropped == {"python3 -m venv .venv", ". .venv/bin/activate", "pip install .",
                       'pip install ".[test]"', 'pip install ".[docs]"', 'pip install ".[artiq]"',
                       "python -m pytest -n 2", 'python -m pytest -n 2 -m "not slow"',
                       "python -m sphinx -W --keep-going -b html docs docs/_build/html"}


def test_a_shown_number_must_round_to_the_printed_one():
    printed = "    A_corr=y(1) : 0.567035 +/- 0.004092\n    runs : 34 over 110.03 days"
    assert unmatched_lines("A_corr=y(1) : 0.56704 +/- 0.00409", printed) == []
    assert unmatched_lines("A_corr=y(1) : 0.5671 +/- 0.00409", printed) != []   # 0.567035 is 0.5670
    assert unmatched_lines("runs : 35 over 110.03 days", printed) != []
    assert unmatched_lines("runs : 34 over 110.0 days\n...", printed) == []
    assert close("+1.24e-05", 1.242e-05) and not close("+1.24e-05", 1.246e-05)
    assert not close("-0.0020", 0.0020)


def _check_shown(path, block, output, failures):
    missing = unmatched_lines(block.text, output)
    if missing:
        failures.append(f"{page_name(path)}:{block.line}: shown output not printed "
                        f"(or numbers off by more than the last digit's half unit):\n  "
                        + "\n  ".join(missing))


@pytest.mark.parametrize("path", [_param(p) for p in PAGES])
def test_page_snippets_run_in_order_and_print_what_the_page_shows(path, tmp_path, monkeypatch):
    (tmp_path / "datasets").symlink_to(ROOT / "datasets")
    if path.name == "benchmarks.md":   # a copy: the page's re-run rewrites a record
        shutil.copytree(ROOT / "benchmarks", tmp_path / "benchmarks",
                        ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.chdir(tmp_path)
    session, output, failures, last = Session(), "", [], None
    shown = [b for b in blocks(path) if b.lang == "text"]
    assert {(page_name(path), b.first_line[:40]) for b in shown} >= {
        n for n in NOT_OUTPUT if n[0] == page_name(path)}, "NOT_OUTPUT names a block not on the page"
    for block in blocks(path):
        if (block.lang == "text" and last is not None
                and (page_name(path), block.first_line[:40]) not in NOT_OUTPUT):
            _check_shown(path, block, output, failures)
        if block.lang not in SHELL_LANGS | {"python", "{code-cell}"} or block.marker:
            continue
        last = block
        where = f"{page_name(path)}:{block.line}: {block.first_line}"
        try:
            output += (run_shell(block.text, tmp_path) if block.lang in SHELL_LANGS
                       else session.run(block.text))
        except Exception as exc:   # noqa: BLE001 - the page and snippet name the failure
            pytest.fail(f"{where}\n{type(exc).__name__}: {exc}")
    for comment, shown, values in session.checked:
        if not all(close(s, v) for s, v in zip(shown, values)):
            failures.append(f"{page_name(path)}: comment '# {comment}' but the values are {values}")
    assert not failures, "\n".join(failures)
