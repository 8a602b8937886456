"""The compiled master equation against the numpy reference (dpdfit.models.gate_sim).

:mod:`dpdfit.models.gate_sim.compiled_lindblad` runs scipy's DOP853 algorithm step for
step on the same right-hand side, compiled.  So the two kernels must take the same
steps (the same number of right-hand sides) and give the same states up to rounding:
the tolerance below, 1e-12 on every element of the spin density matrix, is a thousand
times below the engine's own integration error at its tightest tolerances (~4e-10 for
the master equation at rtol 1e-9, :mod:`~dpdfit.models.gate_sim.integrators`) and seven
orders below it at the diagnosis's (``ENGINE_PRECISION``: probabilities to ~1e-5);
rounding differences (~1e-16 a step, a few hundred steps) stay far inside it.

The parameters cover what the diagnosis integrates: every preparation branch (two ions
from |00> and |01>, one ion from |0> and |1>), the lab's error model with the catalog's
knob steps up to three times (extra independent and common dephasing 300 /s, extra
heating 0.3 quanta/ms, 0.2 more initial phonons), the ranges the catalog fits (rates up
to 5000 /s; heating to 2 quanta/ms, where the engine still holds its Fock cutoff over
1.3 gate times), distorted tones (AM/PM phases, red/blue asymmetry, intermodulation
tones, a power error), gate-rate errors of +-10 %, and time scans read between steps
and past the gate time.
"""

import zlib

import numpy as np
import pytest

from dpdfit.models import gate_sim as gs
from dpdfit.analyses.diagnosis.model.gates.gate_model import ENGINE_PRECISION

XI0 = 3.4e3
S = 1 / np.sqrt(1.5)
N_T = np.array([1, 2, 0, 3, -1, 4])
R_T = np.array([S, -S, 0.02, 0.03, -0.015, 0.01])
UNIT = gs.calibrate_xi0(R_T[:2], R_T[:2], N_T[:2], 1.0)
TIGHT = {"rtol": 1e-9, "atol": 1e-11}
TOL = 1e-12


def _tones(rng):
    """Gate tones with the distortions a campaign's tone model gives them."""
    amp = np.abs(R_T) * (1 + 0.05 * rng.standard_normal(R_T.size))
    amp = np.sign(R_T) * amp
    ph_b = 0.2 * rng.standard_normal(R_T.size)
    ph_r = 0.2 * rng.standard_normal(R_T.size)
    asym = 10 ** (rng.uniform(-0.5, 0.5) / 20)
    return amp * np.exp(1j * ph_b) * asym, amp * np.exp(1j * ph_r) / asym


def _cases():
    """(label, n_ions, initial, nbar, T2, T2_corr, ndot, power factor, rate factor)."""
    lab = dict(nbar=0.1, T2=50e-3, T2_corr=np.inf, ndot=5.0)

    def extra(ind=0.0, com=0.0, ndot=0.0, dnbar=0.0):
        return dict(nbar=lab["nbar"] + dnbar, T2=1 / (1 / lab["T2"] + ind),
                    T2_corr=np.inf if com == 0 else 1 / com, ndot=lab["ndot"] + ndot)

    out = []
    for ions, init in ((2, 0), (1, 0), (2, 1), (1, 1)):
        out.append((f"lab-{ions}ion-from{init}", ions, init, lab))
    out += [("dephasing-step3", 2, 0, extra(ind=300.0)),
            ("common-step3", 2, 0, extra(com=300.0)),
            ("heating-step3", 2, 0, extra(ndot=300.0)),
            ("nbar-step", 2, 0, extra(dnbar=0.2)),
            ("dephasing-max", 2, 0, extra(ind=5000.0)),
            ("common-max", 2, 0, extra(com=5000.0)),
            ("heating-high", 2, 1, extra(ndot=2000.0)),
            ("all-high-one-ion", 1, 1, extra(ind=5000.0, com=5000.0, ndot=2000.0, dnbar=1.0)),
            ("hot", 2, 0, extra(dnbar=1.0, ndot=1000.0)),
            ("no-decoherence", 2, 0, dict(nbar=0.1, T2=np.inf, T2_corr=np.inf, ndot=0.0))]
    return out


CASES = _cases()


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_compiled_equals_reference(case):
    """Same steps, same states (to rounding) at the diagnosis's tolerances, with a time
    scan, a gate-rate error and a power error drawn per case."""
    label, ions, init, em = case
    rng = np.random.default_rng(zlib.crc32(label.encode()))
    b, c = _tones(rng)
    xi0 = XI0 * (1 + rng.uniform(-0.1, 0.1))                  # the lab's rate error
    eO = XI0 / UNIT * 10 ** (rng.uniform(-0.5, 0.5) / 20)     # a power error
    T = 1 / xi0
    times = np.concatenate([[T], np.sort(rng.uniform(0, 1.3 * T, 12)), [0.0]])
    kw = dict(T2=em["T2"], T2_corr=em["T2_corr"], ndot=em["ndot"], n_ions=ions,
              initial=init, return_info=True, **ENGINE_PRECISION)
    ref, info_r = gs.evolve_lindblad(b, c, N_T, eO, xi0, times, em["nbar"], kernel="numpy",
                                     **kw)
    com, info_c = gs.evolve_lindblad(b, c, N_T, eO, xi0, times, em["nbar"], **kw)
    assert info_c["nfev"] == info_r["nfev"] > 0
    assert info_c["n_fock"] == info_r["n_fock"]
    assert abs(info_c["top_population"] - info_r["top_population"]) <= TOL
    assert np.max(np.abs(com - ref)) <= TOL
    # and a physical state: unit trace, Hermitian (the comparison is not of two zeros)
    assert np.allclose(np.trace(com, axis1=-2, axis2=-1), 1.0, atol=1e-4)
    assert np.max(np.abs(com - com[-1])) > 0.1         # the drive moved it (com[-1]: t = 0)


@pytest.mark.parametrize("ions", [2, 1])
def test_compiled_equals_reference_tight(ions):
    """At the engine's default tolerances (400-700 right-hand sides) as well."""
    rng = np.random.default_rng(7 + ions)
    b, c = _tones(rng)
    eO = XI0 / UNIT
    times = np.array([1 / XI0, 0.3 / XI0, 0.71 / XI0, 1.2 / XI0])
    kw = dict(T2=2e-3, T2_corr=5e-3, ndot=500.0, n_ions=ions, return_info=True, **TIGHT)
    ref, info_r = gs.evolve_lindblad(b, c, N_T, eO, XI0, times, 0.3, kernel="numpy", **kw)
    com, info_c = gs.evolve_lindblad(b, c, N_T, eO, XI0, times, 0.3, **kw)
    assert info_c["nfev"] == info_r["nfev"] > 400
    assert np.max(np.abs(com - ref)) <= TOL


def test_time_dependent_dephasing_uses_the_reference():
    """A dephasing profile (a time-local rate) is integrated by the reference, whatever
    the kernel asked for: the same result both ways."""
    b, c = R_T.astype(complex), R_T.astype(complex)
    eO = XI0 / UNIT
    kw = dict(T2=50e-3, ndot=5.0, dephasing_profile=(200.0, 50.0, 2.0, 1 / XI0),
              **ENGINE_PRECISION)
    a = gs.evolve_lindblad(b, c, N_T, eO, XI0, 1 / XI0, 0.1, **kw)
    r = gs.evolve_lindblad(b, c, N_T, eO, XI0, 1 / XI0, 0.1, kernel="numpy", **kw)
    assert np.array_equal(a, r)


def test_unknown_kernel_is_refused():
    with pytest.raises(ValueError, match="kernel"):
        gs.evolve_lindblad(R_T, R_T, N_T, XI0 / UNIT, XI0, 1 / XI0, 0.1, kernel="fast")
