// First source of tb/test_tech_ice40.py's builds: the iCE40 choices in the blocks (sim/synth.py defines
// it on Yosys's command line for the UP5K).
`define FRINGE_TECH_ICE40
