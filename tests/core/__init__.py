"""Tests of dpdfit.core: model adequacy, the error model, result display, memory guards, worker processes."""
