"""Benchmarks and the blind studies (scripts; benchmarks.blind is also imported by the tests)."""
