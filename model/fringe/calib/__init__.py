"""Fitting a recording (the calibration) and judging a correction."""
