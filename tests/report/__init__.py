"""Tests of dpdfit.report: figures, report lines, the summary."""
