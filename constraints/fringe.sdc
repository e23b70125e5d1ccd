# fringe_top / fringe_core: one clock domain (clk), no multicycle or false paths inside the core.
# SDC for vendor flows (Lattice Radiant, Intel Quartus, Synopsys-style tools); `make synth` itself
# gives nextpnr the same periods with --freq (constraints/README.md).
#
# Pick the variant of the target device (the project's targets: iCE40 UP5K >= 48 MHz, ECP5-25k
# >= 150 MHz) by setting FRINGE_CLK_MHZ before sourcing this file; 150 MHz by default.
if {![info exists FRINGE_CLK_MHZ]} { set FRINGE_CLK_MHZ 150.0 }
# 48 MHz:  create_clock -name clk -period 20.833 [get_ports clk]
# 150 MHz: create_clock -name clk -period 6.667  [get_ports clk]
create_clock -name clk -period [expr {1000.0 / $FRINGE_CLK_MHZ}] [get_ports clk]
# rst and the configuration port are synchronous to clk; the AXI4-Stream ports are registered
# inside the core on the s_axis side (s_axis_tready = ce is a combinational function of
# m_axis_tvalid and m_axis_tready, as AXI4-Stream allows). When the core is the top of a chip,
# constrain its pins against the board, e.g.:
#   set_input_delay  -clock clk 2.0 [all_inputs]
#   set_output_delay -clock clk 2.0 [all_outputs]
