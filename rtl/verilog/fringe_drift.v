// fringe_drift: online offset / gain tracker for drifting sin/cos signals: the composition of
// fringe_drift_normaliser (at the front of the core) and fringe_drift_observer (of each sample's fine
// phase), which hand each other the state and the block's update.
//
// NORM_LATENCY = 4 clock enables (in_valid to norm_valid); OBS_LATENCY = 16 (a
// block's last observer sample to its resolved update), one sample per clock; HOLD = 1: in_ready = 0
// holds the sample at a block boundary until the block's update is resolved; ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_drift.md.
// Bit-exact model: model/fringe/fixed/drift.py.

`default_nettype none

module fringe_drift #(
    parameter integer ADC_W        = 14,   // ADC code width, 4..24
    parameter integer FINE_W       = 16,   // fine phase bits per period, 8..30
    parameter integer BLOCK_LOG2   = 8,    // B = 2^BLOCK_LOG2 samples per update block, 4..12
    parameter integer MU_LOG2      = 3,    // final step 2^-MU_LOG2 (gear shift from 1), 0..8
    parameter integer OFS_FRAC     = 4,    // fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
    parameter integer GINV_W       = 18,   // GINV width (GINV_W - 2 fraction bits), 8..24
    parameter integer FWD_W        = 6,    // 2^FWD_W bins per period in the forward tables, 2..min(10, FINE_W-1)
    parameter integer TABLE_W      = 18,   // forward table value and slope width, 8..24
    parameter integer TABLE_FRAC   = 2,    // fraction bits of the table values and of W0 (ADC codes), 0..12
    parameter integer KG_W         = 18,   // KG width (unsigned), 8..24
    parameter integer KG_SHIFT     = 40,   // right shift of SEA * KG, 1..60
    parameter integer PIPE_LATENCY = 0,    // clock enables from the norm outputs to the obs inputs in the core, >= 0
    parameter integer HOLD         = 1,    // 1: updates apply at the block boundary (in_ready holds); 0: B/2 later
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
    output wire                              in_ready,   // HOLD = 1: 0 while a block boundary waits for its update
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
    localparam integer D        = (HOLD != 0) ? 0 : 1 << (BLOCK_LOG2 - 1);   // application delay
    localparam integer TOTAL    = NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY;

    // ---- parameter checks ---------------------------------------------------------------------------
    generate
        `FRINGE_CHECK_DRIFT_STATE("fringe_drift")
        `FRINGE_CHECK_DRIFT_OBSERVER("fringe_drift")
        if (PIPE_LATENCY < 0) begin : g_bad_pipe
            $error("fringe_drift: PIPE_LATENCY = %0d must be >= 0 (instance %m)", PIPE_LATENCY);
        end else if (HOLD == 0 && TOTAL > D + 1) begin : g_late
            $error("fringe_drift: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = %0d + %0d + %0d = %0d exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = %0d: the update would come too late (instance %m)",
                   NORM_LATENCY, PIPE_LATENCY, OBS_LATENCY, TOTAL, D + 1);
        end
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_drift", "USER_W", USER_W, 1)
    endgenerate

    // ---- the two halves ------------------------------------------------------------------------------
    localparam integer OW = ADC_W + OFS_FRAC;   // OFF
    wire                  upd_valid, upd_sat, upd_resolved, upd_take;
    wire signed [OW-1:0]  upd_off_s, upd_off_c;
    wire [GINV_W-1:0]     upd_ginv_s, upd_ginv_c;

    fringe_drift_normaliser #(
        .ADC_W(ADC_W), .BLOCK_LOG2(BLOCK_LOG2), .OFS_FRAC(OFS_FRAC), .GINV_W(GINV_W), .HOLD(HOLD), .USER_W(USER_W)
    ) u_norm (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(in_valid), .raw_sin(raw_sin), .raw_cos(raw_cos), .in_user(in_user), .in_ready(in_ready),
        .norm_valid(norm_valid), .y_sin(y_sin), .y_cos(y_cos), .norm_sat(norm_sat), .norm_user(norm_user),
        .upd_valid(upd_valid), .upd_off_sin(upd_off_s), .upd_off_cos(upd_off_c), .upd_ginv_sin(upd_ginv_s),
        .upd_ginv_cos(upd_ginv_c), .upd_sat(upd_sat), .upd_resolved(upd_resolved), .upd_take(upd_take),
        .off_sin(off_sin), .off_cos(off_cos), .ginv_sin(ginv_sin), .ginv_cos(ginv_cos), .track_sat(track_sat)
    );

    fringe_drift_observer #(
        .ADC_W(ADC_W), .FINE_W(FINE_W), .BLOCK_LOG2(BLOCK_LOG2), .MU_LOG2(MU_LOG2), .OFS_FRAC(OFS_FRAC),
        .GINV_W(GINV_W), .FWD_W(FWD_W), .TABLE_W(TABLE_W), .TABLE_FRAC(TABLE_FRAC), .KG_W(KG_W),
        .KG_SHIFT(KG_SHIFT), .HOLD(HOLD), .FWD_SIN_INIT(FWD_SIN_INIT), .FWD_COS_INIT(FWD_COS_INIT)
    ) u_obs (
        .clk(clk), .rst(rst), .ce(ce),
        .obs_valid(obs_valid), .obs_phase(obs_phase), .obs_y_sin(obs_y_sin), .obs_y_cos(obs_y_cos),
        .obs_bank(obs_bank), .w0_sin(w0_sin), .w0_cos(w0_cos), .kg_sin(kg_sin), .kg_cos(kg_cos),
        .wr_en(wr_en), .wr_sel(wr_sel), .wr_addr(wr_addr), .wr_data(wr_data),
        .off_sin(off_sin), .off_cos(off_cos), .ginv_sin(ginv_sin), .ginv_cos(ginv_cos),
        .upd_valid(upd_valid), .upd_off_sin(upd_off_s), .upd_off_cos(upd_off_c), .upd_ginv_sin(upd_ginv_s),
        .upd_ginv_cos(upd_ginv_c), .upd_sat(upd_sat), .upd_resolved(upd_resolved), .upd_take(upd_take)
    );

endmodule

`default_nettype wire
