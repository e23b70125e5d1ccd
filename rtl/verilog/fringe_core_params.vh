// fringe_core_params.vh: the parameter list of fringe_core, fringe_top and sim/synth_wrap.v, one text
// included inside each module's #( ... ). Written from CoreConfig (model/fringe/fixed/config.py:
// HDL_PARAMETER_DOCS and the defaults of CoreConfig()); the VHDL twins carry the same generics.
// BEGIN generated parameters (written by python sim/hdlgen.py; do not edit)
parameter integer ADC_W                = 12,    // ADC code width (signed), 4..24
parameter integer LINES                = 256,   // signal periods per revolution, 1..2^20 (POS_W = clog2(LINES) + FINE_W <= 31)
parameter integer COARSE_W             = 9,     // coarse code bits, 0 = none (periods are counted); else 2^COARSE_W >= LINES, <= FINE_W-2
parameter integer WAVE_ADDR_W          = 8,     // waveform table address bits per branch, 2..min(ADC_W-1, 15)
parameter integer WAVE_W               = 18,    // waveform table / quadrature data width, 8..31
parameter integer COEF_W               = 18,    // quadrature gain width (COEF_W-2 fraction bits), 8..27
parameter integer FINE_W               = 16,    // fine phase bits per signal period, 8..30
parameter integer CORDIC_STAGES        = 18,    // CORDIC micro-rotations, 4..32
parameter integer CORDIC_GUARD         = 3,     // extra fraction bits inside the CORDIC, 0..8
parameter integer COMPACT              = 0,     // 1 = time-multiplexed: one sample per CORDIC_STAGES clocks, iterated CORDIC (same words)
parameter integer LP_ADDR_W            = 8,     // long-period table entries per revolution = 2^LP_ADDR_W, <= 16
parameter integer LP_W                 = 18,    // long-period table value/slope width, <= 32
parameter integer LP_FRAC              = 4,     // fraction bits of the long-period correction (fine counts)
parameter integer LP_IF                = 8,     // interpolation fraction bits of the long-period table
parameter [63:0]  LP_RECIP             = 64'd1, // long-period index multiplier (long_period.index_mapping; < 2^31 in VHDL)
parameter integer LP_SHIFT             = 16,    // long-period index shift (long_period.index_mapping)
// fringe_trim (closed-loop corrections): built only with TRIM = 1
parameter integer TRIM                 = 0,     // 1 = fringe_trim between the period count and the long-period table (docs/blocks/fringe_trim.md)
parameter integer TRIM_SPEED_LOG2      = 5,     // speed window 2^TRIM_SPEED_LOG2 samples, 0..8
parameter integer TRIM_MAP_PSI_W       = 6,     // 2^TRIM_MAP_PSI_W error-map sectors per revolution, 0..8
parameter integer TRIM_MAP_PHI_W       = 5,     // 2^TRIM_MAP_PHI_W error-map bins per period, 2..min(10, FINE_W-1); TRIM_MAP_PSI_W + TRIM_MAP_PHI_W <= 15
parameter integer TRIM_W               = 18,    // trim table value/slope width, 8..24
parameter integer TRIM_FRAC            = 4,     // fraction bits of the trim (fine counts), 0..16
parameter integer TRIM_G_SHIFT         = 24,    // right shift of the speed and magnitude products, 1..48
parameter [63:0]  TRIM_SECT_RECIP      = 64'd1, // sector multiplier (trim.sector_mapping; < 2^31 in VHDL)
parameter integer TRIM_SECT_SHIFT      = 18,    // sector shift (trim.sector_mapping)
parameter integer TRIM_START_SPEED     = 0,     // speed of the first sample after reset (no window yet), fine counts per 2^TRIM_SPEED_LOG2 samples, -REV/2..REV/2-1
parameter integer TRIM_MAG_SMOOTH_LOG2 = 0,     // the magnitude terms take the magnitude's running average over ~2^TRIM_MAG_SMOOTH_LOG2 samples, 0 (the sample's own)..12
// the drift tracker (fringe_drift_normaliser, fringe_drift_observer): built only with DRIFT = 1
parameter integer DRIFT                = 0,     // 1 = the drift tracker normalises the ADC codes in front of everything (docs/drift.md)
parameter integer DRIFT_BLOCK_LOG2     = 8,     // samples per tracker block = 2^DRIFT_BLOCK_LOG2, 4..12 (>= 7 in the core with DRIFT_HOLD = 0)
parameter integer DRIFT_MU_LOG2        = 1,     // final tracker step 2^-DRIFT_MU_LOG2 per update (gear shift from 1), 0..8
parameter integer DRIFT_OFS_FRAC       = 4,     // fraction bits of the tracked offsets, 0..8
parameter integer DRIFT_GINV_W         = 18,    // tracked inverse gains u(DRIFT_GINV_W), 8..24
parameter integer DRIFT_FWD_W          = 8,     // 2^DRIFT_FWD_W bins of the forward waveform tables, 2..10
parameter integer DRIFT_TABLE_W        = 18,    // forward table value/slope width, 8..24
parameter integer DRIFT_TABLE_FRAC     = 4,     // fraction bits of the forward tables and W0_S/W0_C, 0..12
parameter integer DRIFT_KG_W           = 18,    // KG_S/KG_C width, 8..24
parameter integer DRIFT_KG_SHIFT       = 40,    // right shift of the gain-loop product, 1..60
parameter integer DRIFT_HOLD           = 1,     // 1 = tracker updates apply at the block boundary, in_ready holds the input until ready; 0 = half a block later, no hold
// fringe_canceller (the adaptive interference canceller): built only with CANCEL = 1
parameter integer CANCEL               = 0,     // 1 = fringe_canceller between the quadrature and the CORDIC (docs/blocks/fringe_canceller.md)
parameter integer CANCEL_LUT_W         = 10,    // 2^CANCEL_LUT_W entries of the canceller's sine table, 4..12
parameter integer CANCEL_C_W           = 16,    // canceller sine table value width, 8..18
parameter integer CANCEL_BLOCK_LOG2    = 4,     // samples per canceller update = 2^CANCEL_BLOCK_LOG2, 4..12
parameter integer CANCEL_MU_LOG2       = 6,     // final canceller step 2^-CANCEL_MU_LOG2 per block, 1..12
parameter integer CANCEL_A_FRAC        = 4,     // fraction bits of the canceller coefficients, 0..12
parameter integer CANCEL_A_W           = 20,    // canceller coefficient width, 8..min(32, WAVE_W + CANCEL_A_FRAC)
parameter integer CANCEL_GEAR_OFFSET   = 0,     // the canceller's gear shift starts this many gears lower, 0..CANCEL_MU_LOG2-1
// initial contents: $readmemh images, "" = zeros
parameter         REGS_INIT            = "",    // $readmemh image of the registers, 2 x 32 words of 32 bits
parameter         WAVE_SIN_INIT        = "",    // $readmemh image of the sine table, both banks
parameter         WAVE_COS_INIT        = "",    // $readmemh image of the cosine table, both banks
parameter         LP_INIT              = "",    // $readmemh image of the long-period table, both banks
parameter         TRIM_MAP_INIT        = "",    // $readmemh image of the trim map, both banks (TRIM = 1)
parameter         TRIM_SPEED_INIT      = "",    // $readmemh image of the trim speed table, both banks (TRIM = 1)
parameter         TRIM_AMP_INIT        = "",    // $readmemh image of the trim magnitude table, both banks (TRIM = 1)
parameter         DRIFT_FWD_SIN_INIT   = "",    // $readmemh image of the drift sine forward table, both banks (DRIFT = 1)
parameter         DRIFT_FWD_COS_INIT   = "",    // $readmemh image of the drift cosine forward table, both banks (DRIFT = 1)
parameter         CANCEL_LUT_INIT      = ""     // $readmemh image of the canceller's sine table (CANCEL = 1; canceller.sine_table)
// END generated parameters
