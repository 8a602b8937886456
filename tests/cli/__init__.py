"""Tests of the ``dpdfit`` command line: contracts, bad input, failures, messages."""
