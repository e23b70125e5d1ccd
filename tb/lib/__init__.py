"""The fringe testbench library: what the block tests in tb/ share (import as ``lib.<module>``)."""
