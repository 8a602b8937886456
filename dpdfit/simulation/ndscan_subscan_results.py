"""The result channels an ndscan subscan leaves in its parent scan, for writing results files.

ndscan's ``setattr_subscan(..., scan_name, ...)`` gives the parent fragment the
channels ``<scan>_axis_<i>`` and ``<scan>_channel_<name>`` (opaque: one array
per outer point) and ``<scan>_spec`` (type ``subscan``: the inner scan's schema
as JSON at every point); see ``ndscan/experiment/subscan.py`` and
``scan_runner.describe_scan``.  :func:`subscan_channels` builds them, to be
passed with the parent's own channels to
:func:`~dpdfit.simulation.artiq_results_file.ndscan_datasets`.
"""

from __future__ import annotations

import json

import numpy as np

__all__ = ["subscan_channels"]


def subscan_channels(scan: str, fqn: str, axes: list, channels: dict) -> dict:
    """The parent's channels for subscan ``scan`` of fragment ``fqn``.

    Parameters
    ----------
    scan : str
        The subscan's name (the prefix of its channels).
    fqn : str
        The scanned fragment's fqn (inner axes are ``fqn.<axis name>``).
    axes : list of :func:`~dpdfit.simulation.artiq_results_file.axis`
        The inner axes; ``values`` are (outer points, inner points), stored in SI.
    channels : dict of name -> :func:`~dpdfit.simulation.artiq_results_file.channel`
        The inner result channels, ``values`` (outer points, inner points[, shots]).
    """
    schema = {"fragment_fqn": fqn, "seed": 0, "axes": [
        {"param": {"fqn": f"{fqn}.{a['name']}", "type": "float", "description": a["name"],
                   "spec": {"unit": a["unit"], "scale": a["scale"], "is_scannable": True}},
         "path": "*"} for a in axes],
        "channels": {n: {"path": n, "description": n, "type": "float", "unit": c["unit"],
                         "scale": c["scale"]} for n, c in channels.items()}}
    n_outer = len(np.asarray(axes[0]["values"]))
    out = {f"{scan}_axis_{i}": {"values": np.asarray(a["values"]), "unit": "", "scale": 1.0,
                                "type": "opaque"} for i, a in enumerate(axes)}
    out.update({f"{scan}_channel_{n}": {"values": np.asarray(c["values"]), "unit": "",
                                        "scale": 1.0, "type": "opaque"}
                for n, c in channels.items()})
    out[f"{scan}_spec"] = {"values": [json.dumps(schema)] * n_outer, "unit": "", "scale": 1.0,
                           "type": "subscan"}
    return out
