"""Fidelity estimate and dP_n from recorded heterodyne traces."""

import json

import numpy as np
import pytest

from dpdfit.cli.main import main
from dpdfit.models.fidelity import estimate
from dpdfit.analyses.trace_estimate import delta_powers, trace_estimate
from dpdfit.fits.tones import trace_tone_powers
from dpdfit.simulation.beat_trace import simulate_beat_trace

FS, N, FDET, NU, XI0 = 1e9, 2 ** 20, 20e6, 1.84e6, 20e3


def trace(amps, noise=1e-4, seed=0):
    tones = [(s * (NU + n * XI0), a, 0.0) for s in (1, -1) for n, a in amps.items()]
    return simulate_beat_trace(FS, N, FDET, tones, noise_rms=noise, rng=np.random.default_rng(seed))


def test_estimate_uses_measured_powers():
    res = trace_tone_powers(trace({0: 3e-3, 1: 0.2, 2: 0.2, 3: 1e-3}), FS, FDET, NU, XI0)
    e = trace_estimate(res)
    P = [res.blue.P_dB[n] for n in (0, 1, 2, 3)]
    assert e["blue"]["F_est"] == pytest.approx(float(estimate(P).F_est), abs=1e-15)
    assert e["F_est"] == pytest.approx(0.5 * (e["red"]["F_est"] + e["blue"]["F_est"]))
    assert e["limit"] is None
    # the n=0 tone at -36.5 dBc gives an infidelity of order 1e-4 (exact formula, nbar 0.1)
    assert 1e-5 < e["eps_est"] < 1e-3


def test_buried_im_tone_makes_a_lower_limit():
    res = trace_tone_powers(trace({0: 1e-7, 1: 0.2, 2: 0.2, 3: 1e-3}, noise=1e-3), FS, FDET, NU, XI0)
    assert not res.blue.valid[0]
    e = trace_estimate(res)
    assert e["limit"] == "lower" and e["blue"]["limit"] == "lower"


def test_invalid_gate_tone_gives_no_estimate():
    res = trace_tone_powers(trace({0: 1e-3, 1: 0.2, 2: 1e-6, 3: 1e-3}, noise=1e-3), FS, FDET, NU, XI0)
    e = trace_estimate(res)
    assert e["F_est"] is None and e["blue"]["F_est"] is None


def test_delta_powers_and_cli(tmp_path, capsys):
    a = trace({0: 1e-3, 1: 0.25, 2: 0.25, 3: 1e-3}, seed=1)
    b = trace({0: 3e-3, 1: 0.2, 2: 0.2, 3: 2e-3}, seed=2)
    ra, rb = (trace_tone_powers(x, FS, FDET, NU, XI0) for x in (a, b))
    dp = delta_powers(ra, rb)
    assert dp["mean"]["1"] == pytest.approx(20 * np.log10(0.25 / 0.2), abs=0.02)
    assert dp["mean"]["0"] == pytest.approx(20 * np.log10(1 / 3), abs=0.1)
    np.save(tmp_path / "a.npy", a)
    np.save(tmp_path / "b.npy", b)
    code = main(["spectrum", str(tmp_path / "a.npy"), "--fs", "1e9", "--fdet", "20e6", "--nu",
                 "1.84e6", "--xi0", "20e3", "--json", "--estimate", "--compare",
                 str(tmp_path / "b.npy")])
    out, err = capsys.readouterr()
    assert code == 0, err
    d = json.loads(out)
    assert set(d["estimate"]) >= {"F_est", "eps_est", "red", "blue", "limit"}
    assert d["dP_dB"]["mean"]["1"] == pytest.approx(dp["mean"]["1"])
