"""Tests of the package as a whole: its structure, docstrings, installed data, Python API."""
