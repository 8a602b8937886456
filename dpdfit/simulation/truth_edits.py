"""Single-field edits of a campaign's ``truth.json`` config, as a damaged or crafted file has them.

What the tests of the config's contract
(:data:`~dpdfit.simulation.campaign.config.TRUTH_CONTRACT`) and
``benchmarks/truth_config_edits.py`` share: the edits, and a small campaign whose
truth.json holds a value of every kind.

:func:`value_paths` lists the places of a config that hold a value: every key, every key
of a nested object, and the first and last item of every list, at every depth (a path
is a tuple of keys and list indices).  :func:`edited` replaces the value at one path;
:func:`single_field_edits` gives every path with every value of :data:`REPLACEMENTS`
(a value of another kind, or one no campaign can have).  :func:`path_text` writes a path
as a message names it (``scan_shots[0][1]``, ``photodiode.p_full``).
"""

from __future__ import annotations

import copy

__all__ = ["REPLACEMENTS", "value_paths", "edited", "path_text", "single_field_edits",
           "config_of_every_kind"]

#: what a single-field edit puts in place of a value: another kind (text, a list, null,
#: a flag, an object, a list nested deeper), or a number no campaign has (-1, 0, 1e308,
#: the non-finite numbers Python's JSON reader takes, an integer beyond every bound)
REPLACEMENTS = {
    "text": "ten",
    "list": [1, 2],
    "null": None,
    "-1": -1,
    "0": 0,
    "1e308": 1e308,
    "NaN": float("nan"),
    "Infinity": float("inf"),
    "huge integer": 10 ** 40,
    "bool": True,
    "object": {"x": 1},
    "nested list": [[["x"]]],
}


def value_paths(value, path: tuple = ()) -> list[tuple]:
    """The paths of ``value``'s parts (module doc), depth first; the empty path (the
    whole value) is not among them."""
    out: list[tuple] = []
    if isinstance(value, dict):
        steps = list(value)
    elif isinstance(value, list):
        steps = sorted({0, len(value) - 1}) if value else []
    else:
        return out
    for step in steps:
        out.append(path + (step,))
        out.extend(value_paths(value[step], path + (step,)))
    return out


def edited(config: dict, path: tuple, value) -> dict:
    """A deep copy of ``config`` with the part at ``path`` replaced by ``value``."""
    out = copy.deepcopy(config)
    parent = out
    for step in path[:-1]:
        parent = parent[step]
    parent[path[-1]] = copy.deepcopy(value)
    return out


def path_text(path: tuple) -> str:
    """``("scan_shots", 0, 1)`` -> ``"scan_shots[0][1]"``; ``("photodiode", "p_full")`` ->
    ``"photodiode.p_full"``."""
    text = ""
    for step in path:
        text += f"[{step}]" if isinstance(step, int) else (f".{step}" if text else str(step))
    return text


def single_field_edits(config: dict) -> list[tuple[tuple, str, dict]]:
    """``(path, replacement's name, edited config)`` for every path of ``config``
    (:func:`value_paths`) and every value of :data:`REPLACEMENTS`."""
    return [(path, name, edited(config, path, value))
            for path in value_paths(config) for name, value in REPLACEMENTS.items()]


def config_of_every_kind():
    """``(config, effects)`` of a small campaign whose truth.json holds a value of every
    kind its config can: direct spectra, two gate amplitudes, two scans, a calibration run
    after the recordings, further recordings of every kind (a new gate setting among them)
    and two effects named by ``--effects`` (one with a second parameter).  Simulated by
    ``simulate_campaign(folder, config=config, effects=effects)`` in a few seconds."""
    from dpdfit.simulation.campaign import CampaignConfig, parse_effects
    further = (("phase_run",), ("amplitude_run",), ("scan", 0.4, 1, 200, 0),
               ("scan", 0.5, 0, 100, 100), ("time_scan", 0.6, 0, 100, 4))
    config = CampaignConfig(seed=11, spectra_mode="direct", n_amp_runs=5, amp_span_days=6.0,
                            runs_after_recordings=1, n_phase_runs=2, phase_span_hours=1.0,
                            cal_points=51, trace_amplitudes=(0.2, 0.4, 0.6, 0.8),
                            bundled_traces=(), gate_amplitudes=(0.4, 0.6),
                            scan_shots=((300, 300), (300, 200)), time_scan_A=0.6,
                            time_scan_points=7, further=further)
    return config, parse_effects("spam_offset=0.002,aom_memory=50,aom_memory.f_off=2")
