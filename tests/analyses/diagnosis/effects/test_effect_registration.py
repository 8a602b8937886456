"""Adding an effect is its module and one registration: the diagnosis fits, names and
sizes it, the simulator injects it, the harness plans it, the catalog lists it."""

import numpy as np
import pytest

from dpdfit.analyses.diagnosis.diagnose import diagnose
from dpdfit.analyses.diagnosis.effects import default_effects, register, unregister
from dpdfit.simulation.campaign import SIMULATOR_EFFECTS, simulate_campaign
from dpdfit.simulation.harness import concealed_effects, harness_config, plan

from tests.helpers.registered_effect import registered_effect
from tests.helpers.seventh_order_effect import EFFECT as PM7
from tests.helpers.seventh_order_effect import INJECTION as PM7_INJECTION


@pytest.fixture
def registered():
    with registered_effect(PM7, PM7_INJECTION):
        yield PM7


def test_a_registered_effect_appears_in_every_derived_list(registered):
    assert PM7.name in default_effects() and PM7.name in concealed_effects()
    assert PM7.name in SIMULATOR_EFFECTS         # simulate-campaign --effects takes it
    jobs = plan(1, 0, seed=3, effects=(PM7.name,))
    (v,) = jobs[0]["effects"].values()
    assert set(jobs[0]["effects"]) == {PM7.name} and 0.08 <= abs(v["phi7"]) <= 0.12


def test_register_refuses_a_second_effect_of_the_same_name(registered):
    from tests.helpers.seventh_order_effect import SeventhOrderPM
    with pytest.raises(ValueError, match="already registered"):
        register(SeventhOrderPM())
    with pytest.raises(ValueError, match="belongs to the catalog"):
        unregister("dephasing")


@pytest.mark.slow
def test_a_registered_effect_is_injected_named_and_sized(registered, tmp_path):
    seed = 5151
    phi7 = 0.1
    cfg = harness_config(seed).inject({PM7.name: {"phi7": phi7}})
    simulate_campaign(tmp_path / "c", seed=seed, config=cfg, progress=False)
    (tmp_path / "c" / "truth.json").unlink()
    d = diagnose(tmp_path / "c", progress=False)
    assert d.verdict == PM7.name, d.report()
    size = d.effects[0]["sizes"]["phi7"]
    assert abs(size["value"] - phi7) < 3 * size["error"] + 0.05 * phi7, size
    assert np.isfinite(d.effects[0]["fidelity_cost"])
