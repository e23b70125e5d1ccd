# fringe for AMD Vivado: one clock domain (clk), no multicycle or false paths inside the core.
# 150 MHz (6.667 ns) here, the ECP5 target; use -period 20.833 for 48 MHz.
create_clock -name clk -period 6.667 [get_ports clk]
# As an IP inside a larger design, the clock comes from the parent's constraint: drop this file
# (or scope it with SCOPED_TO_REF fringe_top) and let the parent's create_clock reach clk.
