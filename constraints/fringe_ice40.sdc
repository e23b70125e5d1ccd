# fringe on iCE40 UP5K: one clock, 48 MHz (20.833 ns)
create_clock -name clk -period 20.833 [get_ports clk]
