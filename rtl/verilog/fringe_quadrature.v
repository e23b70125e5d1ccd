// fringe_quadrature: offset, gain and quadrature correction (seed 001 eq. 21, Heydemann form).
//
// LATENCY = 5 clock enables, one sample per clock (SHARED_MUL = 1: the three products k_ss*ds, k_sc*dc,
// k_cc*dc through one multiplier (two halves when the difference is split) in three clock enables, same
// words and LATENCY, samples at least SHARED_MIN_CLOCKS = 4 clock enables apart, fixed/quadrature.py); ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_quadrature.md.
// Bit-exact model: model/fringe/fixed/quadrature.py.

`default_nettype none

module fringe_quadrature #(
    parameter integer WAVE_W = 18,  // data, offset and output width, 8..32
    parameter integer COEF_W = 18,  // gain coefficient width, 8..27 (COEF_W-2 fractional bits)
    parameter integer USER_W = 1,   // sideband width, >= 1
    parameter integer SHARED_MUL = 0    // 1 = one multiplier for the three products (samples >= 4 clock enables apart)
) (
    input  wire              clk,
    input  wire              rst,        // synchronous, active high: clears valid only
    input  wire              ce,         // clock enable: the pipeline advances when 1
    // sample in
    input  wire              in_valid,
    input  wire [WAVE_W-1:0] xs,         // s(WAVE_W): sine channel after the wave LUT
    input  wire [WAVE_W-1:0] xc,         // s(WAVE_W): cosine channel after the wave LUT
    input  wire [USER_W-1:0] in_user,
    // coefficients, sampled with the sample
    input  wire [WAVE_W-1:0] ofs_s,      // s(WAVE_W): sine offset
    input  wire [WAVE_W-1:0] ofs_c,      // s(WAVE_W): cosine offset
    input  wire [COEF_W-1:0] k_ss,       // s(COEF_W): sine gain (1/cos a)
    input  wire [COEF_W-1:0] k_sc,       // s(COEF_W): cosine-into-sine term (tan a)
    input  wire [COEF_W-1:0] k_cc,       // s(COEF_W): cosine gain
    // sample out
    output wire              out_valid,
    output reg  [WAVE_W-1:0] s,          // s(WAVE_W), WAVE_W-2 fractional bits
    output reg  [WAVE_W-1:0] c,          // s(WAVE_W), WAVE_W-2 fractional bits
    output reg               sat,        // s or c saturated
    output wire [USER_W-1:0] out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY   = QUADRATURE_LATENCY;
    localparam integer COEF_FRAC = COEF_W - 2;
    localparam integer D_W       = WAVE_W + 1;       // x - ofs, exact
    localparam integer P_W       = COEF_W + D_W;     // k * (x - ofs), exact
    localparam integer S_W       = P_W + 1;          // sum of two products + rounding, exact
    localparam integer L         = 17;               // low part of a split difference, unsigned
    localparam         WIDE      = D_W > 18;         // split: each partial product fits an 18x18 DSP
    localparam integer DH_W      = WIDE ? D_W - L : 1;  // high part of a split difference, signed
    localparam integer Q_W       = S_W - COEF_FRAC;  // after the shift: WAVE_W + 4
    localparam [S_W-1:0] RND     = {{(S_W-1){1'b0}}, 1'b1} << (COEF_FRAC - 1);

    generate
        if (WAVE_W < 8 || WAVE_W > 32) begin : g_bad_wave_w
            $error("fringe_quadrature: WAVE_W = %0d out of range 8..32 (instance %m)", WAVE_W);
        end
        if (COEF_W < 8 || COEF_W > 27) begin : g_bad_coef_w
            $error("fringe_quadrature: COEF_W = %0d out of range 8..27 (instance %m)", COEF_W);
        end
        if (USER_W < 1) begin : g_bad_user_w
            $error("fringe_quadrature: USER_W = %0d must be >= 1 (instance %m)", USER_W);
        end
        if (SHARED_MUL != 0 && SHARED_MUL != 1) begin : g_bad_shared
            $error("fringe_quadrature: SHARED_MUL = %0d must be 0 or 1 (instance %m)", SHARED_MUL);
        end
    endgenerate

    // ---- stage 1: differences; coefficients travel with the sample --------------------------
    reg signed [D_W-1:0]    ds1, dc1;
    reg signed [COEF_W-1:0] k_ss1, k_sc1, k_cc1;

    // (SHARED_MUL = 1 reads them until stage 4: they take only a valid sample)
    wire take1 = (SHARED_MUL == 0) || in_valid;

    always @(posedge clk) begin
        if (ce && take1) begin
            ds1   <= $signed({xs[WAVE_W-1], xs}) - $signed({ofs_s[WAVE_W-1], ofs_s});
            dc1   <= $signed({xc[WAVE_W-1], xc}) - $signed({ofs_c[WAVE_W-1], ofs_c});
            k_ss1 <= k_ss;
            k_sc1 <= k_sc;
            k_cc1 <= k_cc;
        end
    end

    // the sums the output stage shifts and saturates: k_ss*ds + k_sc*dc + RND and k_cc*dc + RND
    wire signed [S_W-1:0] sum_s, sum_c;

    generate
        if (SHARED_MUL == 0) begin : g_parallel
            // ---- stages 2, 3: products, assembled with the rounding constant -------------------
            reg signed [S_W-1:0] pss3, psc3, pcc3;   // k_ss*ds + RND, k_sc*dc, k_cc*dc + RND

            if (!WIDE) begin : g_narrow
                reg signed [P_W-1:0] pss2, psc2, pcc2;

                always @(posedge clk) begin
                    if (ce) begin
                        pss2 <= k_ss1 * ds1;
                        psc2 <= k_sc1 * dc1;
                        pcc2 <= k_cc1 * dc1;
                        pss3 <= pss2 + $signed(RND);
                        psc3 <= {{(S_W-P_W){psc2[P_W-1]}}, psc2};
                        pcc3 <= pcc2 + $signed(RND);
                    end
                end
            end else begin : g_wide
                localparam integer LO_W = COEF_W + L + 1;    // k * d_lo
                localparam integer HI_W = COEF_W + DH_W;     // k * d_hi
                wire signed [L:0]      ds_lo = {1'b0, ds1[L-1:0]};
                wire signed [L:0]      dc_lo = {1'b0, dc1[L-1:0]};
                wire signed [DH_W-1:0] ds_hi = ds1[D_W-1:L];
                wire signed [DH_W-1:0] dc_hi = dc1[D_W-1:L];
                reg  signed [LO_W-1:0] pss_lo2, psc_lo2, pcc_lo2;
                reg  signed [HI_W-1:0] pss_hi2, psc_hi2, pcc_hi2;

                always @(posedge clk) begin
                    if (ce) begin
                        pss_lo2 <= k_ss1 * ds_lo;
                        psc_lo2 <= k_sc1 * dc_lo;
                        pcc_lo2 <= k_cc1 * dc_lo;
                        pss_hi2 <= k_ss1 * ds_hi;
                        psc_hi2 <= k_sc1 * dc_hi;
                        pcc_hi2 <= k_cc1 * dc_hi;
                    end
                end

                // hi * 2^L + lo (+ RND): the low L bits of hi * 2^L are zero
                wire signed [S_W-1:0] hss = {{(S_W-HI_W-L){pss_hi2[HI_W-1]}}, pss_hi2, {L{1'b0}}};
                wire signed [S_W-1:0] hsc = {{(S_W-HI_W-L){psc_hi2[HI_W-1]}}, psc_hi2, {L{1'b0}}};
                wire signed [S_W-1:0] hcc = {{(S_W-HI_W-L){pcc_hi2[HI_W-1]}}, pcc_hi2, {L{1'b0}}};
                wire signed [S_W-1:0] lss = {{(S_W-LO_W){pss_lo2[LO_W-1]}}, pss_lo2};
                wire signed [S_W-1:0] lsc = {{(S_W-LO_W){psc_lo2[LO_W-1]}}, psc_lo2};
                wire signed [S_W-1:0] lcc = {{(S_W-LO_W){pcc_lo2[LO_W-1]}}, pcc_lo2};

                if (COEF_FRAC - 1 < L) begin : g_rnd_in
                    // RND lies in those zero bits: no third operand
                    always @(posedge clk) begin
                        if (ce) begin
                            pss3 <= (hss | $signed(RND)) + lss;
                            psc3 <= hsc + lsc;
                            pcc3 <= (hcc | $signed(RND)) + lcc;
                        end
                    end
                end else begin : g_rnd_add
                    always @(posedge clk) begin
                        if (ce) begin
                            pss3 <= hss + lss + $signed(RND);
                            psc3 <= hsc + lsc;
                            pcc3 <= hcc + lcc + $signed(RND);
                        end
                    end
                end
            end

            // ---- stage 4: the sine sum -----------------------------------------------------------
            reg signed [S_W-1:0] sum_s3, sum_c3;

            always @(posedge clk) begin
                if (ce) begin
                    sum_s3 <= pss3 + psc3;
                    sum_c3 <= pcc3;
                end
            end

            assign sum_s = sum_s3;
            assign sum_c = sum_c3;
        end else begin : g_shared
            // One multiplier, the sample's three products at stages 2, 3 and 4 (k_ss*ds, k_sc*dc,
            // k_cc*dc); the stage-1 registers hold the sample until stage 4 reads them, so the next
            // sample may enter at stage 4's clock enable at the earliest (4 clock enables apart).
            // prod is the registered product; acc_s = k_ss*ds + RND at stage 3, sum_s3 adds k_sc*dc
            // at stage 4, and k_cc*dc + RND goes straight to the output stage: the same sums as the
            // parallel datapath, at the same clock enables.
            // The operands are registered (the DSP's input registers): k_ss and x_s - ofs_s with the
            // sample (stage 1), then k_sc, dc and k_cc, dc from the stage-1 registers.
            reg                     at1;     // the sample is in stage 1
            reg  signed [COEF_W-1:0] k_m;
            reg  signed [D_W-1:0]    d_m;
            wire signed [D_W-1:0]    ds0 = $signed({xs[WAVE_W-1], xs}) - $signed({ofs_s[WAVE_W-1], ofs_s});
            wire signed [S_W-1:0]    prod;

            always @(posedge clk) begin
                if (ce) begin
                    if (in_valid) begin
                        k_m <= k_ss;
                        d_m <= ds0;
                    end else begin
                        k_m <= at1 ? k_sc1 : k_cc1;
                        d_m <= dc1;
                    end
                end
            end
            reg  signed [S_W-1:0]    acc_s, sum_s3;

            always @(posedge clk) begin
                if (rst) begin
                    at1 <= 1'b0;
                end else if (ce) begin
                    at1 <= in_valid;
                end
            end

            if (!WIDE) begin : g_narrow
                reg signed [P_W-1:0] m2;
                always @(posedge clk) begin
                    if (ce) begin
                        m2 <= k_m * d_m;
                    end
                end
                assign prod = {{(S_W-P_W){m2[P_W-1]}}, m2};
            end else begin : g_wide
                localparam integer LO_W = COEF_W + L + 1;    // k * d_lo
                localparam integer HI_W = COEF_W + DH_W;     // k * d_hi
                wire signed [L:0]      d_lo = {1'b0, d_m[L-1:0]};
                wire signed [DH_W-1:0] d_hi = d_m[D_W-1:L];
                reg  signed [LO_W-1:0] m_lo2;
                reg  signed [HI_W-1:0] m_hi2;
                always @(posedge clk) begin
                    if (ce) begin
                        m_lo2 <= k_m * d_lo;
                        m_hi2 <= k_m * d_hi;
                    end
                end
                // hi * 2^L + lo, exact
                assign prod = {{(S_W-HI_W-L){m_hi2[HI_W-1]}}, m_hi2, {L{1'b0}}}
                              + {{(S_W-LO_W){m_lo2[LO_W-1]}}, m_lo2};
            end

            always @(posedge clk) begin
                if (ce) begin
                    acc_s  <= prod + $signed(RND);
                    sum_s3 <= acc_s + prod;
                end
            end

            assign sum_s = sum_s3;
            assign sum_c = prod + $signed(RND);
        end
    endgenerate

    // ---- stage 5: shift (floor) and saturate ------------------------------------------------
    wire [Q_W-1:0] qs3 = sum_s[S_W-1:COEF_FRAC];
    wire [Q_W-1:0] qc3 = sum_c[S_W-1:COEF_FRAC];
    // in range of s(WAVE_W) when the bits above the sign bit repeat it
    wire ovf_s3 = (qs3[Q_W-1:WAVE_W-1] != {(Q_W-WAVE_W+1){qs3[Q_W-1]}});
    wire ovf_c3 = (qc3[Q_W-1:WAVE_W-1] != {(Q_W-WAVE_W+1){qc3[Q_W-1]}});
    localparam [WAVE_W-1:0] MAX_W = {1'b0, {(WAVE_W-1){1'b1}}};
    localparam [WAVE_W-1:0] MIN_W = {1'b1, {(WAVE_W-1){1'b0}}};

    always @(posedge clk) begin
        if (ce) begin
            s   <= ovf_s3 ? (qs3[Q_W-1] ? MIN_W : MAX_W) : qs3[WAVE_W-1:0];
            c   <= ovf_c3 ? (qc3[Q_W-1] ? MIN_W : MAX_W) : qc3[WAVE_W-1:0];
            sat <= ovf_s3 | ovf_c3;
        end
    end

    // ---- valid (the only reset registers) and sideband, LATENCY stages --------------------------
    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(out_valid), .out_data(out_user)
    );

    // The low COEF_FRAC bits of the sums are the fraction dropped by the shift.
    wire unused_ok = &{1'b0, sum_s[COEF_FRAC-1:0], sum_c[COEF_FRAC-1:0], ds1, k_ss1};

endmodule

`default_nettype wire
