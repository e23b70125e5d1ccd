// fringe_drift_normaliser: the front half of the drift tracker (docs/drift.md): offsets and gains of the
// raw sin/cos codes removed with the tracker's state, which it holds and replaces at block boundaries
// with the update fringe_drift_observer resolves.
//
// LATENCY = 5 clock enables (in_valid to norm_valid), one sample per clock; HOLD = 1: in_ready = 0
// holds the sample at a block boundary until the observer has resolved the block's update; ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_drift_normaliser.md.
// Bit-exact model: model/fringe/fixed/drift_normaliser.py.

`default_nettype none

module fringe_drift_normaliser #(
    parameter integer ADC_W      = 14,   // ADC code width, 4..24
    parameter integer BLOCK_LOG2 = 8,    // B = 2^BLOCK_LOG2 samples per update block, 4..12
    parameter integer OFS_FRAC   = 4,    // fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
    parameter integer GINV_W     = 18,   // GINV width (GINV_W - 2 fraction bits), 8..24
    parameter integer HOLD       = 1,    // 1: updates apply at the block boundary (in_ready holds); 0: B/2 later
    parameter integer USER_W     = 1     // sideband width, >= 1
) (
    input  wire                              clk,
    input  wire                              rst,        // synchronous, active high
    input  wire                              ce,         // clock enable
    // in
    input  wire                              in_valid,
    input  wire signed [ADC_W-1:0]           raw_sin,    // s(ADC_W)
    input  wire signed [ADC_W-1:0]           raw_cos,
    input  wire [USER_W-1:0]                 in_user,
    output wire                              in_ready,   // HOLD = 1: 0 while a block boundary waits for its update
    // out
    output wire                              norm_valid,
    output reg  signed [ADC_W-1:0]           y_sin,      // s(ADC_W)
    output reg  signed [ADC_W-1:0]           y_cos,
    output reg                               norm_sat,   // y saturated (either channel)
    output wire [USER_W-1:0]                 norm_user,
    // the update (from fringe_drift_observer)
    input  wire                              upd_valid,     // an update is pending
    input  wire signed [ADC_W+OFS_FRAC-1:0]  upd_off_sin,   // its state
    input  wire signed [ADC_W+OFS_FRAC-1:0]  upd_off_cos,
    input  wire [GINV_W-1:0]                 upd_ginv_sin,
    input  wire [GINV_W-1:0]                 upd_ginv_cos,
    input  wire                              upd_sat,
    input  wire                              upd_resolved,  // the last complete block's update is known
    output wire                              upd_take,      // the application sample is accepted (this clock enable)
    // tracker state
    output reg  signed [ADC_W+OFS_FRAC-1:0]  off_sin,    // OFF, s(ADC_W + OFS_FRAC)
    output reg  signed [ADC_W+OFS_FRAC-1:0]  off_cos,
    output reg  [GINV_W-1:0]                 ginv_sin,   // GINV, u(GINV_W)
    output reg  [GINV_W-1:0]                 ginv_cos,
    output reg                               track_sat   // the last applied update saturated
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY = DRIFT_NORM_LATENCY;
    localparam integer D       = (HOLD != 0) ? 0 : 1 << (BLOCK_LOG2 - 1);   // application delay

    // ---- parameter checks ---------------------------------------------------------------------------
    generate
        `FRINGE_CHECK_DRIFT_STATE("fringe_drift_normaliser")
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_drift_normaliser", "USER_W", USER_W, 1)
    endgenerate

    // ---- widths ---------------------------------------------------------------------------------------
    localparam integer OW     = ADC_W + OFS_FRAC;                     // OFF
    localparam integer SHN    = OFS_FRAC + GINV_W - 2;                // normaliser shift
    localparam integer PW     = OW + GINV_W + 2;                      // (raw * 2^OFS_FRAC - OFF) * GINV
    localparam integer QW     = PW - SHN;                             // that >>> SHN (ADC_W + 4)
    localparam [GINV_W-1:0] UNITY = {{(GINV_W-2){1'b0}}, 2'b01} << (GINV_W - 2);
    localparam [BLOCK_LOG2-1:0] CNT_D    = D[BLOCK_LOG2-1:0];
    localparam [BLOCK_LOG2-1:0] CNT_LAST = {BLOCK_LOG2{1'b1}};
    localparam [BLOCK_LOG2-1:0] CNT_DM1  = CNT_D - 1'b1;   // (mod B)

    // ---- application of the pending update --------------------------------------------------------------
    wire                   in_take = in_valid & in_ready;
    wire                   acc_n = ce & in_take & ~rst;
    reg  [BLOCK_LOG2-1:0]  ncnt;          // accepted input samples since reset, mod B
    reg                    npast;         // at least B accepted since reset
    // the next sample is an application sample: npast & (ncnt == CNT_D), registered with them (no compare
    // between ncnt and the enables of the state registers)
    reg                    at_apply;
    wire                   take = at_apply & upd_valid;   // (with acc_n) the state becomes the pending update

    // HOLD = 1: the boundary sample waits until its block's update is resolved (at most one block is
    // outstanding: the next one needs samples past this boundary). HOLD = 0: never waits (the latency check).
    assign in_ready = (HOLD == 0) | ~at_apply | upd_resolved;
    assign upd_take = acc_n & at_apply;

    always @(posedge clk) begin
        if (rst) begin
            ncnt      <= {BLOCK_LOG2{1'b0}};
            npast     <= 1'b0;
            at_apply  <= 1'b0;
            off_sin   <= {OW{1'b0}};
            off_cos   <= {OW{1'b0}};
            ginv_sin  <= UNITY;
            ginv_cos  <= UNITY;
            track_sat <= 1'b0;
        end else if (acc_n) begin
            ncnt <= ncnt + 1'b1;
            if (ncnt == CNT_LAST) begin
                npast <= 1'b1;
            end
            at_apply <= (npast | (ncnt == CNT_LAST)) & (ncnt == CNT_DM1);
            if (take) begin
                off_sin   <= upd_off_sin;
                off_cos   <= upd_off_cos;
                ginv_sin  <= upd_ginv_sin;
                ginv_cos  <= upd_ginv_cos;
                track_sat <= upd_sat;
            end
        end
    end

    // ---- normaliser ------------------------------------------------------------------------------------
    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY)) u_norm_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_take), .in_data(in_user),
        .out_valid(norm_valid), .out_data(norm_user)
    );

    reg  signed [ADC_W-1:0] n1_s, n1_c;
    reg  signed [OW:0]      n2_s, n2_c;
    reg         [GINV_W-1:0] n2_gs, n2_gc;
`ifdef FRINGE_TECH_ECP5
    // ECP5: d * GINV registered in the MULT18X18D's output register when OW + 1, GINV_W <= 18
    wire signed [PW-1:0]    n3_s, n3_c;
    generate
        if (OW + 1 <= 18 && GINV_W <= 18) begin : g_n3_dsp
            wire [OW+GINV_W:0] m3_s, m3_c;
            fringe_mul_ecp5 #(.A_W(OW + 1), .B_W(GINV_W), .B_SIGNED(0)) u_n3_s (
                .clk(clk), .ce(ce), .a(n2_s), .b(n2_gs), .p(m3_s));
            fringe_mul_ecp5 #(.A_W(OW + 1), .B_W(GINV_W), .B_SIGNED(0)) u_n3_c (
                .clk(clk), .ce(ce), .a(n2_c), .b(n2_gc), .p(m3_c));
            assign n3_s = {{(PW-OW-GINV_W-1){m3_s[OW+GINV_W]}}, m3_s};
            assign n3_c = {{(PW-OW-GINV_W-1){m3_c[OW+GINV_W]}}, m3_c};
        end else begin : g_n3
            reg signed [PW-1:0] r3_s, r3_c;
            always @(posedge clk) begin
                if (ce) begin
                    r3_s <= n2_s * $signed({1'b0, n2_gs});
                    r3_c <= n2_c * $signed({1'b0, n2_gc});
                end
            end
            assign n3_s = r3_s;
            assign n3_c = r3_c;
        end
    endgenerate
`else
    reg  signed [PW-1:0]    n3_s, n3_c;
`endif
    // the product's bits from the rounding bit up, registered once more in the fabric: the multiplier's
    // output register (on ECP5 inside the DSP) feeds only this register, the rounding adder and the
    // saturation are a stage of their own (5)
    reg  signed [QW:0]      n4_s, n4_c;
    wire signed [OW:0]      n1_sx = {{(OFS_FRAC+1){n1_s[ADC_W-1]}}, n1_s} <<< OFS_FRAC;
    wire signed [OW:0]      n1_cx = {{(OFS_FRAC+1){n1_c[ADC_W-1]}}, n1_c} <<< OFS_FRAC;
    // (P + 2^(SHN-1)) >>> SHN = (P >>> SHN) + P[SHN-1]
    wire signed [QW-1:0]    q_s = n4_s[QW:1] + {{(QW-1){1'b0}}, n4_s[0]};
    wire signed [QW-1:0]    q_c = n4_c[QW:1] + {{(QW-1){1'b0}}, n4_c[0]};
    // in range of s(ADC_W) <=> bits QW-1 .. ADC_W-1 all equal the sign
    wire                    qs_over = `FRINGE_OUTSIDE(q_s, QW, ADC_W);
    wire                    qc_over = `FRINGE_OUTSIDE(q_c, QW, ADC_W);

    always @(posedge clk) begin
        if (ce) begin
            // 1: input registers (a held sample is not taken: norm_valid stays 0)
            n1_s <= raw_sin;
            n1_c <= raw_cos;
            // 2: d = raw * 2^OFS_FRAC - OFF (the state after this sample's acceptance)
            n2_s  <= n1_sx - {off_sin[OW-1], off_sin};
            n2_c  <= n1_cx - {off_cos[OW-1], off_cos};
            n2_gs <= ginv_sin;
            n2_gc <= ginv_cos;
            // 3: d * GINV
`ifndef FRINGE_TECH_ECP5
            n3_s <= n2_s * $signed({1'b0, n2_gs});
            n3_c <= n2_c * $signed({1'b0, n2_gc});
`endif
            // 4: P[PW-1:SHN-1] registered (P >>> SHN and the rounding bit)
            n4_s <= n3_s[PW-1:SHN-1];
            n4_c <= n3_c[PW-1:SHN-1];
            // 5: rounded (P[SHN-1] as a carry), >>> SHN, saturate
            y_sin    <= `FRINGE_SATURATE(q_s, QW, ADC_W);
            y_cos    <= `FRINGE_SATURATE(q_c, QW, ADC_W);
            norm_sat <= qs_over | qc_over;
        end
    end

    // the rounded-off bits of the products
    wire unused = &{1'b0, n3_s[SHN-2:0], n3_c[SHN-2:0]};

endmodule

`default_nettype wire
