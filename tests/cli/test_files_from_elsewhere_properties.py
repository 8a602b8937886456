"""Every command that reads a file from elsewhere, on generated hazards: the hazard is
refused in one line, or the input is taken; never more.

A campaign folder, further recordings, a schedule, an earlier diagnosis, a mapping and
its results files may come from a collaborator or another lab, damaged or crafted.  Each
test draws one input of one command (its *role*: a table of the campaign, NEW's
``populations.csv``, the ``--compare`` file, a results file, the campaign folder itself,
a file the folder might hold and does not, ...) and one hazard for an input of that
kind (:mod:`tests.helpers.file_hazards`): a link to a secret outside the folder, to a
folder, to ``/dev/zero``; a FIFO, a device, a sparse file beyond the bound, a link loop;
a row wider than its header, a column named twice, a NUL byte, a formula cell, a number
nan, empty or 1e400, the file cut inside a line, bytes that are not UTF-8; JSON nested
deeply or with a value of the wrong type; a byte of a results file flipped.  It puts the
hazard there and runs the command in a forked child (:mod:`tests.helpers.forked_command`:
killed should it hang, its memory bounded), the run's size bound set low
(``DPDFIT_MAX_INPUT_BYTES``, :data:`~tests.helpers.file_hazards.BOUND`).

The contract, for every case:

* exit status 0 or 2, never a traceback, never the command line's last line of defence
  (internal error, out of memory, recursion too deep);
* exit 2: exactly one line on stderr, ``dpdfit: error: ...``, printable, naming the file
  (or folder) the hazard is in; and nothing written: the test's whole folder as it was
  (every file's bytes, mode and modification time, every folder, link, FIFO and device);
* exit 0: only the output is new, and it holds regular files and folders only; every
  input as it was;
* the secret outside the folders is never written, nor printed unless the user named
  the file that leads to it;
* ``dpdfit analyze`` also ends as it documents for a table malformed in its values (a
  count that is nan): the analyses that need the table fail, each with one
  ``dpdfit: error:`` line naming a file (one of them the hazard's), the others' results
  are written, exit 2; ``summary.json`` lists the failures.  What it wrote obeys the
  rules of exit 0.

The campaigns are small (the bundled campaign's tables for ``analyze``, the harness's
reduced campaign for the others); nearly every hazard is refused before any fit, so a
case takes a fraction of a second.  The examples are the profile's (``ci`` by default,
:mod:`tests.helpers.prop_mutations`; ``HYPOTHESIS_PROFILE=thorough`` draws more), a third
of them for ``analyze`` and ``--compare``, which may take an input only after seconds of
fits; the cases the issue named, and those found failing, are explicit examples.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import tests.helpers.prop_mutations  # noqa: F401 - registers and loads the hypothesis profiles
from dpdfit.cli.main import INTERNAL_ERROR, OUT_OF_MEMORY, TOO_DEEP
from dpdfit.recordings.schedule import write_schedule
from tests.helpers.bundled_data import CAMPAIGN
from tests.helpers.file_hazards import (BOUND_ENV, Hazard, hazards, outside, put,
                                        wrong_type_targets)
from tests.helpers.forked_command import run_forked
from tests.helpers.tree_snapshot import differences, snapshot
from tests.helpers.untrusted_campaign import SECRET, TABLES, small_campaign

pytestmark = pytest.mark.skipif(not hasattr(os, "fork") or not hasattr(os, "mkfifo")
                                or not sys.platform.startswith("linux"),
                                reason="forks, FIFOs and /proc: Linux")

#: the examples of a test whose inputs a command may take, or fail on in part, only after
#: seconds of fits (``analyze`` runs every analysis on a count that is nan; an earlier
#: diagnosis taken is diagnosed again): a third of the profile's
THIRD = settings(max_examples=max(5, settings.default.max_examples // 3))
LAST_LINE = tuple(f"dpdfit: error: {s}" for s in (INTERNAL_ERROR, OUT_OF_MEMORY, TOO_DEEP))
CSV_TABLES = tuple(t for t in TABLES if t.endswith(".csv"))


@dataclass(frozen=True)
class Role:
    """One input of a command: its path under the case's folder, its kind (for the
    hazards, :func:`~tests.helpers.file_hazards.hazards`), whether the user names it on
    the command line (a link there is the user's own choice, and may be followed), the
    honest file to write first when the folder does not hold it, and the keys of a JSON
    file whose values may take the wrong type.  A path with ``*`` is a glob (the results
    files, named by the time they were written)."""

    path: str
    kind: str
    named: bool = False
    honest: Callable[[Path], None] | None = None
    keys: tuple | None = None


def cases(roles: dict):
    """A strategy of ``(role name, hazard)`` for one of ``roles``."""
    return st.sampled_from(sorted(roles)).flatmap(
        lambda r: st.tuples(st.just(r), hazards(roles[r].kind)))


# ----------------------------------------------------------------------------- the contract


def run_case(pristine: Path, role: Role, hazard: Hazard, argv: Callable[[Path], list],
             output: str | None, command: str) -> str:
    """Copy ``pristine`` into a fresh folder, put ``hazard`` in ``role``'s place, run
    ``dpdfit argv(folder)`` and check the contract (module doc).  Returns how the case
    ended: ``"refused"``, ``"taken"`` or ``"failed in part"`` (``analyze``)."""
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        shutil.copytree(pristine, root, dirs_exist_ok=True, symlinks=True)
        if role.honest is not None:
            role.honest(root)
        target = next(root.glob(role.path)) if "*" in role.path else root / role.path
        put(target, hazard, role.kind, outside(root), role.keys)
        before = snapshot(root)
        ran = run_forked(argv(root), env=BOUND_ENV)
        after = snapshot(root)
        where = (f"dpdfit {command}, {role.path}: {hazard} -> exit {ran.code} after "
                 f"{ran.seconds:.1f} s\nstdout: {ran.out[-1500:]}\nstderr: {ran.err[-3000:]}")
        return _check(ran, before, after, root, role, output, where)


def _check(ran, before, after, root, role, output, where) -> str:
    assert not ran.hung, f"hung (killed): {where}"
    assert ran.code in (0, 2), where
    assert "Traceback" not in ran.err, where
    lines = ran.err.splitlines()
    assert not [ln for ln in lines if ln.startswith(LAST_LINE)], where
    if not role.named:
        assert SECRET not in ran.err and SECRET not in ran.out, f"secret printed: {where}"
    name = Path(role.path).name.split("*")[-1].lstrip("-")
    diff = differences(before, after)
    out = None if output is None else root / output
    failed_in_part = ran.code == 2 and out is not None and (out / "summary.json").is_file()
    if ran.code == 2 and not failed_in_part:
        assert len(lines) == 1 and lines[0].startswith("dpdfit: error: "), \
            f"not one error line: {where}"
        assert lines[0].isprintable(), f"unprintable: {where}"
        assert name in lines[0], f"the line does not name {name}: {where}"
        assert not any(diff.values()), f"refused, yet the folder changed {diff}: {where}"
        return "refused"
    assert not diff["vanished"] and not diff["changed"], f"an input changed {diff}: {where}"
    rel = None if out is None else out.relative_to(root).as_posix()
    stray = [p for p in diff["appeared"] if rel is None or not (p == rel or
                                                                p.startswith(rel + "/"))]
    assert not stray, f"written besides the output: {stray}: {where}"
    for p in diff["appeared"]:
        assert after[p][0] in ("file", "folder"), f"{p} in the output is {after[p]}: {where}"
        if after[p][0] == "file":
            assert SECRET.encode() not in (root / p).read_bytes(), f"secret in {p}: {where}"
    if failed_in_part:
        failures = json.loads((out / "summary.json").read_text())["failures"]
        errors = [ln for ln in lines if ln.startswith("dpdfit: error: ")]
        assert failures and len(errors) == len(failures), f"failures {failures}: {where}"
        assert all(ln.isprintable() for ln in errors), where
        assert any(name in ln for ln in errors), f"no line names {name}: {where}"
        return "failed in part"
    return "taken"


# ----------------------------------------------------------------------------- the inputs

#: a budget.toml as a lab writes it (docs/guide/budget.md)
BUDGET = ("[state_preparation]\nrabi_amplitude = 0.995\nrabi_amplitude_err = 0.002\n\n"
          "[dephasing]\nT2_ms = 35.0\nT2_err_ms = 4.0\n\n[heating]\nrate_per_ms = 0.02\n"
          "rate_err_per_ms = 0.005\nupper_limit = false\n")

#: campaign.json's keys ``analyze`` reads (a wrong type in another key is not read: the
#: command runs every analysis, seconds for nothing)
CAMPAIGN_KEYS = ("nu_hz", "xi0_spectra_hz", "nbar_assumed", "eta_ref", "order",
                 "predistortion_table.amplitude_run", "phase_run_for_model",
                 "spectra_recorded", "gates_recorded")
#: ... the diagnosis reads
DIAGNOSIS_KEYS = CAMPAIGN_KEYS + ("error_model",)
#: ... ``add`` reads (with the keys that tell one campaign's setup from another's)
ADD_KEYS = DIAGNOSIS_KEYS + ("f_det_hz", "eta_ld", "parity_phases", "predistortion_table")

#: an earlier diagnosis (``dpdfit diagnose --json``), with the keys a comparison reads:
#: its proposal's binding pair is refitted
PREVIOUS = {
    "campaign": "campaign", "verdict": "stale_calibration",
    "effects": [{"effect": "stale_calibration"}],
    "ranking": [{"effect": "stale_calibration", "delta_bic": -80.0,
                 "delta_bic_tempered": -40.0},
                {"effect": "detector_nonlinearity", "delta_bic": -75.0,
                 "delta_bic_tempered": -37.0}],
    "alternatives": [{"effect": "detector_nonlinearity", "named": ["detector_nonlinearity"],
                      "replaces": "stale_calibration", "delta_bic": 5.0,
                      "delta_bic_tempered": 4.0}],
    "next_measurement": {
        "what": "spectra", "expected_delta_bic": 27.0, "decisive": True,
        "binding": {"truth": {"effects": ["stale_calibration"], "forms": ["aom"],
                              "chi2": 100.0, "expected_delta_bic": 27.0},
                    "rival": {"effects": ["detector_nonlinearity"], "forms": ["linear"],
                              "chi2": 110.0, "expected_delta_bic": 45.0}}},
}


def _aiming_at(obj, path, keys=None) -> int:
    """The ``at`` of a ``"wrong type"`` hazard that aims at ``path`` of ``obj``."""
    return wrong_type_targets(obj, keys).index(tuple(path))


def _listed_trace(root: Path) -> None:
    """A trace of noise listed in ``traces.csv``, short enough for the bound, sampled
    fast enough for the tones (the traces analysis takes it)."""
    camp = root / "campaign"
    (camp / "traces").mkdir()
    np.savez_compressed(camp / "traces" / "t.npz",
                        trace=np.random.default_rng(0).normal(size=1 << 16))
    (camp / "traces.csv").write_text("file,A,dpd,fs,fdet,nu,xi0\n"
                                     "traces/t.npz,0.5,0,2e7,5e6,1840000,20000\n")


@pytest.fixture(scope="module")
def bundled(tmp_path_factory) -> Path:
    """The bundled campaign's tables (``campaign/``) and the secrets (``outside/``)."""
    root = tmp_path_factory.mktemp("bundled")
    small_campaign(root)
    outside(root)
    return root


def _rows(path: Path, keep) -> str:
    lines = path.read_text().splitlines()
    return "\n".join([lines[0]] + [ln for i, ln in enumerate(lines[1:]) if keep(i, ln)]) + "\n"


@pytest.fixture(scope="module")
def simulated(tmp_path_factory) -> Path:
    """The harness's reduced campaign (``campaign/``, with its truth.json); NEW
    (``new/``: rows of every kind, ``populations.csv`` without ``n_even``, a calibration
    run the campaign has); a schedule of spectra (``schedule.csv``); an earlier diagnosis
    (``previous.json``); the secrets (``outside/``)."""
    from tests.helpers.further_campaign import simulate
    root = tmp_path_factory.mktemp("simulated")
    camp = simulate(root / "campaign")
    new = root / "new"
    new.mkdir()
    pops = (camp / "populations.csv").read_text().splitlines()
    drop = pops[0].split(",").index("n_even")
    (new / "populations.csv").write_text("".join(
        ",".join(c for k, c in enumerate(ln.split(",")) if k != drop) + "\n" for ln in pops))
    (new / "parity.csv").write_text(_rows(camp / "parity.csv", lambda i, ln: i < 16))
    (new / "time_scans.csv").write_text(_rows(camp / "time_scans.csv", lambda i, ln: i < 5))
    (new / "spectra.csv").write_text(_rows(camp / "spectra.csv", lambda i, ln: i < 8))
    shutil.copy(camp / "gate_rates.csv", new / "gate_rates.csv")
    (new / "calibration_amplitude.csv").write_text(
        _rows(camp / "calibration_amplitude.csv", lambda i, ln: ln.startswith("R001,")))
    import pandas as pd
    write_schedule(pd.DataFrame([{"kind": "spectra", "repeat": 1, "point": k, "A": 0.3,
                                  "dpd": d, "lab_s": 5.0} for k, d in enumerate((0, 1))]),
                   root / "schedule.csv")
    (root / "previous.json").write_text(json.dumps(PREVIOUS, indent=1))
    outside(root)
    return root


@pytest.fixture(scope="module")
def lab(tmp_path_factory) -> Path:
    """The small ARTIQ lab (``lab/``: two results files and ``map.toml``), the secrets."""
    pytest.importorskip("h5py")
    from tests.helpers.small_artiq_lab import SMALL_MAPPING, write_small_lab
    root = tmp_path_factory.mktemp("lab")
    write_small_lab(root / "lab")
    (root / "lab" / "map.toml").write_text(SMALL_MAPPING)
    outside(root)
    return root


# ----------------------------------------------------------------------------- analyze

ANALYZE = {
    **{t: Role(f"campaign/{t}", "csv") for t in CSV_TABLES},
    "campaign.json": Role("campaign/campaign.json", "json", keys=CAMPAIGN_KEYS),
    "budget.toml": Role("campaign/budget.toml", "toml",
                        honest=lambda r: (r / "campaign" / "budget.toml").write_text(BUDGET)),
    "budget.toml (absent)": Role("campaign/budget.toml", "absent"),
    "traces.csv": Role("campaign/traces.csv", "csv", honest=_listed_trace),
    "a listed trace": Role("campaign/traces/t.npz", "binary", honest=_listed_trace),
    "the campaign folder": Role("campaign", "folder", named=True),
}


#: the bundled campaign.json's predistortion table run given as a list
_TABLE_RUN_A_LIST = Hazard("wrong type", _aiming_at(
    json.loads((CAMPAIGN / "campaign.json").read_text()),
    ("predistortion_table", "amplitude_run"), CAMPAIGN_KEYS), 0)


@THIRD
@given(case=cases(ANALYZE))
@example(case=("campaign.json", _TABLE_RUN_A_LIST))
@example(case=("spectra.csv", Hazard("link to a secret outside")))
@example(case=("spectra.csv", Hazard("FIFO")))
@example(case=("budget.toml (absent)", Hazard("link to a secret outside")))
def test_analyze_a_campaign_folder(bundled, case):
    role, hazard = case
    run_case(bundled, ANALYZE[role], hazard,
             lambda r: ["analyze", r / "campaign", "-o", r / "results", "--no-diagnosis",
                        "--no-plots", "--no-progress"], "results", "analyze")


# ----------------------------------------------------------------------------- diagnose

DIAGNOSE = {
    **{t: Role(f"campaign/{t}", "csv") for t in CSV_TABLES},
    "campaign.json": Role("campaign/campaign.json", "json", keys=DIAGNOSIS_KEYS),
    "budget.toml (absent)": Role("campaign/budget.toml", "absent"),
    "the campaign folder": Role("campaign", "folder", named=True),
}


@given(case=cases(DIAGNOSE))
@example(case=("campaign.json", Hazard("link to /dev/zero")))
@example(case=("the campaign folder", Hazard("symbolic link loop")))
def test_diagnose_a_campaign_folder(simulated, case):
    role, hazard = case
    run_case(simulated, DIAGNOSE[role], hazard,
             lambda r: ["diagnose", r / "campaign", "--json", "--no-progress",
                        "--schedule", r / "next.csv"], "next.csv", "diagnose")


COMPARE = {"the previous diagnosis": Role("previous.json", "json", named=True)}
_FORM = _aiming_at(PREVIOUS, ("next_measurement", "binding", "truth", "forms", 0))


@THIRD
@given(case=cases(COMPARE))
@example(case=("the previous diagnosis", Hazard("FIFO")))
@example(case=("the previous diagnosis", Hazard("wrong type", _FORM, 0)))   # a form a list
@example(case=("the previous diagnosis",
               Hazard("wrong type", _aiming_at(PREVIOUS, ("effects",)), 0)))  # effects: 7
@example(case=("the previous diagnosis", Hazard("sparse file beyond the bound", 0, 3 << 30)))
def test_diagnose_compare_a_previous_diagnosis(simulated, case):
    role, hazard = case
    run_case(simulated, COMPARE[role], hazard,
             lambda r: ["diagnose", r / "campaign", "--compare", r / "previous.json",
                        "--json", "--no-progress"], None, "diagnose --compare")


# ----------------------------------------------------------------------------- add

NEW_TABLES = ("populations.csv", "parity.csv", "time_scans.csv", "spectra.csv",
              "gate_rates.csv", "calibration_amplitude.csv")
ADD = {
    **{f"CAMPAIGN {t}": Role(f"campaign/{t}", "csv") for t in CSV_TABLES},
    "CAMPAIGN campaign.json": Role("campaign/campaign.json", "json", keys=ADD_KEYS),
    "CAMPAIGN truth.json": Role("campaign/truth.json", "json"),
    "CAMPAIGN README.md": Role("campaign/README.md", "any"),
    "CAMPAIGN traces.csv": Role("campaign/traces.csv", "any"),
    "CAMPAIGN notes.txt": Role("campaign/notes.txt", "absent"),
    "CAMPAIGN traces/blob.bin": Role("campaign/traces/blob.bin", "absent"),
    "CAMPAIGN": Role("campaign", "folder", named=True),
    **{f"NEW {t}": Role(f"new/{t}", "csv") for t in NEW_TABLES},
    "NEW campaign.json": Role(
        "new/campaign.json", "json", keys=ADD_KEYS,
        honest=lambda r: shutil.copy(r / "campaign" / "campaign.json", r / "new")),
    "NEW notes.txt": Role("new/notes.txt", "absent"),
    "NEW": Role("new", "folder", named=True),
}
_N00 = 3 * 2      # NEW populations.csv: row 1 of 2, its 4th numeric cell (n00)


@given(case=cases(ADD))
@example(case=("CAMPAIGN notes.txt", Hazard("link to a secret outside")))
@example(case=("CAMPAIGN notes.txt", Hazard("link to a folder outside")))
@example(case=("CAMPAIGN populations.csv", Hazard("link to a secret outside")))
@example(case=("CAMPAIGN traces/blob.bin", Hazard("link to /dev/zero")))
@example(case=("NEW populations.csv", Hazard("number nan, empty or 1e400", _N00, "nan")))
@example(case=("NEW parity.csv", Hazard("formula cell", 0, "=cmd|' /C calc'!A0")))
@example(case=("CAMPAIGN", Hazard("symbolic link loop")))
@example(case=("CAMPAIGN populations.csv", Hazard("cut inside a line", 7)))    # no 'scan'
@example(case=("NEW", Hazard("symbolic link loop")))
def test_add_recordings_to_a_campaign(simulated, case):
    role, hazard = case
    run_case(simulated, ADD[role], hazard,
             lambda r: ["add", r / "campaign", r / "new", "-o", r / "merged", "--no-progress"],
             "merged", "add")


# ----------------------------------------------------------------------------- write-artiq-results

WRITE = {
    "the schedule": Role("schedule.csv", "csv", named=True),
    **{t: Role(f"campaign/{t}", "csv") for t in CSV_TABLES},
    "truth.json": Role("campaign/truth.json", "json"),
    "campaign.json": Role("campaign/campaign.json", "json", keys=ADD_KEYS),
    "the campaign folder": Role("campaign", "folder", named=True),
}


@given(case=cases(WRITE))
@example(case=("the schedule", Hazard("FIFO")))
@example(case=("the schedule", Hazard("formula cell", 0, "@SUM(1+1)*cmd|' /C calc'!A0")))
@example(case=("calibration_amplitude.csv", Hazard("row wider than its header", 7)))
@example(case=("gate_rates.csv", Hazard("formula cell", 7, "=cmd|' /C calc'!A0")))
@example(case=("truth.json", Hazard("link to a secret outside")))
def test_write_artiq_results_of_a_schedule(simulated, case):
    pytest.importorskip("h5py")
    role, hazard = case
    run_case(simulated, WRITE[role], hazard,
             lambda r: ["write-artiq-results", r / "campaign", r / "recorded", "--schedule",
                        r / "schedule.csv"], "recorded", "write-artiq-results")


# ----------------------------------------------------------------------------- import

IMPORT = {
    "the mapping": Role("lab/map.toml", "toml", named=True),
    "the calibration results file": Role("lab/results/*/*/*-AmplitudeCalibration.h5",
                                         "binary"),
    "the parity results file": Role("lab/results/*/*/*-ParityScan.h5", "binary"),
    "the results folder": Role("lab/results", "folder"),
}


@given(case=cases(IMPORT))
@example(case=("the parity results file", Hazard("byte flipped", 2000)))
@example(case=("the calibration results file", Hazard("byte flipped", 96)))
@example(case=("the mapping", Hazard("nested deeply", 0, 100_000)))
def test_import_a_lab_s_results_files(lab, case):
    role, hazard = case
    run_case(lab, IMPORT[role], hazard,
             lambda r: ["import", r / "lab" / "map.toml", "-o", r / "imported",
                        "--no-progress"], "imported", "import")


# ----------------------------------------------------------------------------- the baseline


@pytest.mark.parametrize("command", ["add", "write-artiq-results", "import"])
def test_the_honest_inputs_are_taken(simulated, lab, command):
    """The inputs the hazards are put into are taken as they are (the cheap commands;
    ``analyze`` and ``diagnose`` take the same campaigns in their own tests)."""
    argv = {"add": (simulated, lambda r: ["add", r / "campaign", r / "new", "-o",
                                          r / "merged"], "merged"),
            "write-artiq-results": (simulated, lambda r: [
                "write-artiq-results", r / "campaign", r / "recorded", "--schedule",
                r / "schedule.csv"], "recorded"),
            "import": (lab, lambda r: ["import", r / "lab" / "map.toml", "-o",
                                       r / "imported"], "imported")}
    pristine, make, output = argv[command]
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        shutil.copytree(pristine, root, dirs_exist_ok=True, symlinks=True)
        ran = run_forked(make(root), env=BOUND_ENV)
        assert ran.code == 0, ran.err
        assert (root / output).is_dir()
