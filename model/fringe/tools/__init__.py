"""Benchmarks (`make bench`), the randomised population of the closed loop and the demo (`make demo`)."""
