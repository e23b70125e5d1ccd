"""The `fringe` command line and the correction engines behind `fringe correct --engine`."""
