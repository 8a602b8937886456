"""ARTIQ's own unit rule: a dataset with a ``unit`` and no ``scale`` holds SI values.

ARTIQ's ``set_dataset(..., unit="kHz")`` without ``scale`` stores the value in
Hz and shows it in kHz: ``artiq/tools.py: scale_from_metadata`` takes the
unit's SI factor from ``artiq.language.units`` when ``scale`` is absent.  The
rule is re-derived here independently of dpdfit (ARTIQ is not a dependency),
and every unit a campaign column can take is imported through it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("h5py")

from dpdfit.recordings.campaign_import import import_campaign  # noqa: E402
from dpdfit.recordings.units import ARTIQ_UNITS, scale_from_metadata  # noqa: E402
from dpdfit.simulation.artiq_results_file import write_results_file  # noqa: E402

#: artiq.language.units as ARTIQ 8 defines it, written out by hand from its source
#: (``_register_unit("s", "pnum_")``, ``("Hz", "m_kMG")``, ``("dB", "_")``,
#: ``("V", "um_k")``, ``("A", "um_")``, ``("W", "num_")``)
ARTIQ_8_UNITS = {"ps": 1e-12, "ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0,
                 "mHz": 1e-3, "Hz": 1.0, "kHz": 1e3, "MHz": 1e6, "GHz": 1e9, "dB": 1.0,
                 "uV": 1e-6, "mV": 1e-3, "V": 1.0, "kV": 1e3, "uA": 1e-6, "mA": 1e-3,
                 "A": 1.0, "nW": 1e-9, "uW": 1e-6, "mW": 1e-3, "W": 1.0}


def artiq_scale_from_metadata(metadata: dict) -> float:
    """ARTIQ's rule, as artiq/tools.py writes it."""
    return metadata.get("scale", ARTIQ_8_UNITS.get(metadata.get("unit", ""), 1))


def test_the_unit_table_is_artiqs():
    assert ARTIQ_UNITS == ARTIQ_8_UNITS


@pytest.mark.parametrize("metadata", [{"unit": u} for u in ARTIQ_8_UNITS]
                         + [{"unit": "kHz", "scale": 1.0}, {"unit": "us", "scale": 1e-6},
                            {"unit": "deg"}, {"unit": ""}, {}, {"scale": 2.0}])
def test_scale_from_metadata_follows_artiq(metadata):
    assert scale_from_metadata(metadata) == artiq_scale_from_metadata(metadata)


#: the units each campaign column can be recorded in, with ARTIQ's SI factor: (column, unit)
COLUMN_UNITS = [("t_us", u) for u in ("ps", "ns", "us", "ms", "s")] + \
    [("xi0_khz", u) for u in ("mHz", "Hz", "kHz", "MHz", "GHz")] + \
    [("xi0_err_khz", u) for u in ("Hz", "kHz")] + [("P_dB", "dB"), ("snr_db", "dB")]
#: the column's value in its documented unit
COLUMN_SI = {"t_us": 1e-6, "xi0_khz": 1e3, "xi0_err_khz": 1e3, "P_dB": 1.0, "snr_db": 1.0}
TABLE = {"t_us": "time_scans", "xi0_khz": "gate_rates", "xi0_err_khz": "gate_rates",
         "P_dB": "spectra", "snr_db": "spectra"}


def _mapping(tmp_path, table: str, column: str, extra: str = "") -> str:
    others = {"time_scans": 'A = 0.5\ndpd = 1\nn00 = 10\nn11 = 10\nshots = 40\n',
              "gate_rates": 'A = 0.5\ndpd = 1\nxi0_khz = 20.0\n',
              "spectra": 'A = 0.5\ndpd = 1\nsideband = "red"\nn = 1\nP_dB = -30.0\n'}[table]
    others = "\n".join(line for line in others.splitlines()
                       if not line.startswith(column + " "))
    text = (f'[[calibration_amplitude]]\nfiles = "results/**/*.h5"\n'
            f'[calibration_amplitude.columns]\nA = 0.5\npower = 1.0\n\n'
            f'[[{table}]]\nfiles = "results/**/*.h5"\n[{table}.columns]\n{others}\n'
            f'{column} = {{ dataset = "value"{extra} }}\n')
    path = tmp_path / "map.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("column,unit", COLUMN_UNITS)
def test_a_dataset_with_a_unit_and_no_scale_is_read_in_si(tmp_path, column, unit):
    shown = np.array([12.5, 20.012345678901, 3.25])       # what the dashboard shows
    stored = shown * ARTIQ_8_UNITS[unit]                    # ARTIQ stores SI
    write_results_file(tmp_path, 7, "Exp", 1.7e9, {"value": stored},
                       metadata={"value": {"unit": unit}})
    got = import_campaign(_mapping(tmp_path, TABLE[column], column)).tables[TABLE[column]]
    want = stored / COLUMN_SI[column]
    np.testing.assert_allclose(got[column].to_numpy(), want, rtol=1e-12, atol=0)


def test_a_gate_rate_stored_in_hz_with_unit_khz_equals_the_csv(tmp_path):
    csv_khz = np.array([20.1234567, 18.5, 25.000001])
    write_results_file(tmp_path, 7, "GateRates", 1.7e9, {"value": csv_khz * 1e3},
                       metadata={"value": {"unit": "kHz"}})
    got = import_campaign(_mapping(tmp_path, "gate_rates", "xi0_khz")).tables["gate_rates"]
    rel = np.abs(got["xi0_khz"].to_numpy() / csv_khz - 1)
    assert rel.max() <= 1e-12


def test_an_explicit_scale_still_wins(tmp_path):
    write_results_file(tmp_path, 7, "GateRates", 1.7e9, {"value": np.array([20.5])},
                       metadata={"value": {"unit": "kHz", "scale": 1.0}})
    got = import_campaign(_mapping(tmp_path, "gate_rates", "xi0_khz")).tables["gate_rates"]
    assert got["xi0_khz"].iloc[0] == 20.5


@pytest.mark.parametrize("unit", ["V", "mA", "mW"])
def test_a_unit_of_another_dimension_is_refused_in_one_line(tmp_path, unit):
    from dpdfit.errors import InputError
    write_results_file(tmp_path, 7, "GateRates", 1.7e9, {"value": np.array([20.5])},
                       metadata={"value": {"unit": unit}})
    with pytest.raises(InputError, match="does not convert to xi0_khz") as exc:
        import_campaign(_mapping(tmp_path, "gate_rates", "xi0_khz"))
    assert "\n" not in str(exc.value) and "value" in str(exc.value)


def test_ndscan_quantities_without_a_scale_take_the_units_si_factor(tmp_path):
    from dpdfit.recordings.artiq import read_results_file
    from dpdfit.simulation.artiq_results_file import axis, channel, ndscan_datasets
    ds = ndscan_datasets(3, "exp.Scan", [axis("duration", np.array([1e-6, 2e-6]), "us", 1e-6)],
                         {"rate": channel(np.array([2e4, 3e4]), "kHz", 1e3)})
    import json
    for key in ("ndscan.rid_3.axes", "ndscan.rid_3.channels"):
        spec = json.loads(ds[key])                     # drop every scale
        for q in (spec if isinstance(spec, list) else spec.values()):
            (q.get("param", {}).get("spec", q)).pop("scale", None)
        ds[key] = json.dumps(spec)
    path = write_results_file(tmp_path, 3, "Scan", 1.7e9, ds)
    scan = read_results_file(path).scan()
    assert scan.axis("duration").scale == 1e-6 and scan.channel("rate").scale == 1e3
    assert math.isclose(scan.points(shown=True)["duration"].iloc[1], 2.0)
