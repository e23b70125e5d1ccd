// fringe_top: fringe_core with AXI4-Stream sample input and position output.
//
// docs/architecture.md, "Top level":
//   s_axis_tdata = {coarse lane, cos lane, sin lane}: sin in [ADC_W-1:0], cos from bit ADC_LANE,
//                  coarse from bit 2*ADC_LANE (no coarse lane when COARSE_W = 0), each field
//                  right-aligned in a lane of whole bytes, ADC_LANE = 8*ceil(ADC_W/8); the padding
//                  bits of a lane are ignored.
//   m_axis_tdata = {status (8 bits), position lane (8*ceil(POS_W/8) bits)}, the position
//                  right-aligned and zero-padded.
//   Backpressure: the whole pipeline advances on ce = !m_axis_tvalid || m_axis_tready and
//   s_axis_tready = ce && the core's in_ready: one sample per clock (COMPACT = 1: per CLOCKS_PER_SAMPLE
//   = CORDIC_STAGES + 1 clock enables), nothing lost or duplicated. m_axis_tvalid is the
//   core's registered out_valid, so m_axis_tdata is stable while the sink stalls.
//   Configuration write port and active_bank: see rtl/verilog/fringe_core.v.
// rst (synchronous, active high) empties the pipeline: m_axis_tvalid is 0 after it, samples in
// flight and a sample taken in the same clock are dropped.
//
// LATENCY = fringe_core LATENCY = CORDIC_STAGES + 24 (+ 12 with TRIM = 1, + 4 with DRIFT = 1) clocks from the s_axis handshake to
// m_axis_tvalid when the sink does not stall (every stall adds its cycles).

`default_nettype none

module fringe_top #(
    // BEGIN generated parameters (written by python sim/hdlgen.py; do not edit)
    parameter integer ADC_W            = 12,    // ADC code width (signed), 4..24
    parameter integer LINES            = 256,   // signal periods per revolution, 1..2^20 (POS_W = clog2(LINES) + FINE_W <= 31)
    parameter integer COARSE_W         = 9,     // coarse code bits, 0 = none (periods are counted); else 2^COARSE_W >= LINES, <= FINE_W-2
    parameter integer WAVE_ADDR_W      = 8,     // waveform table address bits per branch, 2..min(ADC_W-1, 15)
    parameter integer WAVE_W           = 18,    // waveform table / quadrature data width, 8..31
    parameter integer COEF_W           = 18,    // quadrature gain width (COEF_W-2 fraction bits), 8..27
    parameter integer FINE_W           = 16,    // fine phase bits per signal period, 8..30
    parameter integer CORDIC_STAGES    = 18,    // CORDIC micro-rotations, 4..32
    parameter integer CORDIC_GUARD     = 3,     // extra fraction bits inside the CORDIC, 0..8
    parameter integer COMPACT          = 0,     // 1 = time-multiplexed: one sample per CORDIC_STAGES + 1 clocks, iterated CORDIC (same words)
    parameter integer LP_ADDR_W        = 8,     // long-period table entries per revolution = 2^LP_ADDR_W, <= 16
    parameter integer LP_W             = 18,    // long-period table value/slope width, <= 32
    parameter integer LP_FRAC          = 4,     // fraction bits of the long-period correction (fine counts)
    parameter integer LP_IF            = 8,     // interpolation fraction bits of the long-period table
    parameter [63:0]  LP_RECIP         = 64'd1, // long-period index multiplier (long_period.index_mapping; < 2^31 in VHDL)
    parameter integer LP_SHIFT         = 16,    // long-period index shift (long_period.index_mapping)
    // fringe_trim (closed-loop corrections): built only with TRIM = 1
    parameter integer TRIM             = 0,     // 1 = fringe_trim between the period count and the long-period table (docs/blocks/fringe_trim.md)
    parameter integer SPEED_LOG2       = 5,     // speed window 2^SPEED_LOG2 samples, 0..8
    parameter integer MAP_PSI_W        = 6,     // 2^MAP_PSI_W error-map sectors per revolution, 0..8
    parameter integer MAP_PHI_W        = 5,     // 2^MAP_PHI_W error-map bins per period, 2..min(10, FINE_W-1); MAP_PSI_W + MAP_PHI_W <= 15
    parameter integer TRIM_W           = 18,    // trim table value/slope width, 8..24
    parameter integer TRIM_FRAC        = 4,     // fraction bits of the trim (fine counts), 0..16
    parameter integer G_SHIFT          = 24,    // right shift of the speed and magnitude products, 1..48
    parameter [63:0]  SECT_RECIP       = 64'd1, // sector multiplier (trim.sector_mapping; < 2^31 in VHDL)
    parameter integer SECT_SHIFT       = 18,    // sector shift (trim.sector_mapping)
    // fringe_drift (the online offset/gain tracker): built only with DRIFT = 1
    parameter integer DRIFT            = 0,     // 1 = fringe_drift normalises the ADC codes in front of everything (docs/blocks/fringe_drift.md)
    parameter integer DRIFT_BLOCK_LOG2 = 8,     // samples per tracker update = 2^DRIFT_BLOCK_LOG2, >= 7 in the core (PIPE_D)
    parameter integer DRIFT_MU_LOG2    = 1,     // tracker step 2^-DRIFT_MU_LOG2 per block, 0..8
    parameter integer DRIFT_OFS_FRAC   = 4,     // fraction bits of the tracked offsets, 0..8
    parameter integer DRIFT_GINV_W     = 18,    // tracked inverse gains u(DRIFT_GINV_W), 8..24
    parameter integer DRIFT_FWD_W      = 8,     // 2^DRIFT_FWD_W bins of the forward waveform tables, 2..10
    parameter integer DRIFT_TABLE_W    = 18,    // forward table value/slope width, 8..24
    parameter integer DRIFT_TABLE_FRAC = 4,     // fraction bits of the forward tables and W0_S/W0_C, 0..12
    parameter integer DRIFT_KG_W       = 18,    // KG_S/KG_C width, 8..24
    parameter integer DRIFT_KG_SHIFT   = 40,    // right shift of the gain-loop product, 1..60
    parameter integer CANCEL           = 0,     // 1 = fringe_canceller between the quadrature and the CORDIC (docs/blocks/fringe_canceller.md)
    parameter integer CANCEL_LUT_W     = 10,    // 2^CANCEL_LUT_W entries of the canceller's sine table, 4..12
    parameter integer CANCEL_C_W       = 16,    // canceller sine table value width, 8..18
    parameter integer CANCEL_BLOCK_LOG2 = 4,    // samples per canceller update = 2^CANCEL_BLOCK_LOG2, 4..12
    parameter integer CANCEL_MU_LOG2   = 6,     // final canceller step 2^-CANCEL_MU_LOG2 per block, 1..12
    parameter integer CANCEL_A_FRAC    = 4,     // fraction bits of the canceller coefficients, 0..12
    parameter integer CANCEL_A_W       = 20,    // canceller coefficient width, 8..min(32, WAVE_W + CANCEL_A_FRAC)
    // initial contents: $readmemh images, "" = zeros
    parameter         REGS_INIT        = "",    // $readmemh image of the registers, 2 x 32 words of 32 bits
    parameter         WAVE_SIN_INIT    = "",    // $readmemh image of the sine table, both banks
    parameter         WAVE_COS_INIT    = "",    // $readmemh image of the cosine table, both banks
    parameter         LP_INIT          = "",    // $readmemh image of the long-period table, both banks
    parameter         MAP_INIT         = "",    // $readmemh image of the trim map, both banks (TRIM = 1)
    parameter         SPEED_INIT       = "",    // $readmemh image of the trim speed table, both banks (TRIM = 1)
    parameter         AMP_INIT         = "",    // $readmemh image of the trim magnitude table, both banks (TRIM = 1)
    parameter         FWD_SIN_INIT     = "",    // $readmemh image of the drift sine forward table, both banks (DRIFT = 1)
    parameter         FWD_COS_INIT     = "",    // $readmemh image of the drift cosine forward table, both banks (DRIFT = 1)
    parameter         CANCEL_LUT_INIT  = ""     // $readmemh image of the canceller's sine table (CANCEL = 1; canceller.sine_table)
    // END generated parameters
) (
    input  wire                clk,
    input  wire                rst,            // synchronous, active high
    // AXI4-Stream samples in
    // S_DATA_W = 2*ADC_LANE + COARSE_LANE bits
    input  wire [2*(8*((ADC_W+7)/8)) + 8*((COARSE_W+7)/8) - 1:0] s_axis_tdata,
    input  wire                s_axis_tvalid,
    output wire                s_axis_tready,
    // AXI4-Stream positions out
    // M_DATA_W = POS_LANE + 8 bits
    output wire [8*(($clog2(LINES)+FINE_W+7)/8) + 8 - 1:0] m_axis_tdata,
    output wire                m_axis_tvalid,
    input  wire                m_axis_tready,
    // configuration write port (fringe_core)
    input  wire                cfg_wr_en,
    input  wire [19:0]         cfg_wr_addr,
    input  wire [63:0]         cfg_wr_data,
    output wire                active_bank
);

    `include "fringe_pkg.vh"

    // The documented latency (fringe.fixed.core.core_latency); read by the testbench, not by the logic.
    /* verilator lint_off UNUSEDPARAM */
    localparam integer LATENCY = fringe_core_latency(CORDIC_STAGES, TRIM, DRIFT, CANCEL);
    // Clock enables from one sample to the next at full speed (fringe.fixed.config clocks_per_sample).
    localparam integer CLOCKS_PER_SAMPLE = 1 + COMPACT * (CORDIC_STAGES + CORDIC_ITER_CLOCKS_BASE - 1);  // COMPACT: 0 or 1
    /* verilator lint_on UNUSEDPARAM */
    localparam integer CW          = (COARSE_W > 0) ? COARSE_W : 1;  // coarse port width of the core
    localparam integer POS_W       = $clog2(LINES) + FINE_W;         // position bits
    localparam integer ADC_LANE    = 8 * ((ADC_W + 7) / 8);          // bits of the sin and cos lanes
    localparam integer POS_LANE    = 8 * ((POS_W + 7) / 8);          // bits of the position lane

    wire ce = !m_axis_tvalid || m_axis_tready;
    wire in_ready;
    assign s_axis_tready = ce && in_ready;

    wire [CW-1:0] coarse;

    generate
        if (COARSE_W > 0) begin : g_coarse
            assign coarse = s_axis_tdata[2*ADC_LANE +: COARSE_W];
        end else begin : g_no_coarse
            assign coarse = 1'b0;
        end
    endgenerate

    wire [POS_W-1:0] pos;
    wire [7:0]       status;

    fringe_core #(
        // BEGIN generated core map (written by python sim/hdlgen.py; do not edit)
        .ADC_W(ADC_W), .LINES(LINES), .COARSE_W(COARSE_W), .WAVE_ADDR_W(WAVE_ADDR_W), .WAVE_W(WAVE_W),
        .COEF_W(COEF_W), .FINE_W(FINE_W), .CORDIC_STAGES(CORDIC_STAGES), .CORDIC_GUARD(CORDIC_GUARD),
        .COMPACT(COMPACT), .LP_ADDR_W(LP_ADDR_W), .LP_W(LP_W), .LP_FRAC(LP_FRAC), .LP_IF(LP_IF),
        .LP_RECIP(LP_RECIP), .LP_SHIFT(LP_SHIFT), .TRIM(TRIM), .SPEED_LOG2(SPEED_LOG2), .MAP_PSI_W(MAP_PSI_W),
        .MAP_PHI_W(MAP_PHI_W), .TRIM_W(TRIM_W), .TRIM_FRAC(TRIM_FRAC), .G_SHIFT(G_SHIFT),
        .SECT_RECIP(SECT_RECIP), .SECT_SHIFT(SECT_SHIFT), .DRIFT(DRIFT), .DRIFT_BLOCK_LOG2(DRIFT_BLOCK_LOG2),
        .DRIFT_MU_LOG2(DRIFT_MU_LOG2), .DRIFT_OFS_FRAC(DRIFT_OFS_FRAC), .DRIFT_GINV_W(DRIFT_GINV_W),
        .DRIFT_FWD_W(DRIFT_FWD_W), .DRIFT_TABLE_W(DRIFT_TABLE_W), .DRIFT_TABLE_FRAC(DRIFT_TABLE_FRAC),
        .DRIFT_KG_W(DRIFT_KG_W), .DRIFT_KG_SHIFT(DRIFT_KG_SHIFT), .CANCEL(CANCEL), .CANCEL_LUT_W(CANCEL_LUT_W),
        .CANCEL_C_W(CANCEL_C_W), .CANCEL_BLOCK_LOG2(CANCEL_BLOCK_LOG2), .CANCEL_MU_LOG2(CANCEL_MU_LOG2),
        .CANCEL_A_FRAC(CANCEL_A_FRAC), .CANCEL_A_W(CANCEL_A_W), .REGS_INIT(REGS_INIT),
        .WAVE_SIN_INIT(WAVE_SIN_INIT), .WAVE_COS_INIT(WAVE_COS_INIT), .LP_INIT(LP_INIT), .MAP_INIT(MAP_INIT),
        .SPEED_INIT(SPEED_INIT), .AMP_INIT(AMP_INIT), .FWD_SIN_INIT(FWD_SIN_INIT), .FWD_COS_INIT(FWD_COS_INIT),
        .CANCEL_LUT_INIT(CANCEL_LUT_INIT)
        // END generated core map
    ) u_core (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(s_axis_tvalid), .in_ready(in_ready),
        .sin(s_axis_tdata[ADC_W-1:0]),
        .cos(s_axis_tdata[ADC_LANE +: ADC_W]),
        .coarse(coarse),
        .out_valid(m_axis_tvalid), .pos(pos), .status(status),
        .cfg_wr_en(cfg_wr_en), .cfg_wr_addr(cfg_wr_addr), .cfg_wr_data(cfg_wr_data),
        .active_bank(active_bank)
    );

    generate
        if (POS_LANE > POS_W) begin : g_pos_pad
            assign m_axis_tdata = {status, {(POS_LANE - POS_W){1'b0}}, pos};
        end else begin : g_pos_full
            assign m_axis_tdata = {status, pos};
        end
    endgenerate

    // The padding bits of the input lanes carry nothing.
    wire unused_ok = &{1'b0, s_axis_tdata};

endmodule

`default_nettype wire
