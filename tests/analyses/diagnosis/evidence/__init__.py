"""Tests of the diagnosis's evidence: deviation search, tempering, families."""
