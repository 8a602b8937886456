"""Heterodyne trace -> tone powers (Supplement S4): dpdfit.fits.tones (trace_tone_powers)."""

from __future__ import annotations

import argparse
import json
import math
import pickle

import numpy as np
import pytest
from scipy import signal

from dpdfit.core.jsonable import to_jsonable
from dpdfit.errors import DpdfitError, InputError
from dpdfit.cli.spectrum import add_spectrum_command
from dpdfit.fits.tones import (AT_NOISE_FLOOR, FLATTOP_COEFFICIENTS, flattop_periodogram,
                               trace_tone_powers)
from dpdfit.recordings.traces import load_trace
from dpdfit.simulation.beat_trace import simulate_beat_trace

# Scaled-down recording (fast tests): 100 MS/s for 1.3 ms -> bins of 763 Hz,
# main lobe +/-3.8 kHz, well inside xi0/2 = 10 kHz.
FS, N, FDET, NU, XI0 = 100e6, 2**17, 20e6, 1.84e6, 20e3
AMPS = {0: 0.03, 1: 1.0, 2: 0.6, 3: 0.05}


def db(a):
    return 20 * math.log10(a)


def tones_for(amps_red, amps_blue=None, nu=NU, xi0=XI0, shift=None, seed=0):
    """(offset, amplitude, phase) list; shift = {(sideband, n): extra Hz}."""
    amps_blue = amps_red if amps_blue is None else amps_blue
    rng = np.random.default_rng(seed)
    out = []
    for sign, amps, sb in ((-1, amps_red, "red"), (1, amps_blue, "blue")):
        for n, a in amps.items():
            if a:
                extra = (shift or {}).get((sb, n), 0.0)
                out.append((sign * (nu + n * xi0) + extra, a, rng.uniform(0, 2 * np.pi)))
    return out


def trace(amps_red=AMPS, amps_blue=None, noise=0.0, f_det=FDET, n=N, shift=None, seed=1):
    return simulate_beat_trace(FS, n, f_det, tones_for(amps_red, amps_blue, shift=shift,
                                                       seed=seed), noise, rng=seed)


# ----------------------------------------------------------------------------- periodogram


def test_window_coefficients_are_scipys_flattop():
    n = 1000
    k = np.arange(n)
    w = sum((-1) ** j * a * np.cos(2 * np.pi * j * k / n)
            for j, a in enumerate(FLATTOP_COEFFICIENTS))
    np.testing.assert_allclose(w, signal.get_window("flattop", n), rtol=0, atol=1e-15)


@pytest.mark.parametrize("n", [4096, 4097])
def test_flattop_periodogram_equals_scipy(n):
    rng = np.random.default_rng(3)
    t = np.arange(n)
    x = 3.0 + rng.standard_normal(n) + 2 * np.cos(2 * np.pi * 0.1234 * t) + np.cos(
        2 * np.pi * 0.49 * t)
    f_ref, p_ref = signal.periodogram(x, 1e6, window="flattop", scaling="spectrum")
    f, p = flattop_periodogram(x, 1e6)
    np.testing.assert_allclose(f, f_ref, rtol=1e-15)
    np.testing.assert_allclose(p, p_ref, rtol=1e-9, atol=1e-13 * p_ref.max())
    fb, pb = flattop_periodogram(x, 1e6, 100e3, 130e3)   # a band only
    sel = (f_ref >= 100e3) & (f_ref <= 130e3)
    np.testing.assert_allclose(fb, f_ref[sel])
    np.testing.assert_allclose(pb, p_ref[sel], rtol=1e-9, atol=1e-13 * p_ref.max())


# ----------------------------------------------------------------------------- powers


def test_tone_powers_at_any_position_between_bins():
    df = FS / N
    k0 = round(FDET / df)
    worst = 0.0
    for frac in np.linspace(0.0, 1.0, 11):
        f_det = (k0 + frac) * df      # every tone moves by frac bins (xi0/df ~ 26.2 adds more)
        res = trace_tone_powers(trace(f_det=f_det, seed=int(frac * 10)), FS, f_det, NU, XI0)
        for sb in (res.red, res.blue):
            for n, a in AMPS.items():
                assert sb.valid[n], (frac, sb.name, n, sb.reason[n])
                worst = max(worst, abs(sb.P_dB[n] - db(a)))
            for n in (1, 2):
                assert abs(sb.freq_error_hz[n]) < 1.0
    assert worst <= 0.02, worst


def test_noise_floor_is_the_median_of_the_band():
    sigma = 1e-3
    res = trace_tone_powers(trace(noise=sigma, seed=5), FS, FDET, NU, XI0)
    a = np.asarray(FLATTOP_COEFFICIENTS)
    enbw_bins = (a[0] ** 2 + np.sum(a[1:] ** 2) / 2) / a[0] ** 2
    assert res.enbw_hz == pytest.approx(enbw_bins * FS / N)
    # white noise: mean bin power (in a^2 units) 4 sigma^2 ENBW / N, exponential -> median ln2 x
    expect = 10 * math.log10(math.log(2) * 4 * sigma ** 2 * enbw_bins / N)
    assert res.noise_floor_dB == pytest.approx(expect, abs=0.5)
    lo, hi = res.noise_band_hz
    assert lo == pytest.approx(FDET - (NU + 3 * XI0) - 2 * XI0)
    assert hi == pytest.approx(FDET + (NU + 3 * XI0) + 2 * XI0)
    for sb in (res.red, res.blue):
        for n, amp in AMPS.items():
            assert sb.snr_db[n] == pytest.approx(sb.P_dB[n] - res.noise_floor_dB)
            assert sb.P_dB[n] == pytest.approx(db(amp), abs=0.1)


def test_ratio_arithmetic_and_contract():
    res = trace_tone_powers(trace(AMPS, {0: 0.01, 1: 1.0, 2: 0.5, 3: 0.02}), FS, FDET, NU, XI0)
    for sb in (res.red, res.blue):
        assert sb.R10_dB == pytest.approx(sb.P_dB[1] - sb.P_dB[0], abs=1e-12)
        assert sb.R23_dB == pytest.approx(sb.P_dB[2] - sb.P_dB[3], abs=1e-12)
        assert sb.R10_limit is None and sb.R23_limit is None
    assert res.red.R10_dB == pytest.approx(db(1.0 / 0.03), abs=0.03)
    assert res.blue.R23_dB == pytest.approx(db(0.5 / 0.02), abs=0.03)
    assert res.R10_dB == pytest.approx((res.red.R10_dB + res.blue.R10_dB) / 2)
    assert res.R23_dB == pytest.approx((res.red.R23_dB + res.blue.R23_dB) / 2)
    d = json.loads(json.dumps(to_jsonable(res.to_dict())))
    for sb in ("red", "blue"):
        assert set(d[sb]["P_dB"]) == set(d[sb]["valid"]) == {"0", "1", "2", "3"}
        assert d[sb]["valid"] == {"0": True, "1": True, "2": True, "3": True}
        assert d[sb]["R10_dB"] == pytest.approx(getattr(res, sb).R10_dB)
    assert d["R10_dB"] == pytest.approx(res.R10_dB) and d["R23_dB"] == pytest.approx(res.R23_dB)
    text = res.report()
    assert "R10" in text and "red sideband" in text and "noise floor" in text
    assert pickle.loads(pickle.dumps(res)) == res
    with pytest.raises(TypeError):
        res.red.P_dB[1] = 0.0


def test_any_harmonics_including_negative():
    amps = {-1: 0.02, 0: 0.03, 1: 1.0, 2: 0.6, 3: 0.05, 4: 0.01}
    res = trace_tone_powers(trace(amps), FS, FDET, NU, XI0, harmonics=(-1, 0, 1, 2, 3, 4))
    for n, a in amps.items():
        assert res.blue.P_dB[n] == pytest.approx(db(a), abs=0.02)
        assert res.red.expected_hz[n] == pytest.approx(FDET - (NU + n * XI0))
    assert res.harmonics == (-1, 0, 1, 2, 3, 4)
    # without harmonic 0 there is no R10
    res = trace_tone_powers(trace(), FS, FDET, NU, XI0, harmonics=(1, 2, 3))
    assert res.red.R10_dB is None and res.R10_dB is None and res.R23_dB is not None


# ----------------------------------------------------------------------------- validation


def test_gate_tone_too_weak_is_invalid_on_its_sideband_only():
    weak = {**AMPS, 2: 1e-5}
    res = trace_tone_powers(trace(weak, AMPS, noise=1e-3), FS, FDET, NU, XI0)
    assert not res.red.valid[2]
    assert "SNR" in res.red.reason[2]
    assert res.red.snr_db[2] < 20
    assert res.red.R23_dB is None and res.R23_dB is None and res.R23_limit is None
    assert res.red.valid[1] and res.red.R10_dB is not None
    assert all(res.blue.valid.values()) and res.blue.R23_dB is not None
    assert res.to_dict()["red"]["valid"]["2"] is False


def test_displaced_gate_tone_is_found_but_invalid():
    res = trace_tone_powers(trace(noise=1e-4, shift={("blue", 1): 2000.0}), FS, FDET, NU, XI0)
    b = res.blue
    assert not b.valid[1]
    assert "frequency error" in b.reason[1]
    assert b.freq_error_hz[1] == pytest.approx(2000.0, abs=50)
    assert b.found_hz[1] == pytest.approx(FDET + NU + XI0 + 2000.0, abs=50)
    assert b.P_dB[1] == pytest.approx(0.0, abs=0.02)     # found and measured, but not used
    assert b.R10_dB is None and res.R10_dB is None
    assert res.red.valid[1] and res.red.R10_dB is not None
    # displaced less than the 1 kHz tolerance: valid
    res = trace_tone_powers(trace(noise=1e-4, shift={("blue", 1): 600.0}), FS, FDET, NU, XI0)
    assert res.blue.valid[1] and res.blue.freq_error_hz[1] == pytest.approx(600, abs=30)


def test_im_tone_at_noise_floor_gives_a_lower_limit():
    quiet = {**AMPS, 0: 0.0}
    res = trace_tone_powers(trace(quiet, AMPS, noise=1e-3), FS, FDET, NU, XI0)
    r = res.red
    assert not r.valid[0] and r.reason[0] == AT_NOISE_FLOOR
    assert r.snr_db[0] < 10
    assert r.R10_dB == pytest.approx(r.P_dB[1] - r.P_dB[0]) and r.R10_limit == "lower"
    assert res.blue.valid[0] and res.blue.R10_limit is None
    assert res.R10_limit == "lower"
    assert res.R10_dB == pytest.approx((r.R10_dB + res.blue.R10_dB) / 2)
    d = res.to_dict()
    assert d["red"]["R10_limit"] == "lower" and d["R10_limit"] == "lower"
    assert d["red"]["valid"]["0"] is False
    assert ">" in res.report()


def test_swap_sidebands():
    red_amps = {0: 0.02, 1: 0.5, 2: 0.3, 3: 0.04}
    x = trace(red_amps, AMPS)
    plain = trace_tone_powers(x, FS, FDET, NU, XI0)
    swapped = trace_tone_powers(x, FS, FDET, NU, XI0, swap_sidebands=True)
    assert plain.red.P_dB[1] == pytest.approx(db(0.5), abs=0.02)
    assert swapped.red.P_dB[1] == pytest.approx(db(1.0), abs=0.02)
    for n in AMPS:
        assert swapped.red.P_dB[n] == plain.blue.P_dB[n]
        assert swapped.blue.P_dB[n] == plain.red.P_dB[n]
        assert swapped.red.expected_hz[n] == pytest.approx(FDET + NU + n * XI0)
    assert swapped.red.sign == 1 and swapped.blue.sign == -1 and swapped.swap_sidebands


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("kwargs, match", [
    (dict(x=np.zeros(2**15)), r"too short to resolve xi0.*5\*fs/N < xi0/2.*need more than 50000"),
    (dict(fs=40e6), r"sample rate too low: fs/2"),
    (dict(f_det=1.5e6), r"red tone n=3 at -400 kHz is at or below 0 Hz"),
    (dict(search_hz=18e3), r"requested tones collide"),
    (dict(nu=40e3, harmonics=(-2, 1, 2)),
     r"collide: (blue|red) n=-2 at 20 MHz and (blue|red) n=-2 at 20 MHz are 0 Hz apart"),
    (dict(fs=0.0), r"fs must be > 0"),
    (dict(fs=float("nan")), r"fs must be finite"),
    (dict(gate=(1, 2), harmonics=(0, 1, 3)), r"gate harmonic\(s\) \[2\] are not among"),
    (dict(harmonics=(0, 1, 1, 2)), r"more than once"),
    (dict(harmonics=(0, 1.5)), r"not an integer"),
    (dict(x=np.ones((2, 10))), r"1-D array"),
])
def test_bad_input(kwargs, match):
    kw = dict(kwargs)
    x = kw.pop("x", None)
    x = np.random.default_rng(0).standard_normal(N) if x is None else x
    args = dict(fs=FS, f_det=FDET, nu=NU, xi0=XI0)
    args.update({k: kw.pop(k) for k in list(kw) if k in args})
    with pytest.raises(InputError, match=match) as exc:
        trace_tone_powers(x, args["fs"], args["f_det"], args["nu"], args["xi0"], **kw)
    assert "\n" not in str(exc.value)


def test_non_finite_sample_and_empty_band():
    x = np.random.default_rng(0).standard_normal(N)
    x[41] = np.inf
    with pytest.raises(InputError, match=r"row 42: sample is inf"):
        trace_tone_powers(x, FS, FDET, NU, XI0)
    with pytest.raises(InputError, match="no power in the detection band"):
        trace_tone_powers(np.zeros(N), FS, FDET, NU, XI0)


# ----------------------------------------------------------------------------- loading


def test_load_npy_npz(tmp_path):
    x = np.array([1.5, -2.0, 3.25])
    np.save(tmp_path / "f.npy", x)
    np.testing.assert_array_equal(load_trace(tmp_path / "f.npy"), x)
    counts = np.array([100, -200, 300], dtype=np.int16)
    np.save(tmp_path / "i.npy", counts)
    y = load_trace(tmp_path / "i.npy")
    assert y.dtype == np.float64 and list(y) == [100, -200, 300]
    np.savez(tmp_path / "s.npz", trace=counts, scale=np.float64(0.5e-3))
    np.testing.assert_allclose(load_trace(tmp_path / "s.npz"), counts * 0.5e-3)
    np.savez(tmp_path / "n.npz", trace=counts)
    np.testing.assert_array_equal(load_trace(tmp_path / "n.npz"), counts)
    np.savez(tmp_path / "bad.npz", data=counts)
    with pytest.raises(InputError, match=r"bad.npz: no array 'trace'"):
        load_trace(tmp_path / "bad.npz")
    np.savez(tmp_path / "sc.npz", trace=counts, scale=np.array([1.0, 2.0]))
    with pytest.raises(InputError, match="'scale' must be one real number"):
        load_trace(tmp_path / "sc.npz")
    np.save(tmp_path / "nan.npy", np.array([1.0, np.nan, 2.0]))
    with pytest.raises(InputError, match=r"nan.npy, row 2: sample is nan"):
        load_trace(tmp_path / "nan.npy")
    np.save(tmp_path / "two.npy", np.zeros((5, 2)))
    with pytest.raises(InputError, match=r"two.npy: trace must be a 1-D"):
        load_trace(tmp_path / "two.npy")
    np.save(tmp_path / "c.npy", np.zeros(4, complex))
    with pytest.raises(InputError, match="complex"):
        load_trace(tmp_path / "c.npy")
    np.save(tmp_path / "e.npy", np.zeros(0))
    with pytest.raises(InputError, match="no samples"):
        load_trace(tmp_path / "e.npy")
    with pytest.raises(InputError, match="file not found"):
        load_trace(tmp_path / "missing.npy")
    (tmp_path / "t.bin").write_bytes(b"\0")
    with pytest.raises(InputError, match="unsupported file type"):
        load_trace(tmp_path / "t.bin")


def test_load_csv(write_csv):
    np.testing.assert_array_equal(load_trace(write_csv("v\n1.0\n-2\n3e-3\n")), [1.0, -2, 3e-3])
    np.testing.assert_array_equal(load_trace(write_csv("# scope dump\n1\n2\n\n3\n")), [1, 2, 3])
    with pytest.raises(InputError, match=r"data.csv, column 'v', row 2: 'abc' is not a number"):
        load_trace(write_csv("v\n1\nabc\n3\n"))
    with pytest.raises(InputError, match=r"data.csv, row 3: value is nan"):
        load_trace(write_csv("1\n2\nnan\n"))
    with pytest.raises(InputError, match=r"2 columns in the first line; expected one column"):
        load_trace(write_csv("t,v\n0,1\n"))
    with pytest.raises(InputError, match=r"more than one column"):
        load_trace(write_csv("v\n1\n2,3\n4\n"))
    with pytest.raises(InputError, match="empty"):
        load_trace(write_csv("# nothing\n\n"))
    with pytest.raises(InputError, match="header but no samples"):
        load_trace(write_csv("v\n"))


# ----------------------------------------------------------------------------- CLI


def _cli(argv):
    parser = argparse.ArgumentParser(prog="dpdfit")
    add_spectrum_command(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


def test_cli_spectrum(tmp_path, capsys):
    x = trace(noise=1e-4)
    np.save(tmp_path / "trace.npy", x)
    common = ["--fs", str(FS), "--fdet", str(FDET), "--nu", str(NU), "--xi0", str(XI0)]
    assert _cli(["spectrum", str(tmp_path / "trace.npy"), *common, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["red"]["P_dB"]) == {"0", "1", "2", "3"}
    assert d["blue"]["P_dB"]["1"] == pytest.approx(0.0, abs=0.02)
    assert d["R10_dB"] == pytest.approx(db(1 / 0.03), abs=0.05)
    (tmp_path / "trace.csv").write_text("signal\n" + "\n".join(repr(float(v)) for v in x) + "\n")
    assert _cli(["spectrum", str(tmp_path / "trace.csv"), *common, "--harmonics=-1,0,1,2,3",
                 "--swap-sidebands"]) == 0
    out = capsys.readouterr().out
    assert "[[red sideband]] f_det + (nu + n xi0)" in out and "R23" in out
    with pytest.raises(DpdfitError, match=r"trace.npy: trace too short"):
        _cli(["spectrum", str(tmp_path / "trace.npy"), "--fs", "1e9", "--fdet", "2e7",
              "--nu", "1.84e6", "--xi0", "2e4"])
    with pytest.raises(DpdfitError, match=r"--harmonics: 'x' is not an integer"):
        _cli(["spectrum", str(tmp_path / "trace.npy"), *common, "--harmonics", "0,x"])
