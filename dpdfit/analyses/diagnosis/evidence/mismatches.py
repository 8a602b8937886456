"""Where the baseline fails: located mismatches and the tests that say there is one.

* **Locate** (:func:`locate_mismatches`): standardised residuals of each
  series are searched for intervals of significant deviation
  (:func:`dpdfit.analyses.diagnosis.evidence.deviations.deviating_intervals`),
  Bonferroni-corrected over all intervals and all series.
* **Evidence of a mismatch** (:func:`mismatch_evidence`): the global chi2, a located
  interval, or the best gate-side effect's targeted test; :func:`side_evidence` says on
  which side of the model (tones, gates) the recordings show it.
"""

from __future__ import annotations

from scipy.stats import chi2 as chi2_dist

from dpdfit.analyses.diagnosis.evidence.deviations import deviating_intervals
from dpdfit.analyses.diagnosis.evidence.ranking import decisive
from dpdfit.analyses.diagnosis.evidence.thresholds import ALPHA, NULL_REDCHI_MAX
from dpdfit.analyses.diagnosis.fitting.fit_result import FitResult

__all__ = ['locate_mismatches', 'mismatch_evidence', 'side_evidence', 'side_of_observable', 'GATE_OBSERVABLES', 'within_null_range']


def within_null_range(base: FitResult, mismatches: list) -> bool:
    """Whether the baseline looks like a null campaign: no located interval and every
    observable's reduced chi2 at most :data:`NULL_REDCHI_MAX`."""
    if mismatches:
        return False
    red = base.redchi()
    return bool(red) and max(red.values()) <= NULL_REDCHI_MAX


def locate_mismatches(prob, p: dict) -> list:
    """Intervals of significant deviation of every residual series at parameters ``p``,
    most significant first."""
    series = prob.series(p)
    out = []
    for name, sb, d, xname, x, z in series:
        for dev in deviating_intervals(x, z, n_series=len(series), alpha=ALPHA):
            out.append({"observable": name, "sideband": sb, "dpd": None if d < 0 else int(d),
                        "x": xname, "range": [dev.lo, dev.hi], "n_points": dev.n_points,
                        "significance_sigma": dev.significance_sigma,
                        "p_global": dev.p_global, "shape": dev.shape,
                        "offset": dev.offset, "slope": dev.slope})
    # red/blue asymmetry: the same feature deviating differently on the two sidebands
    out.sort(key=lambda m: -m["significance_sigma"])
    return out


def mismatch_evidence(p_base: float, mismatches: list, ranking: list) -> list[str]:
    """Which tests say the baseline does not describe the recordings (empty: none).

    ``"global_chi2"``: the baseline's chi2 p-value is below ``ALPHA``;
    ``"located_interval"``: the deviation search found a deviation;
    ``"targeted:<effect>"``: the best single catalog effect's likelihood-ratio
    test, Bonferroni-corrected over the single effects tried, is below
    ``ALPHA`` with ``delta_bic < -BIC_DECISIVE``.  The targeted test sees
    effects too weak or too smooth for the deviation search (slow heating,
    a small power offset).  The correction bounds its false-alarm rate by
    ``ALPHA`` only if the LRT p-values are calibrated (Wilks); that is not
    tested, only observed on the harness's null campaigns.  Only gate-side
    effects count for it (ranking entries with ``side`` "gates"; entries
    without ``side`` count as gate-side): the ~10^3 tone features are read to
    0.01-0.05 dB, finer than any forward model matches another laboratory's
    physics -- on independent null campaigns single tone-side effects with
    parameters too small to matter (a 1-mrad phase, a 3-ns memory) lowered the
    baseline's chi2 by 20-60 -- so a tone-side mismatch must show as a visible
    one: in the global chi2 or a located interval.
    """
    singles = [r for r in ranking if "+" not in r["effect"]]
    gate_side = [r for r in singles if r.get("side", "gates") == "gates"]
    out = []
    if p_base < ALPHA:
        out.append("global_chi2")
    if mismatches:
        out.append("located_interval")
    if gate_side:
        best = min(gate_side, key=lambda r: r.get("family_delta_bic_tempered",
                                                  r["delta_bic"]))
        if decisive(best, len(singles)):
            out.append(f"targeted:{best['effect']}")
    return out


#: observables of the gate side (everything else -- tone features, the calibration runs --
#: belongs to the tone side)
GATE_OBSERVABLES = ("F_pop", "imb", "C", "P00_t", "P11_t")


def side_of_observable(name: str) -> str:
    """The side of the model an observable belongs to: ``"gates"`` for
    :data:`GATE_OBSERVABLES`, else ``"tones"``."""
    return "gates" if name in GATE_OBSERVABLES else "tones"


def side_evidence(base: FitResult, mismatches: list, evidence: list) -> set:
    """The sides of the model whose recordings show a mismatch: a located interval there,
    that side's chi2 p-value below ALPHA (Bonferroni over the two sides), or for the
    gates the targeted test.  An effect is considered only on a side with evidence:
    a flexible effect fitted to a side the baseline already describes lowers its chi2
    a little without anything being missing there (the tone features are read more
    finely than any forward model matches another laboratory's physics)."""
    out = {side_of_observable(m["observable"]) for m in mismatches}
    for side in ("tones", "gates"):
        keys = [k for k in base.chi2_by_observable
                if side_of_observable(k.split(":", 1)[1]) == side]
        chi = sum(base.chi2_by_observable[k] for k in keys)
        n = sum(base.n_by_observable[k] for k in keys)
        if n and chi2_dist.sf(chi, n) * 2 < ALPHA:
            out.add(side)
    if any(e.startswith("targeted:") for e in evidence):
        out.add("gates")
    return out
