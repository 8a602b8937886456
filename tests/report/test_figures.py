"""Figures as objects: every figure function returns a matplotlib Figure and draws
into the caller's axes (``ax=``) or figure (``fig=``); saving is separate; the library never
chooses a matplotlib backend and ``import dpdfit`` does not import matplotlib.

Inputs are small and built from the bundled campaign (one calibration run, a 13-point
sweep, the gate counts); the diagnosis is a stand-in with the fields its figure reads.
"""

from __future__ import annotations

import ast
import inspect
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
from matplotlib.figure import Figure  # noqa: E402

import dpdfit  # noqa: E402
import dpdfit.report as report  # noqa: E402
from dpdfit import (Calibration, SweepConfig, TransferFunction, align, calibrate_amplitude,  # noqa: E402
                    calibrate_phase, gate_fidelities, merge_parity, read_calibration,
                    read_parity, read_populations, run_sweep)
from dpdfit.analyses.stability import stability  # noqa: E402
from dpdfit.fits.posterior import sample_amplitude_posterior  # noqa: E402
from dpdfit.pipeline.steps.gates import closest_pair  # noqa: E402
from dpdfit.report.figure_io import save_figures  # noqa: E402
from tests.helpers.paths import ROOT  # noqa: E402

PKG = Path(dpdfit.__file__).resolve().parent
CAMP = ROOT / "datasets" / "synthetic_campaign"
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def inp():
    """Everything the figures draw, small: calibration, sweep, gate table, fits, stability."""
    import pandas as pd
    amp_data = read_calibration(CAMP / "calibration_amplitude.csv", "amplitude", "R034")
    ph_data = read_calibration(CAMP / "calibration_phase.csv", "phase", "P006")
    cal = Calibration(amplitude=calibrate_amplitude(amp_data), phase=calibrate_phase(ph_data))
    sweep = run_sweep(TransferFunction.from_calibration(cal),
                      SweepConfig(amplitudes=np.linspace(0.3, 0.9, 13)))
    par = read_parity(CAMP / "parity.csv")
    gate = gate_fidelities(read_populations(CAMP / "populations.csv"), par)
    rates = pd.read_csv(CAMP / "gate_rates.csv")
    gate = gate.merge(rates[["A", "dpd", "xi0_khz", "xi0_err_khz"]], on=["A", "dpd"])
    merged = merge_parity(par)
    parity = {(float(A), int(d)): (g["phase_rad"].to_numpy(), g["n_even"].to_numpy(),
                                   g["shots"].to_numpy())
              for (A, d), g in merged.groupby(["A", "dpd"])}
    return SimpleNamespace(
        cal=cal, amp_data=amp_data, ph_data=ph_data, sweep=sweep, gate=gate, parity=parity,
        merged=merged, fit=align(gate, sweep, 0.2), highlight=closest_pair(gate),
        time_scans=pd.read_csv(CAMP / "time_scans.csv", comment="#"),
        stab=stability(CAMP / "calibration_phase.csv", kind="phase"),
        post=sample_amplitude_posterior(amp_data.A, amp_data.value, amp_data.error, 4,
                                        n_walkers=24, n_steps=300, seed=3),
        diag=_diagnosis(), comparison=_comparison())


def _diagnosis():
    """A stand-in for :class:`~dpdfit.analyses.diagnosis.result.Diagnosis` (its figure's fields)."""
    x = np.linspace(0.3, 0.9, 7)
    before = [("R10", "mean", 1, "A", x, np.sin(5 * x)), ("F_pop", "-", 0, "A", x, x - 0.5),
              ("calibration_amplitude", "-", -1, "A", x, 0.1 * x)]
    after = [(o, s, d, n, xx, 0.5 * z) for o, s, d, n, xx, z in before]
    return SimpleNamespace(series_before=before, series_after=after, verdict="tau",
                           chosen=SimpleNamespace(effect="tau"),
                           mismatches=[{"observable": "R10", "sideband": "mean", "dpd": 1,
                                        "range": (0.4, 0.6)}])


def _comparison():
    """A comparison of two small diagnosis dicts (its figure's evidence rows)."""
    from dpdfit.analyses.diagnosis.comparison.compare import compare_diagnoses

    def diag(verdict, ranking, alternatives=()):
        return {"campaign": "c", "verdict": verdict, "effects": [{"effect": verdict}],
                "ranking": [{"effect": e, "delta_bic": v} for e, v in ranking],
                "alternatives": list(alternatives)}
    alt = {"effect": "spam_offset", "named": ["spam_offset"], "replaces": "tau"}
    return compare_diagnoses(diag("tau", [("tau", -40.0), ("spam_offset", -36.0)], [alt]),
                             diag("tau", [("tau", -90.0), ("spam_offset", -50.0)]))


#: every public Figure-returning function: name -> (call with the inputs, keyword: ax or fig)
CASES = {
    "amplitude_calibration_figure": (lambda i, **k: report.amplitude_calibration_figure(
        i.cal, i.amp_data, **k), "ax"),
    "phase_calibration_figure": (lambda i, **k: report.phase_calibration_figure(
        i.cal, i.ph_data, **k), "ax"),
    "predistortion_figure": (lambda i, **k: report.predistortion_figure(i.cal, **k), "ax"),
    "calibration_figure": (lambda i, **k: report.calibration_figure(
        i.cal, i.amp_data, i.ph_data, **k), "fig"),
    "spectral_figure": (lambda i, **k: report.spectral_figure(i.sweep, **k), "fig"),
    "spectral_supplement_figure": (lambda i, **k: report.spectral_supplement_figure(
        i.sweep, **k), "fig"),
    "infidelity_vs_efficiency_figure": (lambda i, **k: report.infidelity_vs_efficiency_figure(
        i.sweep, **k), "ax"),
    "phase_space_figure": (lambda i, **k: report.phase_space_figure(**k), "ax"),
    "fidelity_vs_rate_figure": (lambda i, **k: report.fidelity_vs_rate_figure(
        i.gate, i.sweep, i.fit, i.parity, i.highlight, **k), "fig"),
    "fidelity_vs_efficiency_figure": (lambda i, **k: report.fidelity_vs_efficiency_figure(
        i.gate, i.sweep, i.fit, **k), "ax"),
    "parity_fringes_figure": (lambda i, **k: report.parity_fringes_figure(
        i.gate, i.parity, **k), "fig"),
    "time_scans_figure": (lambda i, **k: report.time_scans_figure(
        i.gate, i.time_scans, 0.1, **k), "fig"),
    "merged_parity_figure": (lambda i, **k: report.merged_parity_figure(
        i.gate, i.merged, **k), "fig"),
    "stability_figure": (lambda i, **k: report.stability_figure(i.stab, **k), "ax"),
    "envelope_figure": (lambda i, **k: report.envelope_figure(i.stab, **k), "ax"),
    "diagnosis_figure": (lambda i, **k: report.diagnosis_figure(i.diag, "tones", **k), "fig"),
    "corner_figure": (lambda i, **k: report.corner_figure(i.post, **k), "fig"),
    "comparison_figure": (lambda i, **k: report.comparison_figure(i.comparison, **k), "ax"),
}

#: the functions returning a set ``{file stem: Figure}`` and the stems they give here
SETS = {
    "calibration_figures": (lambda i: report.calibration_figures(i.cal, i.amp_data, i.ph_data),
                            {"fig1a_amplitude", "fig1b_phase", "fig1c_predistortion",
                             "fig1_calibration"}),
    "sweep_figures": (lambda i: report.sweep_figures(i.sweep),
                      {"fig2_spectral", "figS5_spectral", "fig5_eps_vs_eta",
                       "figS3_phase_space"}),
    "gate_figures": (lambda i: report.gate_figures(i.gate, i.sweep, i.fit, i.parity,
                                                   i.time_scans, i.highlight),
                     {"fig3_fidelity_vs_rate", "fig4_fidelity_vs_eta", "figS7_parity_fringes",
                      "figS6_time_scans"}),
    "stability_figures": (lambda i: report.stability_figures(i.stab),
                          {"figS1_stability_phase", "figS2_envelope_phase"}),
    "diagnosis_figures": (lambda i: report.diagnosis_figures(i.diag),
                          {"diagnosis_tones", "diagnosis_gates", "diagnosis_calibration"}),
}


def test_every_public_figure_function_is_tested():
    """The cases above cover every ``*_figure``/``*_figures`` name ``dpdfit.report`` exports."""
    exported = {n for n in report.__all__ if n.endswith(("_figure", "_figures"))} - {"save_figures"}
    assert exported == set(CASES) | set(SETS)


@pytest.mark.parametrize("name", sorted(CASES))
def test_returns_a_new_figure(inp, name):
    draw, _ = CASES[name]
    fig = draw(inp)
    assert isinstance(fig, Figure) and fig.axes
    assert fig.canvas.manager is None          # not a pyplot figure: nothing to close


@pytest.mark.parametrize("name", sorted(CASES))
def test_draws_into_the_callers_axes_or_figure(inp, name):
    """``ax=`` draws into that axes (beside the caller's other axes), ``fig=`` into that
    (Sub)Figure; the caller's Figure is returned."""
    draw, kw = CASES[name]
    mine = Figure(figsize=(12, 5))
    if kw == "ax":
        left, right = mine.subplots(1, 2)
        left.plot([0, 1], [0, 1])
        assert draw(inp, ax=right) is mine
        assert right.has_data() or right.texts
        assert mine.axes == [left, right]
    else:
        sub_a, sub_b = mine.subfigures(1, 2)
        assert draw(inp, fig=sub_b) is mine
        assert sub_b.axes and not sub_a.axes
        assert set(sub_b.axes) <= set(mine.axes)


def test_keywords_are_keyword_only():
    """``ax``/``fig`` are keyword-only, so positional calls keep their meaning."""
    for name, (_, kw) in CASES.items():
        p = inspect.signature(getattr(report, name)).parameters[kw]
        assert p.kind is p.KEYWORD_ONLY and p.default is None, name


@pytest.mark.parametrize("name", sorted(SETS))
def test_figure_sets_and_save(inp, name, tmp_path):
    draw, stems = SETS[name]
    figs = draw(inp)
    assert set(figs) == stems and all(isinstance(f, Figure) for f in figs.values())
    paths = save_figures(figs, tmp_path / "out", dpi=40)
    assert [Path(p).name for p in paths] == [f"{s}.png" for s in figs]
    for p in paths:
        assert Path(p).read_bytes()[:8] == PNG
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.endswith(".part")]


def test_save_figures_dpi_per_name(inp, tmp_path):
    from PIL import Image  # matplotlib's own dependency
    fig = report.phase_space_figure()
    save_figures({"a": fig, "b": fig}, tmp_path, dpi={"a": 50})
    wa, _ = Image.open(tmp_path / "a.png").size
    wb, _ = Image.open(tmp_path / "b.png").size
    assert wa == round(fig.get_figwidth() * 50) and wb == round(fig.get_figwidth() * report.DPI)


def test_corner_plot_is_drawn_by_corner(inp):
    """K x K axes (corner's layout), unknown parameters refused."""
    fig = report.corner_figure(inp.post, ["A_corr", "a2"])
    assert len(fig.axes) == 4 and not fig.axes[1].has_data() and fig.axes[2].has_data()
    with pytest.raises(dpdfit.InputError):
        report.corner_figure(inp.post, ["a9"])


def test_import_dpdfit_does_not_import_matplotlib():
    code = ("import dpdfit, dpdfit.report, dpdfit.cli.main, sys; "
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported'; "
            "assert 'corner' not in sys.modules, 'corner imported'")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-2000:]


def _use_calls(node) -> int:
    """Number of ``matplotlib.use(...)`` (or ``mpl.use``) calls under an AST node."""
    return sum(isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)
               and n.func.attr == "use" and isinstance(n.func.value, ast.Name)
               and n.func.value.id in ("matplotlib", "mpl") for n in ast.walk(node))


def test_no_backend_is_chosen_by_the_library():
    """``matplotlib.use`` only in ``figure_io.use_noninteractive_backend``, which only the
    command line calls (a notebook keeps its inline figures)."""
    text_hits = [p.relative_to(PKG).as_posix() for p in PKG.rglob("*.py")
                 if "matplotlib.use" in p.read_text() or "mpl.use" in p.read_text()]
    assert text_hits in ([], ["report/figure_io.py"]), text_hits
    tree = ast.parse((PKG / "report" / "figure_io.py").read_text())
    allowed = [f for f in tree.body if isinstance(f, ast.FunctionDef)
               and f.name == "use_noninteractive_backend"]
    assert _use_calls(tree) == sum(_use_calls(f) for f in allowed)
    callers = [p.relative_to(PKG).as_posix() for p in PKG.rglob("*.py")
               if any(isinstance(n, ast.Call) and "use_noninteractive_backend" in
                      (getattr(n.func, "id", ""), getattr(n.func, "attr", ""))
                      for n in ast.walk(ast.parse(p.read_text())))]
    assert callers and all(c.startswith("cli/") for c in callers), callers


def test_figures_do_not_touch_pyplot(inp):
    """Drawing every figure leaves pyplot's figure manager empty (no leaked figures)."""
    import matplotlib.pyplot as plt
    before = plt.get_fignums()
    for draw, _ in CASES.values():
        draw(inp)
    assert plt.get_fignums() == before
