"""Memory guards: refuse an input whose analysis would not fit in memory, with one line.

Where the memory an analysis needs grows with its input (the samples of a
heterodyne trace, the rows of a CSV table), the reader estimates the bytes
before the large arrays are made and calls :func:`check_memory`, which raises
:class:`~dpdfit.errors.InputError` naming the file, the estimate and the limit
instead of letting the process be killed by the operating system.

The limit is :data:`MAX_MEMORY_GB` (GB = 10^9 bytes), lowered to 80 % of the
machine's physical memory when that is smaller; the environment variable
``DPDFIT_MAX_MEMORY_GB`` overrides both (e.g. ``DPDFIT_MAX_MEMORY_GB=64``).
The estimates come from ``benchmarks/scale.py`` (peak resident memory per
sample or per byte of input, with margin); they are deliberately generous
and refuse only inputs far beyond what was measured.
"""

from __future__ import annotations

import os

from dpdfit.errors import InputError

__all__ = ["MAX_MEMORY_GB", "MEMORY_ENV", "TRACE_BYTES_PER_SAMPLE", "TABLE_BYTES_PER_FILE_BYTE",
           "ENGINE_BYTES_PER_AMPLITUDE", "SCAN_BYTES_PER_INTERVAL", "memory_limit_bytes",
           "check_memory"]

#: Default memory limit of one analysis, GB (10^9 bytes).
MAX_MEMORY_GB = 16.0

#: Environment variable that overrides the limit (GB).
MEMORY_ENV = "DPDFIT_MAX_MEMORY_GB"

#: Peak bytes per sample of a trace's tone analysis: the recorded samples,
#: their float64 copy (and scaled copy), the rfft and FFT work space
#: (measured ~37 B/sample of resident memory at 2^24 samples).
TRACE_BYTES_PER_SAMPLE = 48

#: Peak bytes per byte of a CSV file read by :func:`dpdfit.recordings.tables.read_table`
#: (every cell a string first, then the numeric columns; measured ~6 B of
#: resident memory per file byte on a 7 MB calibration file).
TABLE_BYTES_PER_FILE_BYTE = 12

#: Peak bytes per complex amplitude of the state the gate engine integrates
#: (:mod:`dpdfit.models.gate_sim`): the density matrix of the master equation,
#: ``(spin states x n_fock)^2`` amplitudes, or the Schrodinger columns,
#: ``spin states x n_fock x thermal levels``.  DOP853 keeps 16 stage copies of the
#: state, its dense output and the right-hand side's work arrays: measured 561 B
#: (master equation) and ~500 B (Schrodinger) of traced peak per amplitude, flat
#: from n_fock = 30 to 200 (``benchmarks/engine_memory.py``).
ENGINE_BYTES_PER_AMPLITUDE = 640

#: Peak bytes per interval of the diagnosis's deviation search
#: (:func:`dpdfit.analyses.diagnosis.evidence.deviations.deviating_intervals`, ``n (n + 1) / 2``
#: intervals of a series of ``n`` points: their ends, lengths, statistics and
#: p-values); measured 81 B at n = 500 to 2000 (``benchmarks/engine_memory.py``).
SCAN_BYTES_PER_INTERVAL = 96


def _physical_bytes() -> int | None:
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return None


def memory_limit_bytes() -> float:
    """The limit in bytes: ``DPDFIT_MAX_MEMORY_GB`` if set, else the smaller of
    :data:`MAX_MEMORY_GB` and 80 % of physical memory."""
    env = os.environ.get(MEMORY_ENV, "").strip()
    if env:
        try:
            gb = float(env)
            if not gb > 0:
                raise ValueError
        except ValueError:
            raise InputError(f"{MEMORY_ENV}={env!r} must be a positive number of GB") from None
        return gb * 1e9
    limit = MAX_MEMORY_GB * 1e9
    phys = _physical_bytes()
    return min(limit, 0.8 * phys) if phys else limit


def check_memory(nbytes: float, what: str, *, file: str | None = None, hint: str = "") -> None:
    """InputError if ``nbytes`` (the estimated peak of the work on ``what``) exceeds the limit.

    The message: ``FILE: WHAT needs about X GB of memory, above the limit of
    Y GB (DPDFIT_MAX_MEMORY_GB); HINT``.
    """
    limit = memory_limit_bytes()
    if nbytes > limit:
        tail = f"; {hint}" if hint else f"; set {MEMORY_ENV} to raise the limit"
        raise InputError(f"{what} needs about {nbytes / 1e9:.3g} GB of memory, above the "
                         f"limit of {limit / 1e9:.3g} GB ({MEMORY_ENV}){tail}", file=file)
