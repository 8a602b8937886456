"""Tests of the diagnosis's catalog of effects: registration, forms left out."""
