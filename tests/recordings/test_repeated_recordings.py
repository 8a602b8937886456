"""Repeated recordings of one setting: every table of the campaign folder accepts them,
pools them as repeated measurements are pooled, and refuses repeats that contradict
each other beyond their noise (one line naming file, rows and setting; exit 2)."""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from dpdfit.analyses.diagnosis.model.tones.tone_noise import learn_tone_noise
from dpdfit.analyses.diagnosis.observables.tone_features import (TONE_HARMONICS,
                                                                 debias_tones,
                                                                 tone_features)
from dpdfit.errors import InputError
from dpdfit.recordings.campaign_folder import CampaignFolder
from dpdfit.recordings.counts import read_time_scans
from dpdfit.recordings.gate_rates import read_gate_rates
from dpdfit.recordings.spectra import check_spectra_repeats, pool_spectra, read_spectra
from tests.helpers.cli_refusal import assert_refused
from tests.helpers.paths import ROOT

BUNDLED = ROOT / "datasets" / "synthetic_campaign"


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _db(x):
    return 10 * np.log10(x)


# ----------------------------------------------------------------------------- spectra
SPECTRA = """A,dpd,sideband,n,P_dB,valid,snr_db
0.5,0,red,1,-20.0,1,60.0
0.5,0,red,2,-21.0,1,59.0
0.5,1,red,1,-19.0,1,61.0
0.5,0,red,1,-20.5,1,59.7
0.5,0,red,2,-21.3,0,58.9
"""


def test_repeated_tones_are_pooled_as_the_mean_linear_power(tmp_path):
    reads = read_spectra(_write(tmp_path / "spectra.csv", SPECTRA))
    # the k-th row of a tone is its k-th repeat
    assert reads["repeat"].tolist() == ["1", "1", "1", "2", "2"]
    pooled = pool_spectra(reads).set_index(["A", "dpd", "sideband", "n"])
    assert len(pooled) == 3
    one = pooled.loc[(0.5, 0, "red", 1)]
    assert one["n_repeats"] == 2 and one["valid"] == 1
    assert one["P_dB"] == pytest.approx(_db((10 ** -2.0 + 10 ** -2.05) / 2), abs=1e-12)
    # the pooled reading's floor is the mean of the repeats' floors (-80 and -80.2 dB)
    floor = _db((10 ** -8.0 + 10 ** -8.02) / 2)
    assert one["snr_db"] == pytest.approx(one["P_dB"] - floor, abs=1e-12)
    # a tone valid in one repeat is valid: it was seen, and the mean of all its
    # readings is an unbiased reading
    two = pooled.loc[(0.5, 0, "red", 2)]
    assert two["valid"] == 1 and two["n_repeats"] == 2
    assert two["P_dB"] == pytest.approx(_db((10 ** -2.1 + 10 ** -2.13) / 2), abs=1e-12)
    # a tone read once keeps its values to the last bit
    single = pooled.loc[(0.5, 1, "red", 1)]
    assert single["P_dB"] == -19.0 and single["snr_db"] == 61.0 and single["n_repeats"] == 1


def test_a_repeat_column_labels_the_repeats_and_names_a_tone_twice_in_one(tmp_path):
    text = "A,dpd,sideband,n,P_dB,repeat\n" \
           "0.5,0,red,1,-20.0,a\n0.5,0,red,1,-20.5,b\n0.5,0,red,2,-21.0,b\n0.5,0,red,2,-21.2,a\n"
    reads = read_spectra(_write(tmp_path / "spectra.csv", text))
    assert reads["repeat"].tolist() == ["a", "b", "b", "a"]
    assert (pool_spectra(reads)["n_repeats"] == 2).all()
    bad = _write(tmp_path / "bad.csv", text + "0.5,0,red,2,-21.4,a\n")
    with pytest.raises(InputError, match=r"bad.csv, column 'repeat', row 5: tone \(A=0.5, "
                                         r"dpd=0, red, n=2\) appears twice in repeat a "
                                         r"\(rows 4, 5"):
        read_spectra(bad)


def test_a_trace_or_a_line_pasted_twice_is_refused_an_equal_reading_is_not(tmp_path):
    head, *rows = SPECTRA.splitlines()
    # a third repeat of the trace whose every row copies an earlier one: pasted
    pasted = _write(tmp_path / "pasted.csv", "\n".join([head, *rows, rows[0], rows[1]]) + "\n")
    with pytest.raises(InputError, match=r"pasted.csv, row 6: rows 6, 7 .*copy rows 1, 2 "
                                         r".*in every column: a trace pasted twice"):
        read_spectra(pasted)
    one = _write(tmp_path / "one.csv", "\n".join([head, *rows, rows[2]]) + "\n")
    with pytest.raises(InputError, match=r"row 6 .*copies row 3 .*a line pasted twice"):
        read_spectra(one)
    # a genuine repeat in which one reading happens to equal an earlier one to the digit
    again = "0.5,0,red,1,-20.0,1,60.0\n0.5,0,red,2,-21.1,1,58.8\n"
    ok = read_spectra(_write(tmp_path / "ok.csv", SPECTRA + again))
    assert ok["repeat"].tolist()[-2:] == ["3", "3"]


def test_a_repeat_whose_readings_each_equal_a_different_earlier_repeat_is_not_a_copy(tmp_path):
    # powers written to 0.001 dB: over many repeats every reading of a new repeat may
    # equal some earlier reading, each from a different repeat; only a whole earlier
    # repeat read again is a copy
    head = "A,dpd,sideband,n,P_dB\n"
    r1 = "0.5,0,red,1,-20.001\n0.5,0,red,2,-21.004\n0.5,0,red,3,-30.010\n"
    r2 = "0.5,0,red,1,-20.003\n0.5,0,red,2,-21.002\n0.5,0,red,3,-30.012\n"
    r3 = "0.5,0,red,1,-20.001\n0.5,0,red,2,-21.002\n0.5,0,red,3,-30.011\n"
    r4 = "0.5,0,red,1,-20.003\n0.5,0,red,2,-21.004\n0.5,0,red,3,-30.011\n"
    ok = read_spectra(_write(tmp_path / "many.csv", head + r1 + r2 + r3 + r4))
    assert ok["repeat"].tolist()[-3:] == ["4", "4", "4"]
    # the same rows, the fourth repeat now a whole copy of the second: refused, naming it
    with pytest.raises(InputError, match=r"rows 10, 11, 12 .*of trace \(A=0.5, dpd=0, red\) "
                                         r"copy rows 4, 5, 6 .*\(its repeat 2\) in every "
                                         r"column: a trace pasted twice"):
        read_spectra(_write(tmp_path / "copied.csv", head + r1 + r2 + r3 + r2))


def _tone_table(rng, amplitudes, repeats, *, jitter_db=2.0, repeat_db=0.05,
                floor_db=-90.0):
    """A spectra.csv table as a lab records it: every amplitude in ``amplitudes`` recorded
    ``repeats[A]`` times (appended in turn), each repeat trace (A, dpd) with its laser-power
    jitter, each tone with its repeatability and the floor's Rician noise."""
    N0 = 10 ** (floor_db / 10)
    rows = []
    order = list(amplitudes) + [A for A in amplitudes for _ in range(repeats.get(A, 1) - 1)]
    for A in order:
        for d in (0, 1):
            g = 10 ** (jitter_db * rng.standard_normal() / 10)
            for sb in ("red", "blue"):
                for n in TONE_HARMONICS:
                    gate = n in (1, 2)
                    P = (-18.0 + 20 * np.log10(A) if gate
                         else -48.0 + 60 * np.log10(A / 0.5) - 2.0 * abs(n - 1.5) - 3 * d)
                    c2 = g * 10 ** ((P + repeat_db * rng.standard_normal()) / 10)
                    noise = np.sqrt(N0 / 2) * (rng.standard_normal() + 1j * rng.standard_normal())
                    x = abs(np.sqrt(c2) + noise) ** 2
                    rows.append({"A": A, "dpd": d, "sideband": sb, "n": n,
                                 "P_dB": 10 * np.log10(x), "valid": 1,
                                 "snr_db": 10 * np.log10(x / (N0 * np.log(2)))})
    df = pd.DataFrame(rows)
    df["repeat"] = (df.groupby(["A", "dpd", "sideband", "n"], sort=False).cumcount() + 1
                    ).astype(str)
    return df


@pytest.mark.slow
def test_honest_repeats_pass_and_a_contradicting_reading_is_refused():
    """0.05 dB repeatability, 2 dB laser-power jitter per repeat trace, Rician floor noise:
    400 honest files (1 to 9 repeats of 1 to 4 amplitudes) pass the rule; one gate-tone
    reading 1 dB off in 9 repeats (20 times its repeatability) is refused in all of 50."""
    rng = np.random.default_rng(11)
    grid = np.round(np.linspace(0.1, 1.0, 12), 4)
    for i in range(400):
        k = int(rng.integers(2, 10))
        amps = rng.choice(grid, size=int(rng.integers(1, 5)), replace=False)
        df = _tone_table(rng, grid, {float(a): k for a in amps})
        for drop in (["snr_db"], []):             # with and without the recorded floor
            check_spectra_repeats(df.drop(columns=drop), f"honest {i}")
    refused = 0
    for i in range(50):
        df = _tone_table(rng, grid, {float(grid[5]): 9})
        rep = df.index[(df.A == grid[5]) & (df.n == 1) & (df.sideband == "red")
                       & (df.dpd == 0)]
        df.loc[rep[4], "P_dB"] += 1.0
        with pytest.raises(InputError, match="contradict each other"):
            check_spectra_repeats(df, "bad")
        refused += 1
    assert refused == 50


def _campaign_with(tmp_path, name, edit) -> Path:
    """The bundled campaign (without its traces) with one table edited."""
    folder = tmp_path / "camp"
    shutil.copytree(BUNDLED, folder, ignore=shutil.ignore_patterns("traces*", "truth.json"))
    p = folder / name
    df = pd.read_csv(p, comment="#")
    edit(df).to_csv(p, index=False)
    return folder


def _repeat_spectrum(df, A=0.5, times=4, seed=1, offset=None):
    """``df`` with the spectrum at ``A`` recorded ``times`` more times (appended traces,
    2 dB jitter per trace, 0.05 dB per tone)."""
    rng = np.random.default_rng(seed)
    one = df[np.isclose(df.A, A)]
    parts = [df]
    for _ in range(times):
        r = one.copy()
        jit = {d: 2.0 * rng.standard_normal() for d in (0, 1)}
        r["P_dB"] = r["P_dB"] + r["dpd"].map(jit) + 0.05 * rng.standard_normal(len(r))
        parts.append(r)
    out = pd.concat(parts, ignore_index=True)
    if offset is not None:
        out.loc[offset[0], "P_dB"] += offset[1]
    return out


def test_diagnosis_refuses_contradicting_repeated_tones_in_one_line(tmp_path, capsys):
    n0 = len(pd.read_csv(BUNDLED / "spectra.csv"))
    gate = n0 + 24 + 2                     # second repeat: dpd 0, red, n = 1 (24 tones a trace)
    folder = _campaign_with(tmp_path, "spectra.csv",
                            lambda df: _repeat_spectrum(df, offset=(gate, 1.5)))
    assert_refused(capsys, ["diagnose", folder, "--json"],
                   [str(folder / "spectra.csv"), f"row {gate + 1}",
                    "tone (A=0.5, dpd=0, red, n=1)", "contradict each other"],
                   list(folder.iterdir()))


def test_honest_repeated_spectra_are_read_by_the_campaign_folder(tmp_path):
    folder = _campaign_with(tmp_path, "spectra.csv", lambda df: _repeat_spectrum(df))
    cf = CampaignFolder(folder)
    pooled = cf.pooled_spectra
    assert len(cf.spectra) == 5 * len(pooled[np.isclose(pooled.A, 0.5)]) + len(
        pooled[~np.isclose(pooled.A, 0.5)])
    assert set(pooled[np.isclose(pooled.A, 0.5)]["n_repeats"]) == {5}
    assert set(pooled[~np.isclose(pooled.A, 0.5)]["n_repeats"]) == {1}
    assert "repeat" not in "\n".join(cf.left_out())      # a label costs nothing when absent


# ----------------------------------------------------------------------------- gate rates
def test_repeated_gate_rates_are_pooled_inverse_variance_weighted(tmp_path):
    p = _write(tmp_path / "rates.csv", "A,dpd,xi0_khz,xi0_err_khz\n"
               "0.5,0,4.0,0.1\n0.5,1,4.5,0.1\n0.5,0,4.2,0.2\n")
    r = read_gate_rates(p)
    assert r.index.tolist() == [0, 1] and r["n_repeats"].tolist() == [2, 1]
    assert r["xi0_khz"].iloc[0] == pytest.approx((4.0 * 100 + 4.2 * 25) / 125, abs=1e-12)
    assert r["xi0_err_khz"].iloc[0] == pytest.approx(125 ** -0.5, abs=1e-12)
    assert (r["xi0_khz"].iloc[1], r["xi0_err_khz"].iloc[1]) == (4.5, 0.1)
    q = _write(tmp_path / "plain.csv", "A,dpd,xi0_khz\n0.5,0,4.0\n0.5,1,4.5\n0.5,0,4.2\n")
    r = read_gate_rates(q)
    assert r["xi0_khz"].tolist() == pytest.approx([4.1, 4.5], abs=1e-12)
    assert r["xi0_sem_khz"].iloc[0] == pytest.approx(0.1, abs=1e-12)
    assert np.isnan(r["xi0_sem_khz"].iloc[1]) and "xi0_err_khz" not in r.columns


def test_every_consumer_sees_one_pooled_rate_per_setting(tmp_path, capsys):
    def again(df):
        r = df.iloc[[0]].copy()
        r["xi0_khz"] = r["xi0_khz"] * 1.01
        return pd.concat([df, r], ignore_index=True)
    folder = _campaign_with(tmp_path, "gate_rates.csv", again)
    cf = CampaignFolder(folder)
    rates = cf.gate_rates
    assert len(rates) == len(pd.read_csv(BUNDLED / "gate_rates.csv")) and \
        rates["n_repeats"].iloc[0] == 2
    from dpdfit.analyses.budget.config import gate_rates_khz
    assert gate_rates_khz(folder / "gate_rates.csv") == pytest.approx(
        rates["xi0_khz"].tolist())
    from dpdfit.analyses.diagnosis.observables.campaign import _gates
    g = _gates(cf)
    assert len(g) == len(rates) and g["n_rates"].max() == 2
    # one calibration's relative error, the pooled rate's times sqrt(2)
    first = g[(g.A == rates.A.iloc[0]) & (g.dpd == rates.dpd.iloc[0])].iloc[0]
    assert first["xi0_rel_err"] == pytest.approx(
        rates["xi0_err_khz"].iloc[0] / rates["xi0_khz"].iloc[0] * np.sqrt(2))


def test_contradicting_gate_rates_are_refused_in_one_line(tmp_path, capsys):
    p = _write(tmp_path / "rates.csv", "A,dpd,xi0_khz,xi0_err_khz\n"
               "0.4,0,3.35,0.033\n0.4,1,3.58,0.036\n0.4,0,3.90,0.039\n")
    assert_refused(capsys, ["fidelity", "--populations", BUNDLED / "populations.csv",
                            "--parity", BUNDLED / "parity.csv", "--gate-rates", p],
                   [str(p), "row 3", "A=0.4, dpd=0", "rows 1, 3", "contradict each other",
                    "xi0_err_khz"], [p])
    # repeats within their errors are a pooled calibration, with different errors too
    ok = _write(tmp_path / "ok.csv", "A,dpd,xi0_khz,xi0_err_khz\n"
                "0.4,0,3.35,0.033\n0.4,1,3.58,0.036\n0.4,0,3.40,0.050\n")
    assert read_gate_rates(ok)["n_repeats"].tolist() == [2, 1]


# ----------------------------------------------------------------------------- time scans
def test_repeated_time_scan_points_are_pooled_by_summing_counts(tmp_path):
    p = _write(tmp_path / "time_scans.csv", "A,dpd,t_us,n00,n01_10,n11,shots\n"
               "0.5,0,0,620,5,0,625\n0.5,0,10,500,100,25,625\n0.5,0,0,398,2,0,400\n")
    ts = read_time_scans(p)
    assert ts.index.tolist() == [0, 1]
    assert ts[["n00", "n01_10", "n11", "shots", "n_repeats"]].to_numpy().tolist() == [
        [1018, 7, 0, 1025, 2], [500, 100, 25, 625, 1]]
    assert ts["t_s"].tolist() == pytest.approx([0.0, 1e-5], abs=1e-18)
    # an exact copy of a point is an honest repeat (counts coincide often): pooled
    q = _write(tmp_path / "copy.csv", "A,dpd,t_us,n00,n11,shots\n"
               "0.5,0,0,625,0,625\n0.5,0,0,625,0,625\n")
    assert read_time_scans(q)[["n00", "shots"]].to_numpy().tolist() == [[1250, 1250]]


def test_contradicting_time_scan_counts_are_refused_in_one_line(tmp_path, capsys):
    def again(df):
        r = df.iloc[[5]].copy()                  # a point recorded again, n00 far off
        r["n00"], r["n01_10"] = r["n00"] - 300, r["n01_10"] + 300
        return pd.concat([df, r], ignore_index=True)
    folder = _campaign_with(tmp_path, "time_scans.csv", again)
    n = len(pd.read_csv(BUNDLED / "time_scans.csv"))
    assert_refused(capsys, ["diagnose", folder, "--json"],
                   [str(folder / "time_scans.csv"), f"rows 6, {n + 1}", "A=0.5, dpd=0, t_us=",
                    "contradict binomial noise"], list(folder.iterdir()))


def test_rare_outcomes_repeated_hundreds_of_times_are_honest_repeats(tmp_path):
    """A time-scan point repeated 385 times, its n01_10 a rare outcome (mean 0.06 per
    625 shots): a count of 2 beside zeros is eight normal sigma but an ordinary draw.
    The exact conditional test over all repeated rows refuses none of 200 honest
    tables; it still refuses a row far off."""
    from dpdfit.recordings.counts import check_count_repeats
    rng = np.random.default_rng(20261128)
    refused = 0
    for _ in range(200):
        rare = rng.binomial(625, 1e-4, size=385)
        df = pd.DataFrame({"A": 0.6, "dpd": 1, "t_us": 0.0, "n01_10": rare,
                           "n00": 625 - rare, "shots": 625})
        try:
            check_count_repeats(df, ["A", "dpd", "t_us"], ["n00", "n01_10"], "t.csv", "point")
        except InputError:
            refused += 1
    assert refused == 0
    # the table the closed loop wrote and the normal approximation refused (7.9 sigma)
    rare = np.array([0] * 363 + [1] * 21 + [2])
    df = pd.DataFrame({"A": 0.6, "dpd": 1, "t_us": 0.0, "n01_10": rare, "n00": 625 - rare,
                       "shots": 625})
    check_count_repeats(df, ["A", "dpd", "t_us"], ["n00", "n01_10"], "t.csv", "point")
    # twelve where about 0.06 are expected is a contradiction, named with its count
    df.loc[100, ["n01_10", "n00"]] = [12, 613]
    with pytest.raises(InputError, match=r"row 101 \(12/625\) .* sigma from the others"):
        check_count_repeats(df, ["A", "dpd", "t_us"], ["n00", "n01_10"], "t.csv", "point")


# ----------------------------------------------------------------------------- populations
def test_repeated_scans_of_a_setting_are_pooled_at_the_count_level(tmp_path):
    """populations.csv and parity.csv carry the repeat column ``scan``: more scans of a
    setting are more rows, pooled over their counts (the same (A, dpd, scan) twice is a
    duplicated line)."""
    from dpdfit.fits.counts import gate_fidelities
    from dpdfit.recordings.counts import read_populations
    pop = pd.read_csv(BUNDLED / "populations.csv")
    more = pop[(pop.A == 0.8) & (pop.dpd == 1)].copy()
    more["scan"] = more["scan"] + pop["scan"].max()
    p = tmp_path / "populations.csv"
    pd.concat([pop, more], ignore_index=True).to_csv(p, index=False)
    read = read_populations(p)
    tab = gate_fidelities(read, pd.read_csv(BUNDLED / "parity.csv"))
    row = tab[(tab.A == 0.8) & (tab.dpd == 1)].iloc[0]
    sel = read[(read.A == 0.8) & (read.dpd == 1)]
    assert row["n_scans"] == sel["scan"].nunique() == 2 * pop[(pop.A == 0.8)
                                                              & (pop.dpd == 1)].shape[0]
    assert row["F_pop"] == pytest.approx(sel["n_even"].sum() / sel["shots"].sum())


# ----------------------------------------------------------------------------- statistics
def test_pooled_tone_power_error_covers_the_truth():
    """k repeated Rician readings of one tone at 25 dB over the floor: the mean linear
    power debiased by the floor is unbiased and its error (1/sqrt(k) of one reading's)
    covers the true power in 68 % of 20,000 replicates."""
    rng = np.random.default_rng(4)
    N0, c2, k, reps = 1.0, 10 ** 2.5, 9, 20000
    noise = np.sqrt(N0 / 2) * (rng.standard_normal((reps, k))
                               + 1j * rng.standard_normal((reps, k)))
    x = np.abs(np.sqrt(c2) + noise) ** 2
    val, err = debias_tones(10 * np.log10(x.mean(axis=1)), N0, k)
    assert abs(np.mean(10 ** (val / 10)) / c2 - 1) < 1e-3
    pull = (val - 10 * np.log10(c2)) / err
    assert 0.66 <= np.mean(np.abs(pull) <= 1) <= 0.70
    assert abs(np.std(pull) - 1) < 0.03
    # one reading's error would cover 3 times too much: it is sqrt(k) too large
    _, err1 = debias_tones(10 * np.log10(x.mean(axis=1)), N0, 1)
    assert np.median(err1 / err) == pytest.approx(3.0)


def _null_model_campaign(rng, A, repeats, s_tone, s_trace):
    """A Campaign-like record of tone powers far above the floor: per reading a
    repeatability ``s_tone``, per repeat trace (A, dpd: both sidebands) a jitter
    ``s_trace``; ``repeats[i]`` readings of every tone at amplitude ``A[i]``, pooled as
    the diagnosis pools them (mean linear power)."""
    H = len(TONE_HARMONICS)
    lA = np.log10(A)[:, None, None, None]
    gate = np.isin(TONE_HARMONICS, (1, 2))[None, None, None, :]
    im = -45.0 + 60 * (lA - np.log10(0.5)) - 0.7 * np.arange(H) \
        - np.array([0.0, 2.0])[None, :, None, None]
    truth = np.broadcast_to(np.where(gate, -18.0 + 20 * lA, im), (A.size, 2, 2, H)).copy()
    R = int(max(repeats))
    jit = s_trace * rng.standard_normal((A.size, R, 2, 1, 1))
    each = truth[:, None] + jit + s_tone * rng.standard_normal((A.size, R, 2, 2, H))
    each[np.arange(R)[None, :] >= np.asarray(repeats)[:, None]] = np.nan
    P_raw = 10 * np.log10(np.nanmean(10 ** (each / 10), axis=1))
    n = np.broadcast_to(np.asarray(repeats, float)[:, None, None, None], P_raw.shape).copy()
    N0 = 10 ** (-130 / 10)                  # far below: the noise part is negligible
    P, sd = debias_tones(P_raw, N0, n)
    camp = SimpleNamespace(A_tones=A, has_snr=True, P_dB=P, sd_dB=sd, P_raw=P_raw,
                           snr_raw=P_raw - 10 * np.log10(N0 * np.log(2)), n_repeats=n,
                           P_readings=each)
    model = {k: v for k, (v, _) in tone_features(truth, A).items()}
    return camp, model


@pytest.mark.slow
def test_null_model_scales_stay_unbiased_when_amplitudes_are_repeated():
    """Half the amplitudes recorded 6 times: the learnt repeatability of one reading and
    power jitter of one trace stay within 4 % of the truth (median over 60 replicates);
    without the repeats' 1/k multiples they would come out far too small."""
    rng = np.random.default_rng(8)
    A = np.linspace(0.1, 1.0, 40)
    repeats = np.where(np.arange(A.size) % 2 == 0, 6, 1)
    s_tone, s_trace = 0.05, 0.3
    got, naive = [], []
    for _ in range(60):
        camp, model = _null_model_campaign(rng, A, repeats, s_tone, s_trace)
        _, _, noise = learn_tone_noise(camp, model)
        got.append((noise.s_tone_db, noise.s_trace_db))
        _, _, blind = learn_tone_noise(SimpleNamespace(**{**vars(camp), "n_repeats": None}),
                                       model)
        naive.append((blind.s_tone_db, blind.s_trace_db))
    got, naive = np.median(got, axis=0), np.median(naive, axis=0)
    assert got[0] == pytest.approx(s_tone, rel=0.04)
    assert got[1] == pytest.approx(s_trace, rel=0.04)
    assert naive[0] < 0.85 * s_tone and naive[1] < 0.85 * s_trace
