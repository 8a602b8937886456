"""Error budget of the measured Bell-state fidelity (Supplement S10, Table S2).

Each characterised error source is turned into a loss of the *measured*
fidelity ``F = (F_pop + F_par)/2 = (P00 + P11)/2 + C/2`` (``C`` the parity
contrast), with physically justified first-order formulas that are checked
against the exact gate engine :mod:`dpdfit.models.gate_sim` (``tests/analyses/test_budget.py``),
and the input uncertainties are propagated by Monte Carlo (numpy, fixed seed)
so that upper limits, the physical bound ``amplitude <= 1`` and asymmetric
distributions are handled honestly.

Statistics
----------
Every ``estimate``/``error`` pair is the Monte-Carlo **mean and standard
deviation** over the input distributions; :meth:`BudgetResult.to_dict` also
gives, under ``"details"``, the median, the central 68 % interval (16th-84th
percentiles), the 95th percentile, and the loss at the shortest and longest
gate time.  Input distributions: ``A`` normal truncated to ``[0, 1]``;
``T2`` normal truncated to ``> 0``; an *upper limit* (heating rate, detection
error, default) uniform on ``[0, limit]``, otherwise normal truncated to
``>= 0``; ``delta`` normal.  ``unexplained = |delta| - total`` per draw, with
``P(unexplained > 0)``.

The JSON (``dpdfit budget --json``, :meth:`BudgetResult.to_dict`) has the keys
``state_preparation``, ``dephasing``, ``heating``, ``detection``, ``total``,
``delta`` and ``unexplained``, each ``{"estimate": float, "error": float}``
(fractions, not %; ``delta`` as given, signed; ``delta``/``unexplained`` are
``null`` when delta is disabled), plus ``p_unexplained_positive``, ``paper``
(the paper's method applied to these inputs and the printed Table S2 entries),
``details`` and ``inputs``.

Modules: :mod:`.losses` (the formulas and their checks against the gate
engine), :mod:`.config` (the TOML configuration, its keys and defaults),
:mod:`.result` (:class:`BudgetResult`), :mod:`.monte_carlo`
(:func:`error_budget`).  The command is :mod:`dpdfit.cli.budget`.
"""

from .config import DEFAULT_CONFIG, gate_rates_khz, load_budget_config, validate_budget_config
from .losses import (DEPHASING_COEFFICIENT, dephasing_loss, detection_loss, heating_coefficient,
                     heating_loss, preparation_loss)
from .monte_carlo import error_budget
from .result import PAPER_TABLE, SOURCES, BudgetResult

__all__ = ["DEFAULT_CONFIG", "SOURCES", "PAPER_TABLE", "BudgetResult", "error_budget",
           "load_budget_config", "validate_budget_config", "gate_rates_khz",
           "heating_coefficient", "DEPHASING_COEFFICIENT", "preparation_loss", "dephasing_loss",
           "heating_loss", "detection_loss"]
