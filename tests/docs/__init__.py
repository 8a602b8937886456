"""Tests of the documentation: its pages, snippets, pointers, examples and generated tables."""
