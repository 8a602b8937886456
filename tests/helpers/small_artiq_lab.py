"""A small lab for the import tests: two ARTIQ results files (ndscan scans) and a mapping.

:func:`write_small_lab` writes an amplitude calibration scan and a parity scan under
``results/<date>/<hour>/`` as ARTIQ and ndscan do, and returns the mapping text that
imports both; the mapping's globs are ``results/**/*-<Class>.h5``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dpdfit.simulation.artiq_results_file import (axis, channel, ndscan_datasets,
                                                  write_results_file)

#: start time of the first run (seconds since the epoch)
T0 = 1.76e9

SMALL_MAPPING = '''\
[campaign]
nu_hz = 1.84e6

[[calibration_amplitude]]
files = "results/**/*-AmplitudeCalibration.h5"
[calibration_amplitude.columns]
A = { axis = "amplitude" }
power = { channel = "pd_power" }
run = { run = "rid", format = "R{:03d}" }
timestamp = { run = "start_time" }

[[parity]]
files = "results/**/*-ParityScan.h5"
[parity.columns]
A = { argument = "amplitude" }
dpd = { argument = "dpd" }
phase_rad = { axis = "phase" }
n_even = { channel = "n_even" }
shots = { channel = "shots" }
'''


def write_small_lab(folder: Path) -> list[Path]:
    """The two results files (under ``folder/results``); returns their paths."""
    a = np.linspace(0, 1, 11)
    cal = write_results_file(folder, 1, "AmplitudeCalibration", T0, ndscan_datasets(
        1, "lab.AmplitudeCalibration", [axis("amplitude", a)],
        {"pd_power": channel(a ** 2)}))
    phase = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    par = write_results_file(folder, 2, "ParityScan", T0 + 600, ndscan_datasets(
        2, "lab.ParityScan", [axis("phase", phase, "rad")],
        {"n_even": channel(np.full(8, 300)), "shots": channel(np.full(8, 400))}),
        arguments={"amplitude": 0.5, "dpd": 1})
    return [cal, par]
