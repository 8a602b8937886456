"""The harness's jobs, kind by kind, each kind from random streams of its own.

:func:`dpdfit.simulation.harness.plan` joins them: catalog effects, nulls and pairs
from the plan's seed (:func:`catalog_jobs`), triples (:func:`triple_jobs`), each effect
in each of its forms with that form left out (:func:`form_jobs`), and pairs or triples
with a form of each left out (:func:`mixed_form_jobs`).  Each kind after the first
draws from ``SeedSequence([seed, key, ...])`` with a key of its own, so adding one
leaves every other job as it was.
"""

from __future__ import annotations

import zlib

import numpy as np

from dpdfit.errors import InputError
from dpdfit.simulation.injections import get

__all__ = ["catalog_jobs", "triple_jobs", "form_jobs", "mixed_form_jobs"]

#: keys of the random streams of the triples, of each left-out form, and of the pairs
#: and triples with left-out forms
_TRIPLES_KEY, _FORMS_KEY, _MIXED_KEY = 3, 4, 5


def catalog_jobs(per_effect, nulls, seed, effects, pairs) -> list:
    """The jobs of ``per_effect``, ``nulls`` and ``pairs``, from one stream."""
    rng = np.random.default_rng(seed)
    jobs = []
    for e in effects:
        for _ in range(per_effect):
            jobs.append({"concealed": e, "seed": int(rng.integers(1, 2 ** 31)),
                         "effects": {e: get(e).draw(rng)}})
    for _ in range(nulls):
        jobs.append({"concealed": "none", "seed": int(rng.integers(1, 2 ** 31)), "effects": {}})
    for _ in range(pairs):
        a, b = sorted(rng.choice(len(effects), size=2, replace=False))
        ea, eb = effects[a], effects[b]
        jobs.append({"concealed": f"{ea}+{eb}", "seed": int(rng.integers(1, 2 ** 31)),
                     "effects": {ea: get(ea).draw(rng), eb: get(eb).draw(rng)}})
    return jobs


def triple_jobs(triples, seed, effects) -> list:
    """Campaigns with three distinct effects, each drawn as the catalog harness does."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, _TRIPLES_KEY]))
    jobs = []
    for _ in range(triples):
        names = [effects[i] for i in sorted(rng.choice(len(effects), size=3, replace=False))]
        jobs.append({"concealed": "+".join(names), "seed": int(rng.integers(1, 2 ** 31)),
                     "effects": {n: get(n).draw(rng) for n in names}})
    return jobs


def form_jobs(per_form, seed, effects) -> list:
    """``per_form`` campaigns per effect and form with harness strengths, each injected in
    that form and diagnosed with it left out; one stream per effect and form."""
    jobs = []
    for e in effects:
        for form in get(e).harness_table():
            key = zlib.crc32(f"{e}:{form}".encode())
            rng = np.random.default_rng(np.random.SeedSequence([seed, _FORMS_KEY, key]))
            for _ in range(per_form):
                jobs.append({"concealed": e, "seed": int(rng.integers(1, 2 ** 31)),
                             "effects": {e: get(e).draw(rng, form)},
                             "injected_form": {e: form}, "forms_left_out": {e: [form]}})
    return jobs


def mixed_form_jobs(n: int, k: int, seed: int, effects) -> list:
    """``n`` campaigns with ``k`` distinct effects at once, each injected in a form drawn
    at random among its forms with harness strengths and left out of the catalog
    (families of more than one form only); one stream per ``k``."""
    many = [e for e in effects if len(get(e).forms_for()) > 1 and get(e).harness_table()]
    if n and len(many) < k:
        raise InputError(f"{k} effects with left-out forms need {k} families of more than "
                         f"one form; got {len(many)}")
    rng = np.random.default_rng(np.random.SeedSequence([seed, _MIXED_KEY, k]))
    jobs = []
    for _ in range(n):
        names = [many[i] for i in sorted(rng.choice(len(many), size=k, replace=False))]
        forms = {e: str(rng.choice(sorted(get(e).harness_table()))) for e in names}
        jobs.append({"concealed": "+".join(names), "seed": int(rng.integers(1, 2 ** 31)),
                     "effects": {e: get(e).draw(rng, forms[e]) for e in names},
                     "injected_form": forms, "forms_left_out": {e: [f] for e, f in forms.items()}})
    return jobs
