"""Monte-Carlo propagation of the budget's inputs: :func:`error_budget`.

Input distributions: ``A`` normal truncated to ``[0, 1]``; ``T2`` normal
truncated to ``> 0``; an *upper limit* (heating rate, detection error) uniform
on ``[0, limit]``, otherwise normal truncated to ``>= 0``; ``delta`` normal.
Every source's loss is summarised by its mean and standard deviation over the
draws (see :mod:`dpdfit.analyses.budget`).
"""

from __future__ import annotations

import math

import numpy as np

from .config import validate_budget_config
from .losses import dephasing_loss, detection_loss, heating_loss, preparation_loss
from .result import PAPER_TABLE, SOURCES, BudgetResult

__all__ = ["error_budget"]


def _truncnorm(rng, mean, sd, lo, hi, size):
    """Normal(mean, sd) truncated to [lo, hi] (inverse CDF; sd = 0: constant)."""
    if sd == 0:
        return np.full(size, float(np.clip(mean, lo, hi)))
    from scipy.stats import norm
    a = norm.cdf((lo - mean) / sd)
    b = norm.cdf((hi - mean) / sd)
    u = rng.uniform(a, b, size)
    return np.clip(mean + sd * norm.ppf(u), lo, hi)


def _limit_or_normal(rng, value, err, upper_limit, size):
    if upper_limit:
        return rng.uniform(0.0, value, size)
    return _truncnorm(rng, value, err, 0.0, np.inf, size)


def _summary(x) -> dict:
    x = np.asarray(x, dtype=float)
    q16, q50, q84, q95 = np.percentile(x, [16, 50, 84, 95])
    return {"estimate": float(np.mean(x)), "error": float(np.std(x, ddof=1)),
            "median": float(q50), "interval_68": [float(q16), float(q84)],
            "upper_95": float(q95)}


def _gate_times_s(cfg) -> np.ndarray:
    """Gate times [s]: from rates (1/xi0) or the [min, max] range (mean = midpoint)."""
    g = cfg["gate"]
    if g["rates_khz"]:
        return 1.0 / (np.asarray(g["rates_khz"], dtype=float) * 1e3)
    return np.array([g["time_min_us"], g["time_max_us"]]) * 1e-6


def _draw_inputs(cfg, rng, N) -> dict:
    """Draws of the inputs: Rabi amplitude ``A``, ``T2`` [s], ``ndot`` [1/s], ``p_det``."""
    sp, de, he, dt = (cfg[k] for k in ("state_preparation", "dephasing", "heating", "detection"))
    A = _truncnorm(rng, sp["rabi_amplitude"], sp["rabi_amplitude_err"], 0.0, 1.0, N)
    T2 = _truncnorm(rng, de["T2_ms"], de["T2_err_ms"], 0.0, np.inf, N) * 1e-3
    T2 = np.maximum(T2, 1e-12)
    ndot = _limit_or_normal(rng, he["rate_per_ms"], he["rate_err_per_ms"], he["upper_limit"],
                            N) * 1e3
    pdet = _limit_or_normal(rng, dt["error_per_ion"], dt["error_err"], dt["upper_limit"], N)
    pdet = np.minimum(pdet, 0.5)
    return {"A": A, "T2": T2, "ndot": ndot, "pdet": pdet}


def _losses(x, Tg, coefficient) -> dict:
    """Loss per source for the input draws ``x`` at gate time ``Tg`` [s]."""
    return {"state_preparation": preparation_loss(1.0 - x["A"]),
            "dephasing": dephasing_loss(Tg, x["T2"], coefficient),
            "heating": heating_loss(x["ndot"], Tg),
            "detection": detection_loss(x["pdet"])}


def _paper_method(cfg, T_min, T_max) -> dict:
    """The paper's own method (Table S2) applied to the nominal inputs."""
    sp, de, he, dt = (cfg[k] for k in ("state_preparation", "dephasing", "heating", "detection"))
    p_nom = 1.0 - sp["rabi_amplitude"]
    T2n = de["T2_ms"] * 1e-3
    m_prep = 2 * p_nom
    m_deph = (1 - math.exp(-T_min / T2n), 1 - math.exp(-T_max / T2n))
    m_det = 2 * dt["error_per_ion"]
    dn = he["rate_per_ms"] * 1e3 * T_max
    lt = "<" if he["upper_limit"] else ""
    ltd = "<" if dt["upper_limit"] else ""
    return {
        "method": {
            "state_preparation": f"<~{100 * m_prep:.2f}",
            "dephasing": f"{100 * m_deph[0]:.2f}-{100 * m_deph[1]:.2f}",
            "heating": f"~0 (dn{lt or '='}{dn:.4f})",   # dn: Delta nbar = ndot T_max
            "detection": f"{ltd}{100 * m_det:.3f}",
            "total": f"<~{100 * (m_prep + m_deph[0] + m_det):.2f}-"
                     f"{100 * (m_prep + m_deph[1] + m_det):.2f}",
        },
        "method_values": {"state_preparation": m_prep, "dephasing": list(m_deph),
                          "heating_delta_nbar": dn, "detection": m_det,
                          "total": [m_prep + m_deph[0] + m_det, m_prep + m_deph[1] + m_det]},
        "table_s3": dict(PAPER_TABLE),
        "note": ("paper: preparation 2(1-A) (both ions), dephasing = parity-contrast loss "
                 "1-exp(-T/T2); ours: loss of (F_pop+F_par)/2 = (1-(1-p)^2)/2 and "
                 "0.591 T/T2"),
    }


def error_budget(config: dict | None = None) -> BudgetResult:
    """Error budget from a (partial) config dict; ``None`` = the paper's inputs."""
    cfg = validate_budget_config(config)
    mc = cfg["monte_carlo"]
    N, rng = int(mc["samples"]), np.random.default_rng(mc["seed"])
    T = _gate_times_s(cfg)
    T_min, T_max = float(T.min()), float(T.max())
    T_mean = float(T.mean())              # range: midpoint = mean over a uniform range
    x = _draw_inputs(cfg, rng, N)
    coefficient = cfg["dephasing"]["coefficient"]
    draws = _losses(x, T_mean, coefficient)
    at_min = {k: float(np.mean(v)) for k, v in _losses(x, T_min, coefficient).items()}
    at_max = {k: float(np.mean(v)) for k, v in _losses(x, T_max, coefficient).items()}
    sources = {}
    for k in SOURCES:
        s = _summary(draws[k])
        s["at_T_min"], s["at_T_max"] = at_min[k], at_max[k]
        sources[k] = s
    tot = sum(draws[k] for k in SOURCES)
    total = _summary(tot)
    total["at_T_min"], total["at_T_max"] = sum(at_min.values()), sum(at_max.values())

    delta = unexplained = p_pos = None
    dc = cfg["delta"]
    if dc["enabled"]:
        delta = {"estimate": float(dc["value"]), "error": float(dc["error"])}
        d = rng.normal(dc["value"], dc["error"], N) if dc["error"] > 0 else np.full(N, dc["value"])
        u = np.abs(d) - tot
        unexplained = _summary(u)
        p_pos = float(np.mean(u > 0))
    return BudgetResult(sources=sources, total=total, delta=delta, unexplained=unexplained,
                        p_unexplained_positive=p_pos, paper=_paper_method(cfg, T_min, T_max),
                        gate_times_us=(T_min * 1e6, T_mean * 1e6, T_max * 1e6), inputs=cfg)
