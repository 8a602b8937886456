"""Spectrum-based fidelity estimate and DPD power changes from a trace's tone powers.

Combines the tone extraction (:func:`dpdfit.fits.tones.trace_tone_powers`)
with the fidelity model (:func:`dpdfit.models.fidelity.estimate`, S5):
:func:`trace_estimate` gives ``F_est`` per sideband group and their mean,
:func:`delta_powers` the tone-power changes between two traces (S8).
"""

from __future__ import annotations

from dpdfit.core.defaults import FORMULA, NBAR
from dpdfit.fits.tones import TraceSpectrum
from dpdfit.models.fidelity import estimate

__all__ = ["trace_estimate", "delta_powers"]


def trace_estimate(res: TraceSpectrum, nbar: float = NBAR, formula: str = FORMULA) -> dict:
    """Spectrum-based fidelity estimate (S5) from a trace's tone powers.

    Per sideband group: ``F_est`` from the measured ``P_n`` of all requested
    harmonics (needs the gate tones valid; otherwise ``None``).  An IM tone at
    the noise floor enters with its reading, an upper limit of its power, so
    ``F_est`` is then a lower limit (``limit: "lower"``).  ``mean`` averages the
    two sidebands (S5.4).
    """
    out = {}
    for name in ("red", "blue"):
        t = getattr(res, name)
        if not all(t.valid[n] for n in res.gate):
            out[name] = {"F_est": None, "eps_est": None, "limit": None,
                         "reason": "a gate tone failed validation"}
            continue
        h = list(res.harmonics)
        est = estimate([t.P_dB[n] for n in h], h, gate=tuple(res.gate), nbar=nbar,
                       formula=formula)
        lim = "lower" if any(not t.valid[n] for n in h if n not in res.gate) else None
        out[name] = {"F_est": float(est.F_est), "eps_est": float(est.eps_est), "limit": lim,
                     "reason": "ok"}
    r, b = out["red"], out["blue"]
    if r["F_est"] is None or b["F_est"] is None:
        out["F_est"], out["eps_est"], out["limit"] = None, None, None
    else:
        out["F_est"] = 0.5 * (r["F_est"] + b["F_est"])
        out["eps_est"] = 1.0 - out["F_est"]
        out["limit"] = "lower" if (r["limit"] or b["limit"]) else None
    out.update(formula=formula, nbar=float(nbar))
    return out


def delta_powers(res_dpd: TraceSpectrum, res_ref: TraceSpectrum) -> dict:
    """``dP_n = P_n(this) - P_n(reference)`` in dB per sideband and their mean.

    For DPD vs no-DPD traces at matched A (S8).  A difference is ``None``
    unless the tone is valid in both traces.
    """
    out = {}
    for name in ("red", "blue"):
        a, b = getattr(res_dpd, name), getattr(res_ref, name)
        out[name] = {str(n): (a.P_dB[n] - b.P_dB[n] if a.valid[n] and b.valid[n] else None)
                     for n in res_dpd.harmonics if n in res_ref.harmonics}
    out["mean"] = {k: (None if out["red"][k] is None or out["blue"][k] is None
                       else 0.5 * (out["red"][k] + out["blue"][k])) for k in out["red"]}
    return out

