"""The float signal model: the encoder simulator, the fits, the calibration's stages and the closed loop's
effect library."""
