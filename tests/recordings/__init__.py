"""Tests of dpdfit.recordings: the campaign folder's readers, repeated recordings, ``dpdfit add``."""
