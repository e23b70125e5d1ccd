"""Bit-exact models of the fringe RTL blocks (one module per block, same names as the HDL)."""
