"""The float engine: the correction pipeline in floating point (`fringe correct --engine float`)."""
