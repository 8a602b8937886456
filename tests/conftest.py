import os
import sys

# Small dense problems: threaded BLAS only adds scheduling overhead on a shared
# 2-core machine (must be set before numpy is imported).
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "datasets" / "synthetic_aom"


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

sys.path.insert(0, str(Path(__file__).resolve().parent))   # test-only helpers (exact_ms)


@pytest.fixture(scope="session")
def made(tmp_path_factory):
    """calibration.json, sweep.csv and gate.csv of the bundled data, made once by the CLI."""
    from dpdfit.cli.main import main
    root = Path(__file__).resolve().parents[1]
    amp = root / "datasets" / "synthetic_aom" / "calibration_amplitude.csv"
    camp = root / "datasets" / "synthetic_campaign"
    d = tmp_path_factory.mktemp("made17")
    cal, sweep, gate = d / "c.json", d / "s.csv", d / "g.csv"
    assert main(["calibrate", "--amplitude", str(amp), "-o", str(cal),
                 "--order-scan", "none"]) == 0
    assert main(["sweep", str(cal), "-o", str(sweep), "--amplitudes", "0.05:1:40"]) == 0
    assert main(["fidelity", "--populations", str(camp / "populations.csv"),
                 "--parity", str(camp / "parity.csv"),
                 "--gate-rates", str(camp / "gate_rates.csv"), "-o", str(gate)]) == 0
    return {"cal": cal, "sweep": sweep, "gate": gate}
