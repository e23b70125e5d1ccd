// First source of tb/test_tech_ecp5.py's builds: the ECP5 technology layer (sim/synth.py defines
// it on Yosys's command line).
`define FRINGE_TECH_ECP5
