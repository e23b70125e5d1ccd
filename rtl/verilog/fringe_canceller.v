// fringe_canceller: adaptive canceller of an additive tone on the corrected channels (c, s), between
// the quadrature stage and the CORDIC; the tone is estimated from the radius of the Lissajous figure.
//
// LATENCY = 4 clock enables (in_valid to out_valid), one sample per clock; ADAPT_LATENCY = 15 (a
// block's last sample to its update in place); ce = 0 freezes every register, rst (synchronous,
// active high) clears the valid pipeline, the NCO, the counters, the sums and the coefficients,
// never the data registers. Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_canceller.md.
// Bit-exact model: model/fringe/fixed/canceller.py.

`default_nettype none

module fringe_canceller #(
    parameter integer WAVE_W     = 18,  // width of c, s (radius 2^(WAVE_W-2)), 8..31
    parameter integer LUT_W      = 10,  // 2^LUT_W sine table entries per turn, 4..12
    parameter integer C_W        = 16,  // sine table value width, 8..18
    parameter integer BLOCK_LOG2 = 4,   // B = 2^BLOCK_LOG2 samples per update, 4..12
    parameter integer MU_LOG2    = 6,   // final update step 2^-MU_LOG2 per block, 1..12
    parameter integer A_FRAC     = 4,   // fraction bits of the coefficients, 0..12
    parameter integer A_W        = 20,  // coefficient width, 8..min(32, WAVE_W + A_FRAC)
    parameter integer GEAR_OFFSET = 0,  // the gear shift starts this many gears lower, 0..MU_LOG2-1
    parameter         LUT_INIT   = "",  // $readmemh image of the sine table, 2^LUT_W words of C_W bits ("" = zeros: no cancellation)
    parameter integer USER_W     = 1    // sideband width, >= 1
) (
    input  wire                     clk,
    input  wire                     rst,        // synchronous, active high
    input  wire                     ce,         // clock enable
    input  wire                     in_valid,
    input  wire signed [WAVE_W-1:0] c,          // s(WAVE_W)
    input  wire signed [WAVE_W-1:0] s,
    input  wire [31:0]              freq,       // NCO word of this sample's bank (CANCEL_FREQ), u(32)
    input  wire [USER_W-1:0]        in_user,
    output wire                     out_valid,
    output reg  signed [WAVE_W-1:0] c_out,      // c - n_c, saturated to s(WAVE_W)
    output reg  signed [WAVE_W-1:0] s_out,
    output reg                      sat,        // this sample's subtraction saturated (either channel)
    output wire                     track_sat,  // this sample's coefficients came from a saturated update (held)
    output wire [USER_W-1:0]        out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY       = CANCEL_LATENCY;
    localparam integer ADAPT_LATENCY = CANCEL_ADAPT_LATENCY;
    localparam integer A_W_MAX  = (WAVE_W + A_FRAC < 32) ? WAVE_W + A_FRAC : 32;
    localparam integer SH0      = BLOCK_LOG2 + C_W - 2 - A_FRAC;

    // ---- parameter checks ---------------------------------------------------------------------------
    generate
        `FRINGE_CHECK_RANGE(g_bad_wave_w, "fringe_canceller", "WAVE_W", WAVE_W, 8, 31)
        `FRINGE_CHECK_RANGE(g_bad_lut_w, "fringe_canceller", "LUT_W", LUT_W, 4, 12)
        `FRINGE_CHECK_RANGE(g_bad_c_w, "fringe_canceller", "C_W", C_W, 8, 18)
        `FRINGE_CHECK_RANGE(g_bad_block_log2, "fringe_canceller", "BLOCK_LOG2", BLOCK_LOG2, 4, 12)
        `FRINGE_CHECK_RANGE(g_bad_mu_log2, "fringe_canceller", "MU_LOG2", MU_LOG2, 1, 12)
        `FRINGE_CHECK_RANGE(g_bad_a_frac, "fringe_canceller", "A_FRAC", A_FRAC, 0, 12)
        if (GEAR_OFFSET < 0 || GEAR_OFFSET > MU_LOG2 - 1) begin : g_bad_gear_offset
            $error("fringe_canceller: GEAR_OFFSET = %0d out of range 0..MU_LOG2-1 = %0d (instance %m)",
                   GEAR_OFFSET, MU_LOG2 - 1);
        end
        if (A_W < 8 || A_W > A_W_MAX) begin : g_bad_a_w
            $error("fringe_canceller: A_W = %0d out of range 8..min(32, WAVE_W + A_FRAC) = %0d (instance %m)",
                   A_W, A_W_MAX);
        end
        if (SH0 < 0) begin : g_bad_sh0
            $error("fringe_canceller: BLOCK_LOG2 + C_W - 2 - A_FRAC = %0d must be >= 0 (instance %m)", SH0);
        end
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_canceller", "USER_W", USER_W, 1)
        // the update of block j must be in place before block j + 2 begins (and before block j + 1
        // ends: one update in flight at a time); B >= 16 holds it
        if (ADAPT_LATENCY > (1 << BLOCK_LOG2)) begin : g_late
            $error("fringe_canceller: ADAPT_LATENCY = %0d exceeds B = %0d (instance %m)", ADAPT_LATENCY,
                   1 << BLOCK_LOG2);
        end
    endgenerate

    // ---- widths ---------------------------------------------------------------------------------------
    localparam integer W    = WAVE_W;
    localparam integer NSH  = C_W - 1 + A_FRAC;                    // shift of the estimate
    localparam integer PW   = A_W + C_W;                           // A * cw
    localparam integer DW   = W + 3;                               // c - n_c (|n_c| <= 2^W)
    localparam integer EW   = ((PW + 2 > NSH + DW) ? PW + 2 : NSH + DW) + 1;   // c 2^NSH + 2^(NSH-1) - 1 - A cw - B sw
    localparam integer SQ_W = 2 * W;                               // c_out^2, e * c_out
    localparam integer T_W  = 2 * W + 1;                           // c_out^2 + s_out^2 - 2^(2W-4)
    localparam integer TE_W = T_W - (W - 2);                       // that >>> (W - 2)
    localparam integer U_W  = W + 1;                               // u = (e * c_out) >>> (W - 2)
    localparam integer UC_W = U_W + C_W;                           // u * cw
    localparam integer S_W  = UC_W + BLOCK_LOG2;                   // block sums
    localparam integer R_W  = A_W + 2;                             // the step, clipped (saturates either way)
    localparam integer XR_W = ((S_W > R_W) ? S_W : R_W) + 1;
    localparam integer N_W  = A_W + 3;                             // X + step
    localparam [LUT_W-1:0]      QUARTER  = {{(LUT_W-2){1'b0}}, 2'b01} << (LUT_W - 2);
    localparam [BLOCK_LOG2-1:0] CNT_LAST = {BLOCK_LOG2{1'b1}};
    localparam [NSH-1:0]        K_LOW    = {1'b0, {(NSH-1){1'b1}}};                 // 2^(NSH-1) - 1
    localparam [5:0]            SH0_6    = SH0[5:0];
    localparam integer          GEARS    = MU_LOG2 - GEAR_OFFSET;                    // gears from the first to MU_LOG2
    localparam integer          KW       = (GEARS > 1) ? GEARS : 1;                  // gear counter width
    localparam integer          CAP_I    = (GEARS > 1) ? 1 << (GEARS - 1) : 1;
    localparam integer          GEAR0_I  = GEAR_OFFSET + 1;
    localparam [3:0]            GEAR0    = GEAR0_I[3:0];                             // G_0 (at most 12)
    localparam [KW-1:0]         CAP      = CAP_I[KW-1:0];                            // gear counter top

    // ---- input side: NCO, sample counter, the coefficients of the current block -----------------------
    wire                   acc_in = ce & in_valid & ~rst;
    reg  [31:0]            nco;                // phase of the next sample
    reg  [BLOCK_LOG2-1:0]  cnt;                // accepted samples since reset, mod B
    reg                    inflight;           // a block ended whose update is not in place yet
    wire                   blk_first = acc_in & (cnt == {BLOCK_LOG2{1'b0}});
    wire                   upd_wr;             // an update goes in place (stage 15)
    reg                    act_sat, lat_sat, prv_sat;
    wire                   upd_sat;            // the update in place now saturated

    always @(posedge clk) begin
        if (rst) begin
            nco      <= 32'd0;
            cnt      <= {BLOCK_LOG2{1'b0}};
            inflight <= 1'b0;
        end else begin
            if (acc_in) begin
                nco <= nco + freq;
                cnt <= cnt + 1'b1;
            end
            if (acc_in && cnt == CNT_LAST) begin
                inflight <= 1'b1;
            end else if (upd_wr) begin
                inflight <= 1'b0;
            end
        end
    end

    // track_sat beside the coefficients: latest (lat), the one before (prv), the input block's (act)
    always @(posedge clk) begin
        if (rst) begin
            act_sat <= 1'b0;
            lat_sat <= 1'b0;
            prv_sat <= 1'b0;
        end else begin
            if (blk_first) begin
                act_sat <= inflight ? lat_sat : prv_sat;
            end
            if (upd_wr) begin
                prv_sat <= lat_sat;
                lat_sat <= lat_sat | upd_sat;
            end
        end
    end

    // ---- stage 1: sine table (two reads), input registers -----------------------------------------------
    reg  signed [C_W-1:0] rom [0:(1 << LUT_W)-1];

    generate
        `FRINGE_MEM_INIT(LUT_INIT, rom, 1 << LUT_W, C_W)
    endgenerate

    wire [LUT_W-1:0]      idx_s = nco[31 -: LUT_W];
    wire [LUT_W-1:0]      idx_c = idx_s + QUARTER;
    reg  signed [C_W-1:0] sw1, cw1, sw2, cw2;
    wire signed [W-1:0]   c3, s3;
    wire [2*C_W-1:0]      lut2 = {sw2, cw2};         // coefficient k multiplies lut2 word k % 2 (cw, sw)
    wire [4*PW-1:0]       prod3;                     // stage 3: A_C cw, B_C sw, A_S cw, B_S sw

    // stage 4: c - n = c - ((A cw + B sw + 2^(NSH-1)) >>> NSH) = (c 2^NSH + 2^(NSH-1) - 1 - A cw - B sw) >>> NSH
    // (one sum: the rounding and the subtraction in one carry chain), saturated to s(W)
    wire signed [EW-1:0]  sum_c = {{(EW-NSH-W){c3[W-1]}}, c3, K_LOW}
                                  - {{(EW-PW){prod3[1*PW-1]}}, prod3[0*PW +: PW]}
                                  - {{(EW-PW){prod3[2*PW-1]}}, prod3[1*PW +: PW]};
    wire signed [EW-1:0]  sum_s = {{(EW-NSH-W){s3[W-1]}}, s3, K_LOW}
                                  - {{(EW-PW){prod3[3*PW-1]}}, prod3[2*PW +: PW]}
                                  - {{(EW-PW){prod3[4*PW-1]}}, prod3[3*PW +: PW]};
    wire signed [DW-1:0]  dc    = sum_c[NSH +: DW];  // |c - n_c| < 2^(W+1): the bits above are sign copies
    wire signed [DW-1:0]  ds    = sum_s[NSH +: DW];
    wire                  dc_over = `FRINGE_OUTSIDE(dc, DW, W);
    wire                  ds_over = `FRINGE_OUTSIDE(ds, DW, W);

    always @(posedge clk) begin
        if (ce) begin
            // 1: table reads at the sample's phase (the block RAM's register), input registers
            sw1 <= rom[idx_s];
            cw1 <= rom[idx_c];
            // 2: the table words registered (no logic after the RAM), the block's coefficients (g_coef)
            sw2 <= sw1;
            cw2 <= cw1;
            // 3: the products (g_coef); c, s and track_sat wait in u_x_carry
            // 4: c - n, saturated
            c_out     <= `FRINGE_SATURATE(dc, DW, W);
            s_out     <= `FRINGE_SATURATE(ds, DW, W);
            sat       <= dc_over | ds_over;
        end
    end

    // stages 1..3: the sample, and (from stage 2) its block's track_sat, wait for the products; track_sat is
    // stage 4's: act_sat was taken a stage after the sample
    wire unused_v3;

    fringe_delay #(.WIDTH(2 * W + 1), .DEPTH(3)) u_x_carry (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(1'b0), .in_data({act_sat, s, c}),
        .out_valid(unused_v3), .out_data({track_sat, s3, c3})
    );

    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(out_valid), .out_data(out_user)
    );

    // ---- adaptation (stages 5..13): e, u and the terms of the block sums --------------------------------
    // 5..6 c_out^2, s_out^2   7 t = c^2 + s^2 - 2^(2W-4)   8 e = clip(t >>> (W-2))   9..10 e c_out, e s_out
    // 11..12 u * cw, u * sw   13 the sums (the block's last sample: snapshot, sums cleared)
    wire             a12_valid, a12_last, unused_v1, unused_v2;
    wire [2*C_W-1:0] lut10;                 // {sw, cw} of the sample at stage 10
    wire [2*W-1:0]   y8;                    // {s_out, c_out} of the sample at stage 8
    wire [SQ_W-1:0]  sq_c, sq_s, pe_c, pe_s;
    reg  signed [T_W-1:0] t7;
    reg  signed [W-1:0]   e8;
    wire signed [TE_W-1:0] te7 = t7[T_W-1:W-2];
    wire [2*U_W-1:0] u10 = {pe_s[2*W-2:W-2], pe_c[2*W-2:W-2]};   // fits s(W+1): |e c_out| < 2^(2W-2)
    wire [4*UC_W-1:0] term12;

    fringe_delay #(.WIDTH(1), .DEPTH(12)) u_adapt_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(cnt == CNT_LAST),
        .out_valid(a12_valid), .out_data(a12_last)
    );

    fringe_delay #(.WIDTH(2 * C_W), .DEPTH(8)) u_lut_carry (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(1'b0), .in_data(lut2),
        .out_valid(unused_v1), .out_data(lut10)
    );

    fringe_delay #(.WIDTH(2 * W), .DEPTH(4)) u_y_carry (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(1'b0), .in_data({s_out, c_out}),
        .out_valid(unused_v2), .out_data(y8)
    );

    fringe_split_mul #(.A_W(W), .A_SIGNED(1), .B_W(W), .B_SIGNED(1), .LATENCY(2)) u_sq_c (
        .clk(clk), .ce(ce), .a(c_out), .b(c_out), .p(sq_c)
    );
    fringe_split_mul #(.A_W(W), .A_SIGNED(1), .B_W(W), .B_SIGNED(1), .LATENCY(2)) u_sq_s (
        .clk(clk), .ce(ce), .a(s_out), .b(s_out), .p(sq_s)
    );

    always @(posedge clk) begin
        if (ce) begin
            // 7: (c^2 + s^2) >> (W-2) - R = (c^2 + s^2 - R 2^(W-2)) >>> (W-2)
            t7 <= $signed({1'b0, sq_c}) + $signed({1'b0, sq_s}) - ({{(T_W-1){1'b0}}, 1'b1} <<< (2 * W - 4));
            // 8: e clipped to s(W)
            e8 <= `FRINGE_SATURATE(te7, TE_W, W);
        end
    end

    fringe_split_mul #(.A_W(W), .A_SIGNED(1), .B_W(W), .B_SIGNED(1), .LATENCY(2)) u_ec (
        .clk(clk), .ce(ce), .a(e8), .b(y8[0 +: W]), .p(pe_c)
    );
    fringe_split_mul #(.A_W(W), .A_SIGNED(1), .B_W(W), .B_SIGNED(1), .LATENCY(2)) u_es (
        .clk(clk), .ce(ce), .a(e8), .b(y8[W +: W]), .p(pe_s)
    );

    // ---- stage 13: sums; 14: step = round(S >>> SH) clipped; 15: X + step saturated, in place ----------
    reg              a13_go, a14_go;
    reg  [KW-1:0]    kp1;                   // j + 1 of the block being updated, saturating at CAP
    reg  [3:0]       gear;                  // G_j = min(MU_LOG2, GEAR_OFFSET + bit_length(j + 1))
    wire [5:0]       sh_m1 = SH0_6 + {2'b00, gear} - 6'd1;    // SH_j - 1
    wire [3:0]       sat_k;

    assign upd_wr  = ce & a14_go & ~rst;
    assign upd_sat = |sat_k;

    always @(posedge clk) begin
        if (rst) begin
            a13_go <= 1'b0;
            a14_go <= 1'b0;
            kp1    <= {{(KW-1){1'b0}}, 1'b1};
            gear   <= GEAR0;
        end else if (ce) begin
            a13_go <= a12_valid & a12_last;
            a14_go <= a13_go;
            if (a14_go && kp1 != CAP) begin
                kp1 <= kp1 + 1'b1;
                if (((kp1 + 1'b1) & kp1) == {KW{1'b0}}) begin     // j + 2 a power of two
                    gear <= gear + 4'd1;
                end
            end
        end
    end

    // coefficient k: A_C, B_C, A_S, B_S = channel k / 2 (c, s) times table word k % 2 (cw, sw)
    genvar gk;
    generate
        for (gk = 0; gk < 4; gk = gk + 1) begin : g_coef
            reg  signed [A_W-1:0] act_r, lat_r, prv_r;    // this block's, the latest, the one before
            reg  signed [A_W-1:0] a2;                     // the sample's (stage 2)
            reg  signed [PW-1:0]  p3;
            reg  signed [S_W-1:0] acc, snap;
            reg  signed [R_W-1:0] stp14;
            reg                   rb14;
            wire signed [UC_W-1:0] term = term12[gk*UC_W +: UC_W];
            wire signed [S_W-1:0]  acc_n = acc + {{BLOCK_LOG2{term[UC_W-1]}}, term};
            // (S + 2^(SH-1)) >>> SH = (S >>> SH) + S[SH-1]
            wire signed [S_W-1:0]  v14 = snap >>> sh_m1;
            wire signed [XR_W-1:0] r14 = {{(XR_W-S_W+1){v14[S_W-1]}}, v14[S_W-1:1]};
            wire signed [N_W-1:0]  nx = {{(N_W-A_W){lat_r[A_W-1]}}, lat_r} + {{(N_W-R_W){stp14[R_W-1]}}, stp14}
                                        + {{(N_W-1){1'b0}}, rb14};
            wire                   n_over = `FRINGE_OUTSIDE(nx, N_W, A_W);

            fringe_split_mul #(.A_W(U_W), .A_SIGNED(1), .B_W(C_W), .B_SIGNED(1), .LATENCY(2)) u_term (
                .clk(clk), .ce(ce), .a(u10[(gk/2)*U_W +: U_W]), .b(lut10[(gk%2)*C_W +: C_W]),
                .p(term12[gk*UC_W +: UC_W])
            );

            always @(posedge clk) begin
                if (ce) begin
                    a2 <= act_r;                                                   // 2
                    p3 <= a2 * $signed(lut2[(gk%2)*C_W +: C_W]);                 // 3
                    // 14: the step clipped to s(A_W+2): beyond it X + step saturates either way
                    stp14 <= `FRINGE_SATURATE(r14, XR_W, R_W);
                    rb14  <= v14[0];
                    if (a12_valid && a12_last) begin                               // 13
                        snap <= acc_n;
                    end
                end
            end

            always @(posedge clk) begin
                if (rst || (ce && a12_valid && a12_last)) begin
                    acc <= {S_W{1'b0}};
                end else if (ce && a12_valid) begin
                    acc <= acc_n;
                end
            end

            always @(posedge clk) begin
                if (rst) begin
                    act_r <= {A_W{1'b0}};
                    lat_r <= {A_W{1'b0}};
                    prv_r <= {A_W{1'b0}};
                end else begin
                    // block b begins: coefs[b] is the latest unless the update of block b - 1 is in place
                    if (blk_first) begin
                        act_r <= inflight ? lat_r : prv_r;
                    end
                    if (upd_wr) begin                                              // 15
                        prv_r <= lat_r;
                        lat_r <= `FRINGE_SATURATE(nx, N_W, A_W);
                    end
                end
            end

            assign prod3[gk*PW +: PW] = p3;
            assign sat_k[gk]          = n_over;
        end
    endgenerate

    // Bits that carry nothing: the sign copies above c - n and above e * c_out, the bits shifted off
    // c - n, t and e * c_out, the data-only delays' valid outputs.
    wire unused = &{1'b0, sum_c[EW-1:NSH+DW], sum_s[EW-1:NSH+DW], sum_c[NSH-1:0], sum_s[NSH-1:0], t7[W-3:0],
                    pe_c[2*W-1], pe_s[2*W-1], pe_c[W-3:0],
                    pe_s[W-3:0], unused_v1, unused_v2, unused_v3};

endmodule

`default_nettype wire
