"""Tests of ``dpdfit import``: ARTIQ results files read into a campaign folder by a mapping."""
