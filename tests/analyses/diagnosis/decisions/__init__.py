"""Tests of the diagnosis's decisions: alternatives, upper limits."""
