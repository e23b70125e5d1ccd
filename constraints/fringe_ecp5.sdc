# fringe on an ECP5-25k (Lattice Diamond / Radiant): one clock, 150 MHz (6.667 ns).
# `make synth` (nextpnr-ecp5) uses --freq 150 instead.
create_clock -name clk -period 6.667 [get_ports clk]
