"""The campaign simulator's driver: the recordings of one seed, ``campaign.json``, ``truth.json``.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import os
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from dpdfit.core.defaults import ERROR_MODEL
from dpdfit.core.progress import progress_bar
from dpdfit.core.version import __version__

from .calibration_runs import calibration_runs, table_index
from .config import DEFAULT_SEED, RETIRED_TRUTH_KEYS, CampaignConfig
from .detector_linearity_runs import linearity_table, linearity_truth
from .folder import check_new_folder, csv_text, write_folder
from .gate_runs import gate_references, gate_tables
from .optics import dpd_lut
from .pulse_runs import pulse_table, pulse_truth
from .ramsey_runs import ramsey_table, ramsey_truth
from .readme import campaign_readme
from .spam_runs import spam_table, spam_truth
from .spectra import spectra_tables
from .thermometry_runs import thermometry_table, thermometry_truth

__all__ = ["simulate_campaign"]


def _campaign_json(cfg: CampaignConfig, cal_truth: dict) -> dict:
    """Constants of the campaign as the lab records them (``campaign.json``)."""
    t0 = _dt.datetime.fromisoformat(cfg.start)
    day = cal_truth["gate_day"]
    rec = {k: (t0 + _dt.timedelta(days=day + h / 24)).isoformat(timespec="seconds")
           for k, h in zip(("spectra_recorded", "gates_recorded"), cfg.recording_hours)}
    return {
        "name": f"synthetic campaign, seed {cfg.seed}",
        "synthetic": True,
        "generator": f"dpdfit {__version__} simulate-campaign --seed {cfg.seed}",
        "nu_hz": cfg.nu, "xi0_spectra_hz": cfg.xi0_spec, "f_det_hz": cfg.f_det,
        "fs_traces_hz": cfg.fs, "eta_ld": cfg.eta_ld, "nbar_assumed": cfg.nbar,
        "eta_ref": cfg.eta_ref, "order": cfg.order,
        # what the lab's records say: the table was made from the gate day's run
        "predistortion_table": {"amplitude_run": f"R{table_index(cfg) + 1:03d}",
                                "points": cfg.lut_points,
                                "order": cfg.order, "interpolation": "linear"},
        "phase_run_for_model": f"P{cfg.n_phase_runs:03d}",
        "gate_waveform": "Cardioid(1,2)",
        "parity_phases": ERROR_MODEL.parity_phases, "nominal_shots": 625, **rec,
        # the lab's error model (its own characterisation, Table S2), not the truth
        "error_model": {"nbar": cfg.nbar, "T2_s": cfg.T2,
                        "heating_quanta_per_s": cfg.ndot, "p_prep": cfg.p_prep,
                        "p_det": cfg.p_det, "power_jitter_db": cfg.power_jitter_db,
                        "xi0_rel_err": cfg.xi0_rel_err},
        "units": {"A": "normalised RF amplitude", "power": "photodiode V*us (arbitrary)",
                  "phase_rad": "rad", "P_dB": "dB re unit-amplitude sinusoid in trace volts",
                  "xi0_khz": "kHz", "t_us": "microseconds", "timestamp": "ISO 8601 UTC"},
    }


def _rounded(obj, digits: int = 10):
    """Round every float in a JSON-like object to ``digits`` significant digits."""
    if isinstance(obj, dict):
        return {k: _rounded(v, digits) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_rounded(v, digits) for v in obj]
    if isinstance(obj, float) and np.isfinite(obj):
        return float(f"{obj:.{digits}g}")
    return obj


def _jsonable_config(cfg: CampaignConfig) -> dict:
    d = dict.fromkeys(RETIRED_TRUTH_KEYS, 0.0)
    for f in dataclasses.fields(cfg):
        v = getattr(cfg, f.name)
        if f.name in ("further", "spam_shots", "pulse_traces", "ramsey_shots",
                      "detector_linearity_points", "thermometry_shots") and not v:
            continue        # keeps the truth.json of campaigns without them byte for byte
        if dataclasses.is_dataclass(v):
            v = {k: (abs(x) if isinstance(x, complex) else x)
                 for k, x in dataclasses.asdict(v).items()}
        elif isinstance(v, tuple):
            v = [list(x) if isinstance(x, tuple) else x for x in v]
        d[f.name] = v
    return json.loads(json.dumps(d, default=lambda o: float(np.real(o))))


def _truth_json(truth: dict) -> str:
    # 10 significant digits: independent of BLAS threading in the last bits
    return json.dumps(_rounded(json.loads(json.dumps(truth, default=float))),
                      indent=2, sort_keys=True) + "\n"


def simulate_campaign(outdir: str | os.PathLike, seed: int = DEFAULT_SEED,
                      effects: dict | None = None, *, config: CampaignConfig | None = None,
                      progress=None, include_gates: bool = True) -> dict:
    """Simulate a campaign and write it to ``outdir`` (which must not exist or be empty).

    Files are written into a temporary folder beside ``outdir`` and moved
    into place only when complete.  Returns the ``truth`` dict.  ``progress``:
    None (bars when stderr is a terminal), True, False, or a factory
    ``progress(label, total)`` returning a context manager with ``update()``.
    """
    if progress is None or isinstance(progress, bool):
        show = progress

        def progress(label, total):
            return progress_bar(total=total, desc=label, progress=show)
    out = Path(outdir)
    check_new_folder(out)
    cfg = (config or CampaignConfig(seed=seed))
    cfg = dataclasses.replace(cfg, seed=seed) if config is None else cfg
    # the effects act through their injections' inject_* hooks: the configuration's own
    # parameters (the lab's error model in campaign.json among them) stay nominal
    cfg = cfg.with_effects(effects or {})
    # the engine's small matrices gain nothing from threaded BLAS and, on a loaded
    # machine, its threads made a reduced campaign 5-7x slower (as in the diagnosis)
    with threadpool_limits(limits=1, user_api="blas"):
        truth, files, bundled = _simulated(cfg, progress, include_gates)
    write_folder(out, files, bundled)
    return truth


def _simulated(cfg: CampaignConfig, progress, include_gates: bool):
    """(truth, {file name: text}, bundled traces) of a configured campaign."""
    amp, ph, aom, tf, cal_truth = calibration_runs(cfg)
    lut = dpd_lut(tf, cfg.lut_points)
    spectra, index, bundled = spectra_tables(cfg, aom, lut, progress)
    files = {
        "calibration_amplitude.csv": csv_text(amp),
        "calibration_phase.csv": csv_text(ph),
        "spectra.csv": csv_text(spectra),
        "traces.csv": csv_text(index),
    }
    gate_truth = None
    if include_gates:
        pop, par, rates, ts, gate_truth = gate_tables(cfg, aom, lut, progress)
        files.update({"populations.csv": csv_text(pop), "parity.csv": csv_text(par),
                      "gate_rates.csv": csv_text(rates), "time_scans.csv": csv_text(ts)})
    truth = {"config": _jsonable_config(cfg), "calibration": cal_truth, "gates": gate_truth}
    spam = spam_table(cfg)
    if len(spam):           # only then: the files of campaigns without it stay as they were
        files["spam.csv"] = csv_text(spam)
        truth["spam"] = spam_truth(cfg)
    pulse = pulse_table(cfg, aom)
    if len(pulse):          # as spam.csv: only then
        files["pulse_response.csv"] = csv_text(pulse)
        truth["pulse_response"] = pulse_truth(cfg, aom)
    if cfg.ramsey_shots or any(item[0] == "ramsey" for item in cfg.further):
        refs = gate_references(cfg, aom, lut)
        files["ramsey.csv"] = csv_text(ramsey_table(cfg, refs))
        truth["ramsey"] = ramsey_truth(cfg, refs)
    linearity = linearity_table(cfg, aom)
    if len(linearity):      # only then, as spam.csv
        files["detector_linearity.csv"] = csv_text(linearity)
        truth["detector_linearity"] = linearity_truth(cfg)
    thermo = thermometry_table(cfg)
    if len(thermo):         # as spam.csv: only when recorded
        files["thermometry.csv"] = csv_text(thermo)
        truth["thermometry"] = thermometry_truth(cfg)
    files["campaign.json"] = json.dumps(_campaign_json(cfg, cal_truth), indent=2,
                                        sort_keys=True) + "\n"
    files["truth.json"] = _truth_json(truth)
    files["README.md"] = campaign_readme(f"Synthetic campaign (seed {cfg.seed})", cfg.seed,
                                         cfg.effects)
    return truth, files, bundled
