"""Which hypotheses the recordings do not separate from the named effects.

The diagnosis names the best hypothesis; this module lists every other one
still *within reach* of it once the evidence is judged against the misfit the
forms leave (:mod:`~dpdfit.analyses.diagnosis.evidence.tempering`):

* a **swap**: another single effect that is itself decisive against the
  baseline (tempered) and whose tempered BIC is within ``BIC_DECISIVE`` of the
  named one's -- "stale_calibration, or detector_nonlinearity: these
  recordings do not separate them"; and, at each step of the forward
  selection, another candidate within ``BIC_DECISIVE`` (tempered) of the one
  added;
* an **addition**: a further effect that the raw likelihood would have
  added (decisive before tempering) and that the tempered evidence still
  favours strongly (tempered delta BIC at most ``-ADDITION_IN_REACH``), but not
  decisively -- "perhaps also spam_offset".

Each alternative is an :class:`Alternative`; its :meth:`~Alternative.to_dict` is an
entry of the JSON's ``alternatives``.  An addition whose added size is consistent with
zero is not kept among them: it is an upper limit on that effect
(:mod:`~dpdfit.analyses.diagnosis.decisions.upper_limits`).  Of those that stay, the
strongest rival (:func:`strongest_alternative`) is the one the proposal aims at.
"""

from __future__ import annotations

from dataclasses import dataclass

from dpdfit.analyses.diagnosis.effects import EFFECTS
from dpdfit.analyses.diagnosis.evidence.families import chi2_gap_z, shared_observables
from dpdfit.analyses.diagnosis.evidence.ranking import decisive
from dpdfit.analyses.diagnosis.evidence.tempering import tempered_gap
from dpdfit.analyses.diagnosis.evidence.thresholds import (ADDITION_IN_REACH, ALPHA,
                                                           BIC_DECISIVE, NOISE_Z)
from dpdfit.core.records import Record

__all__ = ["Alternative", "alternative_entry", "swap_alternatives", "addition_alternatives",
           "strongest_alternative"]


@dataclass(frozen=True)
class Alternative(Record):
    """A hypothesis the recordings do not separate from the named one (module doc)."""

    #: the candidate effect
    effect: str
    #: its BIC minus the named hypothesis's, raw (> 0: worse; for an addition, the BIC of
    #: the named effects plus it minus theirs)
    delta_bic: float
    #: the same with the chi2 difference divided by the dispersion of the evidence
    delta_bic_tempered: float
    #: that dispersion (``tau`` >= 1, :mod:`~dpdfit.analyses.diagnosis.evidence.tempering`)
    tempering: float
    #: the named effect it would replace (None: an addition)
    replaces: str | None
    #: the complete set of effects the alternative stands for
    named: tuple
    #: how many standard deviations of its own scatter its chi2 is from the named fit's
    #: (:func:`~dpdfit.analyses.diagnosis.evidence.families.chi2_gap_z`; None: not computed)
    separation_sigma: float | None = None
    #: for an addition a named family leaves no room for: that family's form and evidence
    #: (``{"family", "form", "delta_bic_tempered"}``; None otherwise)
    room: dict | None = None

    @property
    def is_swap(self) -> bool:
        """Whether it replaces a named effect (else it is an addition)."""
        return self.replaces is not None

    @classmethod
    def from_dict(cls, d: dict) -> "Alternative":
        """The alternative of a JSON entry (:meth:`to_dict`), e.g. of an earlier diagnosis."""
        return cls(d["effect"], d["delta_bic"], d["delta_bic_tempered"], d["tempering"],
                   d.get("replaces"), tuple(d.get("named") or [d["effect"]]),
                   d.get("separation_sigma"), d.get("room"))

    def to_dict(self) -> dict:
        """The JSON's entry: every attribute, ``separation_sigma`` and ``room`` where set."""
        out = {"effect": self.effect, "delta_bic": self.delta_bic,
               "delta_bic_tempered": self.delta_bic_tempered, "tempering": self.tempering,
               "replaces": self.replaces, "named": list(self.named)}
        if self.separation_sigma is not None:
            out["separation_sigma"] = self.separation_sigma
        if self.room is not None:
            out["room"] = self.room
        return out


def alternative_entry(effect, raw, gap_t, tau, replaces, named, z=None,
                      room=None) -> Alternative:
    """One :class:`Alternative` from its evidence against the named hypothesis: raw and
    tempered delta BIC (``raw``, ``gap_t``), the tempering ``tau``, the separation ``z``."""
    return Alternative(effect, float(raw), float(gap_t), float(tau), replaces, tuple(named),
                       None if z is None else float(z), room)


def swap_alternatives(fits: dict, form_fits: dict, ranking: list, first: str,
                      named: list, sides: set | None, exclude=()) -> list:
    """Families the recordings do not separate from the first named one (module doc):
    ``fits`` the single effects' fits by name (the best form, carried to the gates where
    it was), ``form_fits`` every form's fit, ``ranking`` their ranking entries (with
    their family evidence).  A family is in reach when it is itself decisive against
    the baseline (its family evidence, tempered) and either its family evidence is
    within ``BIC_DECISIVE`` of the named one's or one of its forms is within the noise
    of the named fit (:func:`~dpdfit.analyses.diagnosis.evidence.families.chi2_gap_z` below
    :data:`~dpdfit.analyses.diagnosis.evidence.thresholds.NOISE_Z`): a parameter count alone
    never puts a family out of reach.  ``exclude``: families already given as complete
    explanations of their own.  Returns ``[(Alternative, its fit)]``."""
    out = []
    n_tests = len(ranking)
    by_name = {r["effect"]: r for r in ranking}
    ref = by_name.get(first, {})
    for r in ranking:
        e = r["effect"]
        if e == first or e in named or "+" in e or e not in fits or e in exclude:
            continue
        if sides is not None and r["side"] not in sides:
            continue
        if not decisive(r, n_tests):
            continue
        raw, gap_t, tau = tempered_gap(fits[e], fits[first])
        fam_gap = (r.get("family_delta_bic_tempered", -gap_t)
                   - ref.get("family_delta_bic_tempered", 0.0))
        forms = {**form_fits.get(e, {}), fits[e].forms[0]: fits[e]}
        zs = {f: chi2_gap_z(fits[first], ff, shared_observables(fits[first], ff))
              for f, ff in forms.items()}
        z = min(zs.values())
        if fam_gap < BIC_DECISIVE or z < NOISE_Z:
            best = min(zs, key=zs.get)
            out.append((alternative_entry(e, raw, gap_t, tau, first,
                               [e] + [x for x in named if x != first], z=z),
                        forms[best] if z < NOISE_Z else fits[e]))
    return out


def addition_alternatives(steps: list, named: list, open_sides=()) -> list:
    """Alternatives from the forward selection's steps
    (:func:`~dpdfit.analyses.diagnosis.decisions.additions.add_effects`): ``steps`` is a list of
    ``(entries, added, refused)`` per step, ``entries`` the ``(ranking entry, fit)`` of
    each candidate tried (against the named effects before the step), ``added`` the fit
    added at that step or None, ``refused`` the ``(entry, fit, room)`` of candidates
    decisive against the named model that a form of a named family leaves no room for
    (module doc).  ``open_sides``: the sides on which the named model still shows a
    mismatch; there an addition the raw likelihood would make stays in reach whatever
    its tempering, since the misfit that tempers it is itself unexplained.  Returns
    ``[(Alternative, its fit)]``."""
    out = []
    for step in steps:
        entries, added = step[0], step[1]
        refused = step[2] if len(step) > 2 else []
        n = len(entries)
        for entry, f, room in refused:
            c = f.effects[-1]
            out.append((alternative_entry(c, entry["delta_bic"], entry["delta_bic_tempered"],
                               entry.get("tempering", 1.0), None, list(named) + [c],
                               room={"family": room["family"], "form": room["form"],
                                     "delta_bic_tempered": room.get(
                                         "family_delta_bic_tempered",
                                         room["delta_bic_tempered"])}), f))
        if added is None:
            listed = {f.effects[-1] for _, f, _ in refused}
            for entry, f in entries:
                c = f.effects[-1]
                gain_t = entry["delta_chi2"] / max(entry.get("tempering", 1.0), 1.0)
                open_side = getattr(EFFECTS.get(c), "side", None) in open_sides
                if (c not in listed and entry["delta_bic"] < -BIC_DECISIVE
                        and entry["p_value"] * n < ALPHA
                        and (gain_t >= ADDITION_IN_REACH or open_side)):
                    out.append((alternative_entry(c, entry["delta_bic"], entry["delta_bic_tempered"],
                                       entry.get("tempering", 1.0), None, list(named) + [c]),
                                f))
            continue
        a = added.effects[-1]
        for entry, f in entries:
            c = f.effects[-1]
            if f is added or c in named or not decisive(entry, n):
                continue
            raw, gap_t, tau = tempered_gap(f, added)
            z = chi2_gap_z(added, f)
            if gap_t < BIC_DECISIVE or z < NOISE_Z:
                out.append((alternative_entry(c, raw, gap_t, tau, a,
                                   [c if x == a else x for x in named], z=z), f))
    return out


def strongest_alternative(alternatives: list):
    """The best-supported of the open alternatives, each an ``(Alternative, its fit)``:
    the lowest tempered delta BIC against the named hypothesis (the first listed on a
    tie), the rival a proposed recording is aimed at; None when there is none."""
    if not alternatives:
        return None
    return min(alternatives, key=lambda af: af[0].delta_bic_tempered)
