"""Tests of the diagnosis's proposal: next measurement, expected separation, schedule."""
