"""Tests of the comparison of a diagnosis with the one after further recordings."""
