"""Test helpers for vcran and its users: hypothesis strategies (:mod:`vcran.testing.strategies`)."""
