"""Tests of the diagnosis's evidence: interval scan, tempering, families."""
