// fringe_formal_params.vh: the core parameters of the formal wrappers (fringe_top_stream.sv,
// fringe_top_miter.sv), included inside their #( ... ) before their own parameters. The defaults are a
// small legal configuration; run.py sets every parameter of its configuration (chparam).
parameter integer ADC_W = 4, parameter integer LINES = 4, parameter integer COARSE_W = 2,
parameter integer WAVE_ADDR_W = 2, parameter integer WAVE_W = 8, parameter integer COEF_W = 8,
parameter integer FINE_W = 8, parameter integer CORDIC_STAGES = 4, parameter integer CORDIC_GUARD = 1,
parameter integer LP_ADDR_W = 2, parameter integer LP_W = 8, parameter integer LP_FRAC = 2,
parameter integer LP_IF = 2, parameter [63:0] LP_RECIP = 64'd1, parameter integer LP_SHIFT = 8,
