# fringe on an iCE40 UP5K (Lattice Radiant / iCEcube2): one clock, 48 MHz (20.833 ns).
# `make synth` (nextpnr-ice40) uses --freq 48 and the pins of fringe_up5k.pcf instead.
create_clock -name clk -period 20.833 [get_ports clk]
