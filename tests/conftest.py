import os

# Small dense problems: threaded BLAS only adds scheduling overhead on a shared
# 2-core machine (must be set before numpy is imported).
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
import shutil
import warnings
from pathlib import Path
from typing import NamedTuple

import pytest

from tests.helpers.built_once import built_once
from tests.helpers.bundled_data import AOM, CAMPAIGN


def pytest_collection_modifyitems(config, items):
    """Run the modules with ``slow`` tests first, each module's slow tests before its
    others (a stable sort: the order within each kind is kept).

    With ``-n 2`` a long test collected late would leave one worker running it alone
    after the other has finished; started first, the long tests are shared out while the
    many short ones fill the gaps.  A module's tests stay together: a module-scoped
    fixture that slow and other tests share is made once, not again when the module's
    other tests come round (pytest ends it when the next test is another module's)."""
    def is_slow(item):
        return item.get_closest_marker("slow") is not None

    def module(item):
        return item.nodeid.split("::")[0]

    with_slow = {module(item) for item in items if is_slow(item)}
    first_seen = {}
    for item in items:
        first_seen.setdefault(module(item), len(first_seen))
    items.sort(key=lambda item: (module(item) not in with_slow,
                                 first_seen[module(item)] if module(item) in with_slow else 0,
                                 not is_slow(item)))


@pytest.fixture
def data_dir():
    return AOM


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
    amp = AOM / "calibration_amplitude.csv"
    camp = CAMPAIGN
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
    to a results folder: the suite's most expensive fixture, made once per test run (by
    the first xdist worker that needs it, :func:`~tests.helpers.built_once.built_once`)
    and shared.  Tests only read it; one that changes the Analysis or the folder must
    make its own."""
    from dpdfit.pipeline.analyze import analyze

    def build(folder):
        out = folder / "results"
        return analyze(CAMPAIGN, out, plots=True, diagnosis=True, progress=False), out
    return AnalysedCampaign(*built_once(tmp_path_factory, "bundled_analysis", build))


@pytest.fixture
def bundled_calibration_files(tmp_path):
    """Copies of the bundled amplitude and phase calibration recordings in tmp_path:
    (amp.csv, phase.csv), for commands that may write beside their input."""
    amp, ph = tmp_path / "amp.csv", tmp_path / "phase.csv"
    shutil.copy(AOM / "calibration_amplitude.csv", amp)
    shutil.copy(AOM / "calibration_phase.csv", ph)
    return amp, ph


@pytest.fixture(scope="module")
def bundled_campaign_folder():
    """The bundled campaign, read as a CampaignFolder (tests only read it)."""
    from dpdfit.recordings.campaign_folder import CampaignFolder
    return CampaignFolder(CAMPAIGN)


@pytest.fixture(scope="module")
def bundled_alignment(bundled_campaign_folder):
    """The bundled campaign's alignment fit, built as ``dpdfit analyze`` builds it."""
    import dpdfit
    from dpdfit.analyses.sweep import SweepConfig, run_sweep
    from dpdfit.fits.calibration import Calibration, calibrate_amplitude, calibrate_phase
    from dpdfit.fits.counts.gates import gate_fidelities
    from dpdfit.models.transfer import TransferFunction
    from dpdfit.recordings.tables import read_calibration
    cf, m = bundled_campaign_folder, bundled_campaign_folder.meta
    amp = calibrate_amplitude(read_calibration(CAMPAIGN / "calibration_amplitude.csv",
                                               "amplitude", cf.table_run))
    ph = calibrate_phase(read_calibration(CAMPAIGN / "calibration_phase.csv", "phase",
                                          cf.phase_run))
    sweep = run_sweep(TransferFunction.from_calibration(Calibration(amp, ph, created="-")),
                      SweepConfig(nu=m["nu_hz"], xi0=m["xi0_spectra_hz"],
                                  nbar=m["nbar_assumed"], eta_ref=m["eta_ref"]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tab = gate_fidelities(cf.populations, cf.parity)
    tab = tab.merge(cf.gate_rates[["A", "dpd", "xi0_khz", "xi0_err_khz"]], on=["A", "dpd"])
    return dpdfit.align(tab, sweep, 0.2)
