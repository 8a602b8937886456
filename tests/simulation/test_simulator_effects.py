"""``simulate-campaign --effects`` takes exactly the registered effects: one path (the
effect registry and each effect's ``inject_*`` hooks) from a name to the simulator."""

from dpdfit.analyses.diagnosis.effects import EFFECTS, Effect, Param, register, unregister
from dpdfit.cli.main import main
from dpdfit.simulation import injections
from dpdfit.simulation.campaign import SIMULATOR_EFFECTS, CampaignConfig, parse_effects


def test_simulator_effects_are_the_registry():
    assert list(SIMULATOR_EFFECTS) == list(EFFECTS)
    for name in EFFECTS:
        e = injections.get(name)
        param, unit, meaning = e.strength_of()
        assert SIMULATOR_EFFECTS[name] == (unit, meaning)
        # NAME=S injects S as that parameter, through the effect's own injection values
        cfg = CampaignConfig().with_effects(parse_effects(f"{name}=0.01"))
        assert cfg.injections() == [(e, e.injected({param: 0.01}))]
        assert cfg.effects == {name: 0.01}


def test_a_registered_effect_is_simulated_without_touching_the_simulator():
    class Probe(Effect):
        """A registered effect the simulator has never heard of."""
        name = "probe_effect"
        meaning = "a probe"
        params = (Param("k", "1", -1.0, 1.0, 0.0, 0.1, "its strength"),)

    register(Probe())
    try:
        assert SIMULATOR_EFFECTS["probe_effect"] == ("1", "its strength")
        cfg = CampaignConfig().with_effects(parse_effects("probe_effect=0.5"))
        (e, v), = cfg.injections()
        assert e.name == "probe_effect" and v == {"k": 0.5}
    finally:
        unregister("probe_effect")
    assert "probe_effect" not in SIMULATOR_EFFECTS


def test_no_effect_leaves_the_configuration_as_it_was():
    assert CampaignConfig().with_effects({}) == CampaignConfig()


def test_cli_help_lists_the_registered_effects_and_the_simulator_knobs(capsys):
    try:
        main(["simulate-campaign", "--help"])
    except SystemExit:
        pass
    out = " ".join(capsys.readouterr().out.split())
    for name in EFFECTS:
        assert name in out
    assert "--stale-days" in out and "--table-drift" in out


def test_cli_refuses_a_former_simulator_only_knob(tmp_path, capsys):
    assert main(["simulate-campaign", str(tmp_path / "c"), "--effects",
                 "calibration_drift=0.01"]) != 0
    assert "unknown effect 'calibration_drift'" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()
