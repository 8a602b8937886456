"""Tests of dpdfit.simulation: the campaign simulator, effect injection, the harness, recorded schedules."""
