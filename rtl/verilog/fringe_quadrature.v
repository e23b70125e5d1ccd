// fringe_quadrature: offset, gain and quadrature correction (seed 001 eq. 21, Heydemann form).
//
// LATENCY = 5 clock enables, one sample per clock (SHARED_MUL = 1: the three products k_ss*ds, k_sc*dc,
// k_cc*dc through one multiplier (fringe_split_mul: partial products of a split operand) in three clock enables, same
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
    localparam integer Q_W       = S_W - COEF_FRAC;  // after the shift: WAVE_W + 4
    localparam [S_W-1:0] RND     = {{(S_W-1){1'b0}}, 1'b1} << (COEF_FRAC - 1);

    generate
        `FRINGE_CHECK_RANGE(g_bad_wave_w, "fringe_quadrature", "WAVE_W", WAVE_W, 8, 32)
        `FRINGE_CHECK_RANGE(g_bad_coef_w, "fringe_quadrature", "COEF_W", COEF_W, 8, 27)
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_quadrature", "USER_W", USER_W, 1)
        `FRINGE_CHECK_BIT(g_bad_shared, "fringe_quadrature", "SHARED_MUL", SHARED_MUL)
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

    // ---- valid (the only reset registers) and sideband, LATENCY stages: stage 1, then the rest -------
    wire              at1;       // the sample is in stage 1 (SHARED_MUL = 1 picks the operands by it)
    wire [USER_W-1:0] user1;

    fringe_delay #(.WIDTH(USER_W), .DEPTH(1)) u_valid1 (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(at1), .out_data(user1)
    );
    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY - 1)) u_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(at1), .in_data(user1),
        .out_valid(out_valid), .out_data(out_user)
    );

    generate
        if (SHARED_MUL == 0) begin : g_parallel
            // ---- stage 2: the products, bare: fringe_split_mul with LATENCY 1 registers the 18x18
            // partial products of a wide difference or gain, and adds them without a register ----
            wire [P_W-1:0] m_ss, m_sc, m_cc;

            fringe_split_mul #(.A_W(COEF_W), .B_W(D_W), .LATENCY(1)) u_mul_ss (
                .clk(clk), .ce(ce), .a(k_ss1), .b(ds1), .p(m_ss)
            );
            fringe_split_mul #(.A_W(COEF_W), .B_W(D_W), .LATENCY(1)) u_mul_sc (
                .clk(clk), .ce(ce), .a(k_sc1), .b(dc1), .p(m_sc)
            );
            fringe_split_mul #(.A_W(COEF_W), .B_W(D_W), .LATENCY(1)) u_mul_cc (
                .clk(clk), .ce(ce), .a(k_cc1), .b(dc1), .p(m_cc)
            );

            // ---- stage 3: the products assembled, with the rounding constant; stage 4: the sine sum
            reg signed [S_W-1:0] pss3, psc3, pcc3;   // k_ss*ds + RND, k_sc*dc, k_cc*dc + RND
            reg signed [S_W-1:0] sum_s3, sum_c3;

            always @(posedge clk) begin
                if (ce) begin
                    pss3   <= $signed({m_ss[P_W-1], m_ss}) + $signed(RND);
                    psc3   <= $signed({m_sc[P_W-1], m_sc});
                    pcc3   <= $signed({m_cc[P_W-1], m_cc}) + $signed(RND);
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
            // prod is the product (fringe_split_mul, LATENCY 1: registered partial products, their
            // sum unregistered); acc_s = k_ss*ds + RND at stage 3, sum_s3 adds k_sc*dc at stage 4,
            // and k_cc*dc + RND goes straight to the output stage: the same sums as the parallel
            // datapath, at the same clock enables.
            // The operands are registered (the DSP's input registers): k_ss and x_s - ofs_s with the
            // sample (stage 1), then k_sc, dc and k_cc, dc from the stage-1 registers.
            reg  signed [COEF_W-1:0] k_m;
            reg  signed [D_W-1:0]    d_m;
            wire signed [D_W-1:0]    ds0 = $signed({xs[WAVE_W-1], xs}) - $signed({ofs_s[WAVE_W-1], ofs_s});
            wire        [P_W-1:0]    m;
            wire signed [S_W-1:0]    prod = $signed({m[P_W-1], m});
            reg  signed [S_W-1:0]    acc_s, sum_s3;

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

            fringe_split_mul #(.A_W(COEF_W), .B_W(D_W), .LATENCY(1)) u_mul (
                .clk(clk), .ce(ce), .a(k_m), .b(d_m), .p(m)
            );

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

    // The low COEF_FRAC bits of the sums are the fraction dropped by the shift.
    wire unused_ok = &{1'b0, sum_s[COEF_FRAC-1:0], sum_c[COEF_FRAC-1:0], ds1, k_ss1};

endmodule

`default_nettype wire
