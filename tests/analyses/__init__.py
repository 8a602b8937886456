"""Tests of dpdfit.analyses: sweep, stability, posterior propagation, budget, trace estimate."""
