"""Files: recordings, safe outputs, calibration folders and the shared data sets."""
