# fringe for Vivado: one clock; set the period to the sample clock you need (150 MHz here)
create_clock -name clk -period 6.667 [get_ports clk]
