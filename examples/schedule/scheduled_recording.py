"""Record a dpdfit schedule in ARTIQ: one experiment per kind of recording.

``dpdfit diagnose CAMPAIGN --schedule schedule.csv`` writes the recording the diagnosis
proposes as one row per point and repeat (kind, repeat, point, A, dpd, shots, phase_rad,
t_us, lab_s, day, start_s, tone_sd_db; and prepared, in a schedule of a SPAM
characterisation).  Each experiment below reads the rows of its kind, records them in
order and archives one value per point in plain datasets, the names that
``scheduled_recording.toml`` maps to dpdfit's tables; ``dpdfit add CAMPAIGN
scheduled_recording.toml -o CAMPAIGN_PLUS`` then merges the results into a copy of the
campaign.

Only the ``measure_*`` methods are the lab's: replace their bodies with your own
sequences (cooling, the gate with or without the predistortion table at amplitude A,
the analysis pulse at phase ``phase_rad``, detection; for SPAM, the state preparation
and detection with no gate).  Spectra are not recorded here:
a heterodyne trace's tone powers come from the lab's trace tool, and a folder of CSVs
in the campaign layout (``spectra.csv``) is added the same way.
"""

import csv

import numpy as np
from artiq.experiment import EnvExperiment, StringValue


class _ScheduledRecording(EnvExperiment):
    """The rows of one kind of a schedule file, recorded in order."""

    KIND = None

    def build(self):
        self.setattr_device("core")
        self.setattr_argument("schedule", StringValue("schedule.csv"))

    def prepare(self):
        with open(self.schedule, newline="") as fh:
            self.rows = [r for r in csv.DictReader(fh) if r["kind"] == self.KIND]
        if not self.rows:
            raise ValueError(f"{self.schedule}: no '{self.KIND}' rows")

    def archive(self, values: dict):
        """One value per recorded point, as plain datasets in the results file."""
        for name, column in values.items():
            self.set_dataset(name, np.asarray(column), archive=True)


class ScheduledPopulations(_ScheduledRecording):
    KIND = "populations"

    def run(self):
        out = {k: [] for k in ("A", "dpd", "scan", "n00", "n01_10", "n11", "shots")}
        for r in self.rows:
            A, dpd, shots = float(r["A"]), int(r["dpd"]), int(r["shots"])
            n00, n01_10, n11 = self.measure_populations(A, dpd, shots)
            for k, v in zip(out, (A, dpd, int(r["repeat"]), n00, n01_10, n11, shots)):
                out[k].append(v)
        self.archive(out)

    def measure_populations(self, A, dpd, shots):
        """The lab's gate at (A, dpd), ``shots`` times: counts of 00, 01 or 10, and 11."""
        raise NotImplementedError("the lab's own sequence")


class ScheduledParity(_ScheduledRecording):
    KIND = "parity"

    def run(self):
        out = {k: [] for k in ("A", "dpd", "scan", "phase_rad", "n_even", "shots")}
        for r in self.rows:
            A, dpd, shots = float(r["A"]), int(r["dpd"]), int(r["shots"])
            phase = float(r["phase_rad"])
            n_even = self.measure_parity(A, dpd, shots, phase)
            for k, v in zip(out, (A, dpd, int(r["repeat"]), phase, n_even, shots)):
                out[k].append(v)
        self.archive(out)

    def measure_parity(self, A, dpd, shots, phase_rad):
        """The gate, then the analysis pulse at ``phase_rad``: shots with even parity."""
        raise NotImplementedError("the lab's own sequence")


class ScheduledTimeScan(_ScheduledRecording):
    KIND = "time_scan"

    def run(self):
        out = {k: [] for k in ("A", "dpd", "t_us", "n00", "n01_10", "n11", "shots")}
        for r in self.rows:
            A, dpd, shots = float(r["A"]), int(r["dpd"]), int(r["shots"])
            t_us = float(r["t_us"])
            n00, n01_10, n11 = self.measure_populations_at(A, dpd, shots, t_us)
            for k, v in zip(out, (A, dpd, t_us, n00, n01_10, n11, shots)):
                out[k].append(v)
        self.archive(out)

    def measure_populations_at(self, A, dpd, shots, t_us):
        """The gate drive at (A, dpd) for ``t_us`` microseconds: counts as above."""
        raise NotImplementedError("the lab's own sequence")


class ScheduledAmplitudeRun(_ScheduledRecording):
    """One results file per run (``repeat``): submit it once per repeat, with the
    argument ``repeat``, on the row's ``day`` at its ``start_s`` (the runs are paced as
    the campaign's own runs were, not taken back to back); dpdfit labels the run by its
    rid."""

    KIND = "amplitude_run"

    def build(self):
        super().build()
        self.setattr_argument("repeat", StringValue("1"))

    def run(self):
        out = {k: [] for k in ("A", "power", "power_err")}
        for r in self.rows:
            if r["repeat"] != self.repeat:
                continue
            A = float(r["A"])
            power, err = self.measure_power(A)
            for k, v in zip(out, (A, power, err)):
                out[k].append(v)
        self.archive(out)

    def measure_power(self, A):
        """The AOM's diffracted power at RF amplitude ``A`` (photodiode): value, error."""
        raise NotImplementedError("the lab's own sequence")


class ScheduledSpam(_ScheduledRecording):
    """The SPAM characterisation: each row's basis state ``prepared`` (``00`` .. ``11``,
    the first character the first ion) prepared and detected with no gate."""

    KIND = "spam"

    def run(self):
        out = {k: [] for k in ("prepared", "n00", "n01_10", "n11", "shots")}
        for r in self.rows:
            state, shots = r["prepared"], int(r["shots"])
            n00, n01_10, n11 = self.measure_prepared(state, shots)
            # archived as a number (the state read in binary: 00 -> 0, 11 -> 3), which the
            # mapping's labels turn back into the text spam.csv records
            for k, v in zip(out, (int(state, 2), n00, n01_10, n11, shots)):
                out[k].append(v)
        self.archive(out)

    def measure_prepared(self, state, shots):
        """Prepare ``state``, no gate, detect, ``shots`` times: counts as above."""
        raise NotImplementedError("the lab's own sequence")


class ScheduledThermometry(_ScheduledRecording):
    """The sideband thermometry: for each row, cool the gate mode, wait ``wait_us``
    microseconds, drive the fixed probe pulse on the ``sideband`` (``red`` or ``blue``),
    read the probed ion (the first of the chain)."""

    KIND = "thermometry"

    def run(self):
        out = {k: [] for k in ("wait_us", "sideband", "n_bright", "shots")}
        for r in self.rows:
            wait_us, sideband, shots = float(r["wait_us"]), r["sideband"], int(r["shots"])
            n_bright = self.measure_sideband(wait_us, sideband, shots)
            # the sideband archived as a number (red -> 0, blue -> 1), which the mapping's
            # labels turn back into the text thermometry.csv records
            for k, v in zip(out, (wait_us, {"red": 0, "blue": 1}[sideband], n_bright, shots)):
                out[k].append(v)
        self.archive(out)

    def measure_sideband(self, wait_us, sideband, shots):
        """Cool, wait, probe ``sideband``, detect, ``shots`` times: the bright count."""
        raise NotImplementedError("the lab's own sequence")
