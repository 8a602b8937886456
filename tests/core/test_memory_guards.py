"""Memory guards (dpdfit.core.memory): a too-large input is refused in one line, not killed.

Cheap: the limit is lowered (environment variable or module constant) instead
of allocating large arrays.
"""

import numpy as np
import pytest

from dpdfit.core import memory
from dpdfit.errors import InputError
from dpdfit.fits.tones import trace_tone_powers
from dpdfit.recordings.tables import read_calibration, read_calibration_runs, read_table
from dpdfit.recordings.traces import as_trace, load_trace


def test_limit_from_environment(monkeypatch):
    monkeypatch.setenv(memory.MEMORY_ENV, "2.5")
    assert memory.memory_limit_bytes() == 2.5e9


def test_default_limit_at_most_the_constant(monkeypatch):
    monkeypatch.delenv(memory.MEMORY_ENV, raising=False)
    assert 0 < memory.memory_limit_bytes() <= memory.MAX_MEMORY_GB * 1e9


@pytest.mark.parametrize("bad", ["zero", "0", "-1", "nan"])
def test_bad_environment_value_is_one_line(monkeypatch, bad):
    monkeypatch.setenv(memory.MEMORY_ENV, bad)
    with pytest.raises(InputError, match="DPDFIT_MAX_MEMORY_GB=.* must be a positive number"):
        memory.memory_limit_bytes()


def test_check_memory_message(monkeypatch):
    monkeypatch.setenv(memory.MEMORY_ENV, "1")
    memory.check_memory(0.9e9, "x")
    with pytest.raises(InputError) as e:
        memory.check_memory(3e9, "a trace of 5 samples", file="t.npy", hint="do less")
    msg = str(e.value)
    assert msg == ("t.npy: a trace of 5 samples needs about 3 GB of memory, above the limit "
                   "of 1 GB (DPDFIT_MAX_MEMORY_GB); do less")
    assert "\n" not in msg


def test_trace_file_refused(monkeypatch, tmp_path):
    p = tmp_path / "trace.npz"
    np.savez(p, trace=np.zeros(4096, dtype=np.int16), scale=np.array(1e-3))
    assert load_trace(p).size == 4096
    # 4096 samples * 48 B = 197 kB > 100 kB
    monkeypatch.setenv(memory.MEMORY_ENV, "1e-4")
    with pytest.raises(InputError, match=r"trace\.npz: a trace of 4096 samples needs about "
                                         r"0\.000197 GB of memory, above the limit of 0\.0001 GB"):
        load_trace(p)


def test_trace_in_memory_refused(monkeypatch):
    monkeypatch.setattr(memory, "MAX_MEMORY_GB", 1e-6)
    monkeypatch.delenv(memory.MEMORY_ENV, raising=False)
    with pytest.raises(InputError, match="a trace of 1024 samples needs about"):
        as_trace(np.zeros(1024))
    with pytest.raises(InputError, match="a trace of 1024 samples"):
        trace_tone_powers(np.zeros(1024), 1e9, 20e6, 1.84e6, 20e3)


def test_table_refused(monkeypatch, tmp_path):
    p = tmp_path / "cal.csv"
    p.write_text("A,power\n" + "".join(f"{a:.3f},{a * a:.6f}\n" for a in np.linspace(0, 1, 50)))
    assert len(read_table(p, ["A", "power"])) == 50
    monkeypatch.setenv(memory.MEMORY_ENV, "1e-6")       # 1 kB < ~900 B x 12
    with pytest.raises(InputError, match=r"cal\.csv: reading this table needs about .* GB of "
                                         r"memory, above the limit"):
        read_table(p, ["A", "power"])


def test_calibration_runs_read_once_equal_read_per_run(tmp_path):
    rows = ["run,timestamp,A,power,power_err"]
    for r, day in (("R1", 1), ("R2", 3), ("R3", 2)):
        for a in np.linspace(0, 1, 11):
            rows.append(f"{r},2025-01-0{day}T00:00:00Z,{a:.2f},{a * day:.4f},0.01")
    p = tmp_path / "amp.csv"
    p.write_text("\n".join(rows) + "\n")
    runs = read_calibration_runs(p, "amplitude")
    assert list(runs) == ["R1", "R2", "R3"]
    for r, d in runs.items():
        one = read_calibration(p, "amplitude", r)
        assert d.run == one.run and d.timestamp == one.timestamp and d.source == one.source
        for f in ("A", "value", "error", "rows"):
            np.testing.assert_array_equal(getattr(d, f), getattr(one, f))
