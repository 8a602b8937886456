"""Test-only helpers: reference implementations, generators and an outside effect.

Not tests themselves (no ``test_`` prefix); imported as ``tests.helpers.<module>``.
"""
