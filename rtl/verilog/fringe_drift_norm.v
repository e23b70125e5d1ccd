// fringe_drift_norm: fringe_drift's normaliser, y = sat(((raw * 2^OFS_FRAC - OFF) * GINV) >>> SHN), and
// the application of the observer's pending update to OFF and GINV at the block's application sample.
//
// Part of the fringe_drift block (its contract: docs/blocks/fringe_drift.md; its parameter checks are
// fringe_drift's); NORM_LATENCY = 4 clock enables, one sample per clock; ce = 0 freezes every register,
// rst clears the valid pipeline and the state (counters, OFF, GINV), never the data registers.
// Bit-exact model: model/fringe/fixed/drift.py.

`default_nettype none

module fringe_drift_norm #(
    parameter integer ADC_W      = 14,   // ADC code width
    parameter integer BLOCK_LOG2 = 8,    // B = 2^BLOCK_LOG2 samples per update block
    parameter integer OFS_FRAC   = 4,    // fraction bits of OFF
    parameter integer GINV_W     = 18,   // GINV width (GINV_W - 2 fraction bits)
    parameter integer USER_W     = 1     // sideband width
) (
    input  wire                              clk,
    input  wire                              rst,        // synchronous, active high
    input  wire                              ce,         // clock enable
    // sample in
    input  wire                              in_valid,
    input  wire signed [ADC_W-1:0]           raw_sin,    // s(ADC_W)
    input  wire signed [ADC_W-1:0]           raw_cos,
    input  wire [USER_W-1:0]                 in_user,
    // sample out
    output wire                              norm_valid,
    output reg  signed [ADC_W-1:0]           y_sin,      // s(ADC_W)
    output reg  signed [ADC_W-1:0]           y_cos,
    output reg                               norm_sat,   // y saturated (either channel)
    output wire [USER_W-1:0]                 norm_user,
    // the observer's pending update; take: applied at this clock enable
    input  wire                              pend_valid,
    input  wire signed [ADC_W+OFS_FRAC-1:0]  pend_off_s,
    input  wire signed [ADC_W+OFS_FRAC-1:0]  pend_off_c,
    input  wire [GINV_W-1:0]                 pend_ginv_s,
    input  wire [GINV_W-1:0]                 pend_ginv_c,
    input  wire                              pend_sat,
    output wire                              take,
    // tracker state
    output reg  signed [ADC_W+OFS_FRAC-1:0]  off_sin,    // OFF, s(ADC_W + OFS_FRAC)
    output reg  signed [ADC_W+OFS_FRAC-1:0]  off_cos,
    output reg  [GINV_W-1:0]                 ginv_sin,   // GINV, u(GINV_W)
    output reg  [GINV_W-1:0]                 ginv_cos,
    output reg                               track_sat   // the last applied update saturated
);

    `include "fringe_pkg.vh"

    localparam integer NORM_LATENCY = DRIFT_NORM_LATENCY;
    localparam integer D      = 1 << (BLOCK_LOG2 - 1);
    localparam integer OW     = ADC_W + OFS_FRAC;                     // OFF
    localparam integer SHN    = OFS_FRAC + GINV_W - 2;                // normaliser shift
    localparam integer PW     = OW + GINV_W + 2;                      // (raw * 2^OFS_FRAC - OFF) * GINV
    localparam integer QW     = PW - SHN;                             // that >>> SHN (ADC_W + 4)
    localparam [GINV_W-1:0] UNITY = {{(GINV_W-2){1'b0}}, 2'b01} << (GINV_W - 2);
    localparam [BLOCK_LOG2-1:0] CNT_D    = D[BLOCK_LOG2-1:0];
    localparam [BLOCK_LOG2-1:0] CNT_LAST = {BLOCK_LOG2{1'b1}};

    // ---- application of the pending update ------------------------------------------------------------
    wire                   acc_n = ce & in_valid & ~rst;
    reg  [BLOCK_LOG2-1:0]  ncnt;          // accepted input samples since reset, mod B
    reg                    npast;         // at least B accepted since reset

    assign take = acc_n & npast & (ncnt == CNT_D) & pend_valid;

    always @(posedge clk) begin
        if (rst) begin
            ncnt      <= {BLOCK_LOG2{1'b0}};
            npast     <= 1'b0;
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
            if (take) begin
                off_sin   <= pend_off_s;
                off_cos   <= pend_off_c;
                ginv_sin  <= pend_ginv_s;
                ginv_cos  <= pend_ginv_c;
                track_sat <= pend_sat;
            end
        end
    end

    // ---- normaliser ------------------------------------------------------------------------------------
    fringe_delay #(.WIDTH(USER_W), .DEPTH(NORM_LATENCY)) u_norm_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(norm_valid), .out_data(norm_user)
    );

    reg  signed [ADC_W-1:0] n1_s, n1_c;
    reg  signed [OW:0]      n2_s, n2_c;
    reg         [GINV_W-1:0] n2_gs, n2_gc;
    reg  signed [PW-1:0]    n3_s, n3_c;
    wire signed [OW:0]      n1_sx = {{(OFS_FRAC+1){n1_s[ADC_W-1]}}, n1_s} <<< OFS_FRAC;
    wire signed [OW:0]      n1_cx = {{(OFS_FRAC+1){n1_c[ADC_W-1]}}, n1_c} <<< OFS_FRAC;
    // (P + 2^(SHN-1)) >>> SHN = (P >>> SHN) + P[SHN-1]
    wire signed [QW-1:0]    q_s = n3_s[PW-1:SHN] + {{(QW-1){1'b0}}, n3_s[SHN-1]};
    wire signed [QW-1:0]    q_c = n3_c[PW-1:SHN] + {{(QW-1){1'b0}}, n3_c[SHN-1]};
    // in range of s(ADC_W) <=> bits QW-1 .. ADC_W-1 all equal the sign
    wire                    qs_over = q_s[QW-1] ? ~&q_s[QW-1:ADC_W-1] : |q_s[QW-1:ADC_W-1];
    wire                    qc_over = q_c[QW-1] ? ~&q_c[QW-1:ADC_W-1] : |q_c[QW-1:ADC_W-1];
    wire signed [ADC_W-1:0] y_max = {1'b0, {(ADC_W-1){1'b1}}};
    wire signed [ADC_W-1:0] y_min = {1'b1, {(ADC_W-1){1'b0}}};

    always @(posedge clk) begin
        if (ce) begin
            // 1: input registers
            n1_s <= raw_sin;
            n1_c <= raw_cos;
            // 2: d = raw * 2^OFS_FRAC - OFF (the state after this sample's acceptance)
            n2_s  <= n1_sx - {off_sin[OW-1], off_sin};
            n2_c  <= n1_cx - {off_cos[OW-1], off_cos};
            n2_gs <= ginv_sin;
            n2_gc <= ginv_cos;
            // 3: d * GINV
            n3_s <= n2_s * $signed({1'b0, n2_gs});
            n3_c <= n2_c * $signed({1'b0, n2_gc});
            // 4: rounded (P[SHN-1] as a carry), >>> SHN, saturate
            y_sin    <= qs_over ? (q_s[QW-1] ? y_min : y_max) : q_s[ADC_W-1:0];
            y_cos    <= qc_over ? (q_c[QW-1] ? y_min : y_max) : q_c[ADC_W-1:0];
            norm_sat <= qs_over | qc_over;
        end
    end

    // Bits that carry nothing: the rounded-off bits of the products.
    wire unused = &{1'b0, n3_s[SHN-1:0], n3_c[SHN-1:0]};

endmodule

`default_nettype wire
