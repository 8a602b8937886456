"""Tests of dpdfit.fits: polynomial fits, calibration, counts, heterodyne tones, alignment."""
