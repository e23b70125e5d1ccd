// fringe_drift: online offset / gain tracker for drifting sin/cos signals: a normaliser at
// the front of the core and an observer of each sample's fine phase.
//
// NORM_LATENCY = 4 clock enables (in_valid to norm_valid); OBS_LATENCY = 15 (a
// block's last observer sample to its pending update), one sample per clock; ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// The two halves are fringe_drift_norm (normaliser, application of the pending update) and
// fringe_drift_obs (observer, update), one module each; this one checks the parameters and joins them.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_drift.md.
// Bit-exact model: model/fringe/fixed/drift.py.

`default_nettype none

module fringe_drift #(
    parameter integer ADC_W        = 14,   // ADC code width, 4..24
    parameter integer FINE_W       = 16,   // fine phase bits per period, 8..30
    parameter integer BLOCK_LOG2   = 8,    // B = 2^BLOCK_LOG2 samples per update block, 4..12
    parameter integer MU_LOG2      = 3,    // offset step 2^-MU_LOG2 of the mean error, 0..8
    parameter integer OFS_FRAC     = 4,    // fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
    parameter integer GINV_W       = 18,   // GINV width (GINV_W - 2 fraction bits), 8..24
    parameter integer FWD_W        = 6,    // 2^FWD_W bins per period in the forward tables, 2..min(10, FINE_W-1)
    parameter integer TABLE_W      = 18,   // forward table value and slope width, 8..24
    parameter integer TABLE_FRAC   = 2,    // fraction bits of the table values and of W0 (ADC codes), 0..12
    parameter integer KG_W         = 18,   // KG width (unsigned), 8..24
    parameter integer KG_SHIFT     = 40,   // right shift of SEA * KG, 1..60
    parameter integer PIPE_LATENCY = 0,    // clock enables from the norm outputs to the obs inputs in the core, >= 0
    parameter         FWD_SIN_INIT = "",   // $readmemh image of the sine table, 2 banks x 2^FWD_W words; "" = zeros
    parameter         FWD_COS_INIT = "",   // $readmemh image of the cosine table, 2 banks x 2^FWD_W words; "" = zeros
    parameter integer USER_W       = 1     // normaliser sideband width, >= 1
) (
    input  wire                              clk,
    input  wire                              rst,        // synchronous, active high
    input  wire                              ce,         // clock enable
    // normaliser in
    input  wire                              in_valid,
    input  wire signed [ADC_W-1:0]           raw_sin,    // s(ADC_W)
    input  wire signed [ADC_W-1:0]           raw_cos,
    input  wire [USER_W-1:0]                 in_user,
    // normaliser out
    output wire                              norm_valid,
    output wire signed [ADC_W-1:0]           y_sin,      // s(ADC_W)
    output wire signed [ADC_W-1:0]           y_cos,
    output wire                              norm_sat,   // y saturated (either channel)
    output wire [USER_W-1:0]                 norm_user,
    // observer in
    input  wire                              obs_valid,
    input  wire [FINE_W-1:0]                 obs_phase,  // u(FINE_W)
    input  wire signed [ADC_W-1:0]           obs_y_sin,  // the same sample's normalised codes
    input  wire signed [ADC_W-1:0]           obs_y_cos,
    input  wire                              obs_bank,   // table (and W0, KG) bank of this sample
    input  wire signed [ADC_W+TABLE_FRAC-1:0] w0_sin,    // W0 of this sample's bank, s(ADC_W + TABLE_FRAC)
    input  wire signed [ADC_W+TABLE_FRAC-1:0] w0_cos,
    input  wire [KG_W-1:0]                   kg_sin,     // KG of this sample's bank (taken with a block's last sample)
    input  wire [KG_W-1:0]                   kg_cos,
    // table write port (software side), independent of ce
    input  wire                              wr_en,
    input  wire                              wr_sel,     // 0 sine table, 1 cosine table
    input  wire [FWD_W:0]                    wr_addr,    // {bank, bin}
    input  wire [2*TABLE_W-1:0]              wr_data,    // {slope, value}
    // tracker state
    output wire signed [ADC_W+OFS_FRAC-1:0]  off_sin,    // OFF, s(ADC_W + OFS_FRAC)
    output wire signed [ADC_W+OFS_FRAC-1:0]  off_cos,
    output wire [GINV_W-1:0]                 ginv_sin,   // GINV, u(GINV_W)
    output wire [GINV_W-1:0]                 ginv_cos,
    output wire                              track_sat   // the last applied update saturated
);

    `include "fringe_pkg.vh"

    localparam integer NORM_LATENCY = DRIFT_NORM_LATENCY;
    localparam integer OBS_LATENCY  = DRIFT_OBS_LATENCY;
    localparam integer D        = 1 << (BLOCK_LOG2 - 1);
    localparam integer FWD_MAX  = (FINE_W - 1 < 10) ? FINE_W - 1 : 10;
    localparam integer TOTAL    = NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY;

    // ---- parameter checks ---------------------------------------------------------------------------
    generate
        `FRINGE_CHECK_RANGE(g_bad_adc_w, "fringe_drift", "ADC_W", ADC_W, 4, 24)
        `FRINGE_CHECK_RANGE(g_bad_fine_w, "fringe_drift", "FINE_W", FINE_W, 8, 30)
        `FRINGE_CHECK_RANGE(g_bad_block_log2, "fringe_drift", "BLOCK_LOG2", BLOCK_LOG2, 4, 12)
        `FRINGE_CHECK_RANGE(g_bad_mu_log2, "fringe_drift", "MU_LOG2", MU_LOG2, 0, 8)
        `FRINGE_CHECK_RANGE(g_bad_ofs_frac, "fringe_drift", "OFS_FRAC", OFS_FRAC, 0, 8)
        if (ADC_W + OFS_FRAC > 32) begin : g_bad_ofs_w
            $error("fringe_drift: ADC_W + OFS_FRAC = %0d exceeds 32 (instance %m)", ADC_W + OFS_FRAC);
        end
        `FRINGE_CHECK_RANGE(g_bad_ginv_w, "fringe_drift", "GINV_W", GINV_W, 8, 24)
        if (FWD_W < 2 || FWD_W > FWD_MAX) begin : g_bad_fwd_w
            $error("fringe_drift: FWD_W = %0d out of range 2..min(10, FINE_W-1) = %0d (instance %m)", FWD_W, FWD_MAX);
        end
        `FRINGE_CHECK_RANGE(g_bad_table_w, "fringe_drift", "TABLE_W", TABLE_W, 8, 24)
        `FRINGE_CHECK_RANGE(g_bad_table_frac, "fringe_drift", "TABLE_FRAC", TABLE_FRAC, 0, 12)
        `FRINGE_CHECK_RANGE(g_bad_kg_w, "fringe_drift", "KG_W", KG_W, 8, 24)
        `FRINGE_CHECK_RANGE(g_bad_kg_shift, "fringe_drift", "KG_SHIFT", KG_SHIFT, 1, 60)
        if (PIPE_LATENCY < 0) begin : g_bad_pipe
            $error("fringe_drift: PIPE_LATENCY = %0d must be >= 0 (instance %m)", PIPE_LATENCY);
        end else if (TOTAL > D + 1) begin : g_late
            $error("fringe_drift: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = %0d + %0d + %0d = %0d exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = %0d: the update would come too late (instance %m)",
                   NORM_LATENCY, PIPE_LATENCY, OBS_LATENCY, TOTAL, D + 1);
        end
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_drift", "USER_W", USER_W, 1)
    endgenerate

    // ---- the normaliser (fringe_drift_norm) and the observer (fringe_drift_obs) -----------------------
    localparam integer OW = ADC_W + OFS_FRAC;                         // OFF
    wire                 pend_valid, pend_sat, take;
    wire signed [OW-1:0] pend_off_s, pend_off_c;
    wire [GINV_W-1:0]    pend_ginv_s, pend_ginv_c;

    fringe_drift_norm #(
        .ADC_W(ADC_W), .BLOCK_LOG2(BLOCK_LOG2), .OFS_FRAC(OFS_FRAC), .GINV_W(GINV_W), .USER_W(USER_W)
    ) u_norm (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(in_valid), .raw_sin(raw_sin), .raw_cos(raw_cos), .in_user(in_user),
        .norm_valid(norm_valid), .y_sin(y_sin), .y_cos(y_cos), .norm_sat(norm_sat), .norm_user(norm_user),
        .pend_valid(pend_valid), .pend_off_s(pend_off_s), .pend_off_c(pend_off_c),
        .pend_ginv_s(pend_ginv_s), .pend_ginv_c(pend_ginv_c), .pend_sat(pend_sat), .take(take),
        .off_sin(off_sin), .off_cos(off_cos), .ginv_sin(ginv_sin), .ginv_cos(ginv_cos), .track_sat(track_sat)
    );

    fringe_drift_obs #(
        .ADC_W(ADC_W), .FINE_W(FINE_W), .BLOCK_LOG2(BLOCK_LOG2), .MU_LOG2(MU_LOG2), .OFS_FRAC(OFS_FRAC),
        .GINV_W(GINV_W), .FWD_W(FWD_W), .TABLE_W(TABLE_W), .TABLE_FRAC(TABLE_FRAC), .KG_W(KG_W),
        .KG_SHIFT(KG_SHIFT), .FWD_SIN_INIT(FWD_SIN_INIT), .FWD_COS_INIT(FWD_COS_INIT)
    ) u_obs (
        .clk(clk), .rst(rst), .ce(ce),
        .obs_valid(obs_valid), .obs_phase(obs_phase), .obs_y_sin(obs_y_sin), .obs_y_cos(obs_y_cos),
        .obs_bank(obs_bank), .w0_sin(w0_sin), .w0_cos(w0_cos), .kg_sin(kg_sin), .kg_cos(kg_cos),
        .wr_en(wr_en), .wr_sel(wr_sel), .wr_addr(wr_addr), .wr_data(wr_data),
        .off_sin(off_sin), .off_cos(off_cos), .ginv_sin(ginv_sin), .ginv_cos(ginv_cos),
        .pend_valid(pend_valid), .pend_off_s(pend_off_s), .pend_off_c(pend_off_c),
        .pend_ginv_s(pend_ginv_s), .pend_ginv_c(pend_ginv_c), .pend_sat(pend_sat), .take(take)
    );

endmodule

`default_nettype wire
