"""Tests of dpdfit.analyses.diagnosis, one folder per stage where a file tests one."""
