// fringe_pkg.vh: what every fringe block shares, Verilog-2005 (twin: rtl/vhdl/fringe_pkg.vhd).
//
// Included inside a module body (`include "fringe_pkg.vh"): the exact reciprocal-mapping check
// of fringe_long_period and fringe_trim, and the constants generated from the Python single
// source (register map, address spaces, status bits, block latencies); the macros of the parameter
// checks, of saturation (FRINGE_OUTSIDE, FRINGE_SATURATE) and of a memory's initial contents
// (FRINGE_MEM_INIT). Widths use $clog2 (integer arithmetic). The $readmemh images are read by
// $readmemh itself.

// A module uses a few of the shared constants; the others are not an error.
/* verilator lint_off UNUSEDPARAM */
// BEGIN generated constants (written by python sim/hdlgen.py; do not edit)
localparam integer REG_W                   = 32;  // bits per register word
localparam integer N_REGS                  = 32;  // register words per bank
localparam integer REG_INDEX_W             = 5;  // bits of a register's index in its bank
localparam [4:0]   REG_K_SS                = 5'd0;  // s(COEF_W)
localparam [4:0]   REG_K_SC                = 5'd1;  // s(COEF_W)
localparam [4:0]   REG_K_CC                = 5'd2;  // s(COEF_W)
localparam [4:0]   REG_OFS_S               = 5'd3;  // s(WAVE_W)
localparam [4:0]   REG_OFS_C               = 5'd4;  // s(WAVE_W)
localparam [4:0]   REG_MID_S               = 5'd5;  // s(ADC_W+1)
localparam [4:0]   REG_THR_HI_S            = 5'd6;  // s(ADC_W+1)
localparam [4:0]   REG_THR_LO_S            = 5'd7;  // s(ADC_W+1)
localparam [4:0]   REG_MID_C               = 5'd8;  // s(ADC_W+1)
localparam [4:0]   REG_THR_HI_C            = 5'd9;  // s(ADC_W+1)
localparam [4:0]   REG_THR_LO_C            = 5'd10;  // s(ADC_W+1)
localparam [4:0]   REG_COARSE_OFS          = 5'd11;  // s(POS_W+1)
localparam [4:0]   REG_ZERO                = 5'd12;  // u(POS_W)
localparam [4:0]   REG_DIR                 = 5'd13;  // u(1)
localparam [4:0]   REG_AMP_LOW             = 5'd14;  // u(WAVE_W+1)
localparam [4:0]   REG_AMP_HIGH            = 5'd15;  // u(WAVE_W+1)
localparam [4:0]   REG_W0_S                = 5'd16;  // s(ADC_W+DRIFT_TABLE_FRAC)
localparam [4:0]   REG_W0_C                = 5'd17;  // s(ADC_W+DRIFT_TABLE_FRAC)
localparam [4:0]   REG_KG_S                = 5'd18;  // u(DRIFT_KG_W)
localparam [4:0]   REG_KG_C                = 5'd19;  // u(DRIFT_KG_W)
localparam [4:0]   REG_CANCEL_FREQ         = 5'd20;  // u(32)
localparam [15:0]  CTRL_WORD               = 16'd128;  // register-space word of CTRL
localparam integer CTRL_SWAP               = 0;  // CTRL bit: 1 swaps the banks
localparam integer SPACE_LSB               = 16;  // cfg_wr_addr bit where the address space starts
localparam [3:0]   SPACE_REGS              = 4'd0;  // cfg_wr_addr[19:16] of the regs image
localparam [3:0]   SPACE_WAVE_SIN          = 4'd1;  // cfg_wr_addr[19:16] of the wave_sin image
localparam [3:0]   SPACE_WAVE_COS          = 4'd2;  // cfg_wr_addr[19:16] of the wave_cos image
localparam [3:0]   SPACE_LONG_PERIOD       = 4'd3;  // cfg_wr_addr[19:16] of the long_period image
localparam [3:0]   SPACE_TRIM_MAP          = 4'd4;  // cfg_wr_addr[19:16] of the trim_map image
localparam [3:0]   SPACE_TRIM_SPEED        = 4'd5;  // cfg_wr_addr[19:16] of the trim_speed image
localparam [3:0]   SPACE_TRIM_AMP          = 4'd6;  // cfg_wr_addr[19:16] of the trim_amp image
localparam [3:0]   SPACE_DRIFT_FWD_SIN     = 4'd7;  // cfg_wr_addr[19:16] of the drift_fwd_sin image
localparam [3:0]   SPACE_DRIFT_FWD_COS     = 4'd8;  // cfg_wr_addr[19:16] of the drift_fwd_cos image
localparam integer STATUS_W                = 8;  // bits of the status word
localparam integer STATUS_CLIP_SIN         = 0;  // status bit
localparam integer STATUS_CLIP_COS         = 1;  // status bit
localparam integer STATUS_AMP_LOW          = 2;  // status bit
localparam integer STATUS_AMP_HIGH         = 3;  // status bit
localparam integer STATUS_OVERSPEED        = 4;  // status bit
localparam integer STATUS_COARSE_ERR       = 5;  // status bit
localparam integer STATUS_SATURATED        = 6;  // status bit
localparam integer STATUS_BANK             = 7;  // status bit
localparam integer CORE_INPUT_LATENCY      = 2;  // fringe_core input registers
localparam integer WAVE_LUT_LATENCY        = 4;  // fringe_wave_lut
localparam integer QUADRATURE_LATENCY      = 5;  // fringe_quadrature
localparam integer CORDIC_LATENCY_BASE     = 2;  // fringe_cordic: STAGES + this
localparam integer CORDIC_ITER_CLOCKS_BASE = 0;  // fringe_cordic ITERATIVE = 1: a sample every STAGES + this clock enables
localparam integer PERIOD_COUNT_LATENCY    = 4;  // fringe_period_count
localparam integer TRIM_LATENCY            = 13;  // fringe_trim
localparam integer LONG_PERIOD_LATENCY     = 8;  // fringe_long_period
localparam integer DRIFT_NORM_LATENCY      = 5;  // fringe_drift_normaliser
localparam integer DRIFT_OBS_LATENCY       = 16;  // fringe_drift_observer
localparam integer DRIFT_SWEEP_MIN_LOG2    = 4;  // fringe_drift_observer: a block that swept 2^-this of a period updates
localparam integer DRIFT_PARTIAL_MU_MIN    = 2;  // fringe_drift_observer: ... if MU_LOG2 is at least this
localparam integer CANCEL_LATENCY          = 4;  // fringe_canceller
localparam integer CANCEL_ADAPT_LATENCY    = 15;  // fringe_canceller: a block's last sample to its update in place
// END generated constants
/* verilator lint_on UNUSEDPARAM */

// Parameter checks inside a generate region: stop elaboration with the model's ValueError text (and
// the instance path). LABEL names the generate block, UNIT and NAME are string literals, NAME's value V.
`ifndef FRINGE_CHECK_RANGE
`define FRINGE_CHECK_RANGE(LABEL, UNIT, NAME, V, LO, HI) \
    if ((V) < (LO) || (V) > (HI)) begin : LABEL \
        $error("%s: %s = %0d out of range %0d..%0d (instance %m)", UNIT, NAME, V, LO, HI); \
    end
`define FRINGE_CHECK_MIN(LABEL, UNIT, NAME, V, LO) \
    if ((V) < (LO)) begin : LABEL \
        $error("%s: %s = %0d must be >= %0d (instance %m)", UNIT, NAME, V, LO); \
    end
`define FRINGE_CHECK_BIT(LABEL, UNIT, NAME, V) \
    if ((V) != 0 && (V) != 1) begin : LABEL \
        $error("%s: %s = %0d must be 0 or 1 (instance %m)", UNIT, NAME, V); \
    end
// The blocks that count in REV = LINES * 2^FINE_W: FINE_W, LINES and POS_W = FINE_W + clog2(LINES) (the
// VHDL's check_position); generate blocks g_bad_fine_w, g_bad_lines, g_bad_pos_w.
`define FRINGE_CHECK_POSITION(UNIT, FW, LN, PMAX) \
    `FRINGE_CHECK_RANGE(g_bad_fine_w, UNIT, "FINE_W", FW, 8, 30) \
    if ((LN) < 1 || (LN) > (1 << 20)) begin : g_bad_lines \
        $error("%s: LINES = %0d out of range 1..2^20 (instance %m)", UNIT, LN); \
    end \
    if ((FW) + $clog2(LN) > (PMAX)) begin : g_bad_pos_w \
        $error("%s: POS_W = FINE_W + clog2(LINES) = %0d exceeds %0d (instance %m)", UNIT, (FW) + $clog2(LN), PMAX); \
    end
// The drift tracker's halves (the VHDL's check_drift_state and check_drift_observer), on the module's own
// parameters of these names: the state and the block (ADC_W, BLOCK_LOG2, OFS_FRAC, ADC_W + OFS_FRAC <=
// 32, GINV_W, HOLD), and the observer's (FINE_W, MU_LOG2, FWD_W, TABLE_W, TABLE_FRAC, KG_W, KG_SHIFT);
// generate blocks g_bad_<name>.
`define FRINGE_CHECK_DRIFT_STATE(UNIT) \
    `FRINGE_CHECK_RANGE(g_bad_adc_w, UNIT, "ADC_W", ADC_W, 4, 24) \
    `FRINGE_CHECK_RANGE(g_bad_block_log2, UNIT, "BLOCK_LOG2", BLOCK_LOG2, 4, 12) \
    `FRINGE_CHECK_RANGE(g_bad_ofs_frac, UNIT, "OFS_FRAC", OFS_FRAC, 0, 8) \
    if (ADC_W + OFS_FRAC > 32) begin : g_bad_ofs_w \
        $error("%s: ADC_W + OFS_FRAC = %0d exceeds 32 (instance %m)", UNIT, ADC_W + OFS_FRAC); \
    end \
    `FRINGE_CHECK_RANGE(g_bad_ginv_w, UNIT, "GINV_W", GINV_W, 8, 24) \
    `FRINGE_CHECK_RANGE(g_bad_hold, UNIT, "HOLD", HOLD, 0, 1)
`define FRINGE_CHECK_DRIFT_OBSERVER(UNIT) \
    `FRINGE_CHECK_RANGE(g_bad_fine_w, UNIT, "FINE_W", FINE_W, 8, 30) \
    `FRINGE_CHECK_RANGE(g_bad_mu_log2, UNIT, "MU_LOG2", MU_LOG2, 0, 8) \
    if (FWD_W < 2 || FWD_W > ((FINE_W - 1 < 10) ? FINE_W - 1 : 10)) begin : g_bad_fwd_w \
        $error("%s: FWD_W = %0d out of range 2..min(10, FINE_W-1) = %0d (instance %m)", UNIT, FWD_W, \
               (FINE_W - 1 < 10) ? FINE_W - 1 : 10); \
    end \
    `FRINGE_CHECK_RANGE(g_bad_table_w, UNIT, "TABLE_W", TABLE_W, 8, 24) \
    `FRINGE_CHECK_RANGE(g_bad_table_frac, UNIT, "TABLE_FRAC", TABLE_FRAC, 0, 12) \
    `FRINGE_CHECK_RANGE(g_bad_kg_w, UNIT, "KG_W", KG_W, 8, 24) \
    `FRINGE_CHECK_RANGE(g_bad_kg_shift, UNIT, "KG_SHIFT", KG_SHIFT, 1, 60)
`endif

// Saturation (the VHDL's outside and saturate), X the name of a signed XW-bit value (a name: it is
// indexed): `FRINGE_OUTSIDE(X, XW, W) is 1 when X is outside s(W) (bits XW-1 .. W-1 not all equal to
// the sign); `FRINGE_SATURATE(X, XW, W) is X clipped to s(W), W bits.
`ifndef FRINGE_OUTSIDE
`define FRINGE_OUTSIDE(X, XW, W) (X[(XW)-1] ? ~&X[(XW)-1:(W)-1] : |X[(XW)-1:(W)-1])
`define FRINGE_SATURATE(X, XW, W) \
    (`FRINGE_OUTSIDE(X, XW, W) ? {X[(XW)-1], {((W)-1){~X[(XW)-1]}}} : X[(W)-1:0])
`endif

// A memory's initial contents inside a generate region: the $readmemh image FILE (a string parameter)
// or, when FILE is "", DEPTH words of W zero bits (the VHDL's read_hex_image). Two separate initial
// blocks: Yosys 0.23 loses the $readmemh image when a zeroing loop precedes it in the same block.
// Generate blocks g_init_file, g_init_zero.
`ifndef FRINGE_MEM_INIT
`define FRINGE_MEM_INIT(FILE, MEM, DEPTH, W) \
    if (FILE != "") begin : g_init_file \
        initial $readmemh(FILE, MEM); \
    end else begin : g_init_zero \
        integer i; \
        initial begin \
            for (i = 0; i < (DEPTH); i = i + 1) begin \
                MEM[i] = {(W){1'b0}}; \
            end \
        end \
    end
`endif

// A slice of an image: MEM, declared with the image's addresses [FIRST : FIRST+DEPTH-1], gets words
// FIRST .. FIRST+DEPTH-1 of the $readmemh image FILE (missing words and FILE = "" give zeros; the VHDL's
// read_memh with its `first`). A RAM piece thus holds its own words only. $readmemh cannot skip words
// portably: Yosys drops the image's words that lie outside MEM, but Verilator stops at the first of
// them and Icarus refuses a start address below MEM. So simulators read FILE with $fgetc as $readmemh
// does (hex words separated by white space, "//" comments) and stop after the slice; Yosys (SYNTHESIS)
// loads from word 0 and keeps MEM's words. Generate blocks g_init_file, g_init_zero / g_init_slice.
`ifndef FRINGE_MEM_INIT_SLICE
`ifdef SYNTHESIS
`define FRINGE_MEM_INIT_SLICE(FILE, MEM, FIRST, DEPTH, W) \
    if (FILE != "") begin : g_init_file \
        initial $readmemh(FILE, MEM, 0, (FIRST) + (DEPTH) - 1); \
    end else begin : g_init_zero \
        integer i; \
        initial begin \
            for (i = 0; i < (DEPTH); i = i + 1) begin \
                MEM[(FIRST) + i] = {(W){1'b0}}; \
            end \
        end \
    end
`else
`define FRINGE_MEM_INIT_SLICE(FILE, MEM, FIRST, DEPTH, W) \
    if (1) begin : g_init_slice \
        integer fd, c, n, i; \
        reg [(W)-1:0] word; \
        /* verilator lint_off UNUSEDSIGNAL */ \
        reg [(W)+3:0] acc; /* a word's digits above W bits are dropped, as $readmemh drops them */ \
        /* verilator lint_on UNUSEDSIGNAL */ \
        reg in_word, comment; \
        initial begin \
            for (i = 0; i < (DEPTH); i = i + 1) begin \
                MEM[(FIRST) + i] = {(W){1'b0}}; \
            end \
            if (FILE != "") begin \
                fd = $fopen(FILE, "r"); \
                if (fd == 0) begin \
                    $fatal(1, "cannot open INIT_FILE %0s (instance %m)", FILE); \
                end \
                n = 0; \
                word = {(W){1'b0}}; \
                in_word = 1'b0; \
                comment = 1'b0; \
                c = 0; \
                while (c != -1 && n < (FIRST) + (DEPTH)) begin \
                    c = $fgetc(fd); \
                    if (comment) begin \
                        comment = (c != 10); \
                    end else if ((c >= "0" && c <= "9") || (c >= "a" && c <= "f") || (c >= "A" && c <= "F")) begin \
                        acc = {word, c[3:0] + (c > "9" ? 4'd9 : 4'd0)}; /* "a" and "A" end in 1 */ \
                        word = acc[(W)-1:0]; \
                        in_word = 1'b1; \
                    end else if (c == "_" && in_word) begin \
                    end else if (c == -1 || c == " " || c == 9 || c == 10 || c == 13 || c == "/") begin \
                        if (in_word && n >= (FIRST)) begin \
                            MEM[n] = word; \
                        end \
                        n = n + (in_word ? 1 : 0); \
                        word = {(W){1'b0}}; \
                        in_word = 1'b0; \
                        comment = (c == "/"); \
                    end else begin \
                        $fatal(1, "INIT_FILE %0s: character %0d after word %0d is not hex, white space or a comment (instance %m)", \
                               FILE, c, n); \
                    end \
                end \
                $fclose(fd); \
            end \
        end \
    end
`endif
`endif

// LATENCY of fringe_core and fringe_top (trim, drift, cancel: the TRIM, DRIFT and CANCEL parameters, 0 or
// 1): the input registers and the blocks in the chain, from the generated block latencies above
function integer fringe_core_latency;
    input integer cordic_stages;
    input integer trim;
    input integer drift;
    input integer cancel;
    begin
        fringe_core_latency = CORE_INPUT_LATENCY + WAVE_LUT_LATENCY + QUADRATURE_LATENCY + cordic_stages
                              + CORDIC_LATENCY_BASE + PERIOD_COUNT_LATENCY + LONG_PERIOD_LATENCY
                              + trim * TRIM_LATENCY + drift * DRIFT_NORM_LATENCY + cancel * CANCEL_LATENCY;
    end
endfunction

// trailing zero bits of 1 <= v < 2^31 (its 2-adic valuation), at most 30
function integer fringe_trailing_zeros;
    input integer v;
    integer k;
    begin
        fringe_trailing_zeros = 0;
        for (k = 1; k <= 30; k = k + 1) begin      // a bounded loop: Yosys evaluates it at elaboration
            if (v % (1 << k) == 0) begin
                fringe_trailing_zeros = k;
            end
        end
    end
endfunction

// 1 when floor(p * recip / 2^shift) = floor(p * 2^addr_w / REV) for every position
// 0 <= p < REV = lines * 2^fine_w (Granlund-Montgomery bound, model:
// fringe.fixed.long_period.mapping_ok): with E = recip * REV - 2^(addr_w + shift) and
// 2^G = gcd(2^addr_w, REV), E >= 0 and (REV - 1) * E < 2^(G + shift). 256-bit arithmetic.
function fringe_mapping_exact;
    input [63:0]  recip;
    input integer shift;
    input integer addr_w;
    input integer lines;
    input integer fine_w;
    reg   [255:0] rev_x, prod, pw, e, lhs, rhs;
    integer       g_log;
    begin
        g_log = fine_w + fringe_trailing_zeros(lines);
        if (addr_w < g_log) begin
            g_log = addr_w;
        end
        rev_x = {224'd0, lines} << fine_w;
        prod  = {192'd0, recip} * rev_x;
        pw    = 256'd1 << (addr_w + shift);
        e     = prod - pw;
        lhs   = (rev_x - 256'd1) * e;
        rhs   = 256'd1 << (g_log + shift);
        fringe_mapping_exact = (lines > 0) && (recip != 64'd0) && (prod >= pw) && (lhs < rhs);
    end
endfunction
