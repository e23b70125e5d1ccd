# fringe on ECP5-25k: one clock, 150 MHz (6.667 ns)
create_clock -name clk -period 6.667 [get_ports clk]
