"""Tests of dpdfit.pipeline: the steps of ``analyze`` and the outputs it publishes."""
