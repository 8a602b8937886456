import os

# Small dense problems: threaded BLAS only adds scheduling overhead on a shared
# 2-core machine (must be set before numpy is imported).
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "datasets" / "synthetic_aom"
BUNDLED_CAMPAIGN = ROOT / "datasets" / "synthetic_campaign"


@pytest.fixture
def data_dir():
    return DATA


@pytest.fixture
def write_csv(tmp_path):
    """Write text to a CSV file in tmp_path and return its path."""
    def _write(text, name="data.csv"):
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


@pytest.fixture(scope="session")
def cli_outputs(tmp_path_factory):
    """calibration.json, sweep.csv and gate.csv of the bundled data, made once by the CLI."""
    from dpdfit.cli.main import main
    root = Path(__file__).resolve().parents[1]
    amp = root / "datasets" / "synthetic_aom" / "calibration_amplitude.csv"
    camp = root / "datasets" / "synthetic_campaign"
    d = tmp_path_factory.mktemp("cli_outputs")
    cal, sweep, gate = d / "c.json", d / "s.csv", d / "g.csv"
    assert main(["calibrate", "--amplitude", str(amp), "-o", str(cal),
                 "--order-scan", "none"]) == 0
    assert main(["sweep", str(cal), "-o", str(sweep), "--amplitudes", "0.05:1:40"]) == 0
    assert main(["fidelity", "--populations", str(camp / "populations.csv"),
                 "--parity", str(camp / "parity.csv"),
                 "--gate-rates", str(camp / "gate_rates.csv"), "-o", str(gate)]) == 0
    return {"cal": cal, "sweep": sweep, "gate": gate}


class AnalysedCampaign(NamedTuple):
    analysis: object   # the dpdfit.Analysis that analyze returned
    results: Path      # the results folder it wrote


@pytest.fixture(scope="session")
def bundled_analysis(tmp_path_factory):
    """``analyze`` on the bundled campaign with everything on (figures, diagnosis), written
    to a results folder: the suite's most expensive fixture, made once per test process
    (per xdist worker) and shared.  Tests only read it; one that changes the Analysis or
    the folder must make its own."""
    from dpdfit.pipeline.analyze import analyze
    out = tmp_path_factory.mktemp("bundled_analysis") / "results"
    res = analyze(BUNDLED_CAMPAIGN, out, plots=True, diagnosis=True, progress=False)
    return AnalysedCampaign(res, out)
