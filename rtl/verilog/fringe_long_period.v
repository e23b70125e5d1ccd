// fringe_long_period: the seed 000 harmonic (long-period) table, then direction and zero.
//
// Formats (docs/architecture.md, "fringe_long_period"), REV = LINES * 2^FINE_W fine counts,
// POS_W = FINE_W + clog2(LINES), 2^LP_ADDR_W table entries per revolution:
//   t      = pos * LP_RECIP;  entry = t >> LP_SHIFT;  frac = (t >> (LP_SHIFT - LP_IF)) mod 2^LP_IF
//   word   = {slope, value}, both s(LP_W), fine counts with LP_FRAC fraction bits, from the
//            two-bank fringe_table_ram at {bank, entry}; slope[k] = value[k+1] - value[k] (wrapping)
//   corr   = value + ((slope * frac + 2^(LP_IF-1)) >>> LP_IF)
//   pos_c  = (pos - ((corr + 2^(LP_FRAC-1)) >>> LP_FRAC)) mod REV     (no rounding term if LP_FRAC = 0)
//   pos_out = dir ? (zero - pos_c) mod REV : (pos_c + zero) mod REV
// LP_RECIP and LP_SHIFT come from model/fringe/fixed/long_period.py index_mapping(): the entry is
// exactly floor(pos * 2^LP_ADDR_W / REV); a power-of-two REV makes LP_RECIP a power of two (a shift).
// Bit-exact model: model/fringe/fixed/long_period.py.
//
// LATENCY = 6 clock enables from in_valid to out_valid:
//   1 index product   2 table read   3 slope x fraction   4 correction, rounded to counts
//   5 subtract, wrap   6 direction and zero, wrap
// rst (synchronous, active high, wins over ce) clears the valid pipeline only. The table's write
// port works whatever ce is.

`default_nettype none

module fringe_long_period #(
    parameter integer LINES     = 256,    // signal periods per revolution, >= 1
    parameter integer FINE_W    = 16,     // fine phase bits per period, 8..30
    parameter integer LP_ADDR_W = 8,      // 2^LP_ADDR_W table entries per revolution, 2..16, 2^LP_ADDR_W <= REV
    parameter integer LP_W      = 18,     // value and slope width, 8..32; corrections stay below REV/2
    parameter integer LP_FRAC   = 4,      // fraction bits of the correction (fine counts), 0..16
    parameter integer LP_IF     = 8,      // interpolation fraction bits, 1..16, <= LP_SHIFT
    parameter [63:0]  LP_RECIP  = 64'd1,  // index multiplier, from index_mapping()
    parameter integer LP_SHIFT  = 16,     // index shift, from index_mapping()
    parameter         INIT_FILE = "",     // $readmemh image, 2 banks x 2^LP_ADDR_W words {slope, value}
    parameter integer USER_W    = 1,      // sideband width, >= 1
    // derived: do not override
    parameter integer POS_W     = FINE_W + ((LINES > 1) ? $clog2(LINES) : 0)
) (
    input  wire                 clk,
    input  wire                 rst,
    input  wire                 ce,
    input  wire                 in_valid,
    input  wire [POS_W-1:0]     pos,        // u(POS_W), in [0, REV)
    input  wire                 bank,       // table bank of this sample
    input  wire [POS_W-1:0]     zero,       // u(POS_W), in [0, REV)
    input  wire                 dir,        // 1: the output runs the other way
    input  wire [USER_W-1:0]    in_user,
    input  wire                 wr_en,      // table write port: {bank, entry}
    input  wire [LP_ADDR_W:0]   wr_addr,
    input  wire [2*LP_W-1:0]    wr_data,
    output wire                 out_valid,
    output reg  [POS_W-1:0]     pos_out,    // u(POS_W), in [0, REV)
    output wire [USER_W-1:0]    out_user
);

    localparam integer LATENCY = 6;
    localparam integer RECIP_W = (LP_RECIP > 64'd1) ? $clog2(LP_RECIP + 64'd1) : 1;
    localparam integer T_W     = POS_W + RECIP_W;          // the index product
    localparam integer PR_W    = LP_W + LP_IF + 1;         // slope x fraction, signed
    localparam integer C_W     = LP_W + 2;                 // correction, signed
    localparam integer WW      = ((POS_W > C_W) ? POS_W : C_W) + 2;  // signed position arithmetic
    localparam [63:0]  LINES64 = {32'd0, LINES};
    localparam [63:0]  REV64   = LINES64 << FINE_W;

    generate
        if (FINE_W < 8 || FINE_W > 30) begin : g_bad_fine_w
            $error("fringe_long_period: FINE_W = %0d out of range 8..30 (instance %m)", FINE_W);
        end
        if (LP_ADDR_W < 2 || LP_ADDR_W > 16 || (64'd1 << LP_ADDR_W) > REV64) begin : g_bad_addr_w
            $error("fringe_long_period: LP_ADDR_W = %0d out of range 2..16 or above clog2(REV) (instance %m)",
                   LP_ADDR_W);
        end
        if (LP_W < 8 || LP_W > 32) begin : g_bad_lp_w
            $error("fringe_long_period: LP_W = %0d out of range 8..32 (instance %m)", LP_W);
        end
        if (LP_FRAC < 0 || LP_FRAC > 16) begin : g_bad_lp_frac
            $error("fringe_long_period: LP_FRAC = %0d out of range 0..16 (instance %m)", LP_FRAC);
        end
        if (LP_IF < 1 || LP_IF > 16 || LP_IF > LP_SHIFT) begin : g_bad_lp_if
            $error("fringe_long_period: LP_IF = %0d out of range 1..16 or above LP_SHIFT (instance %m)", LP_IF);
        end
        if ((64'd1 << (LP_W - 1 - LP_FRAC)) >= (REV64 >> 1)) begin : g_bad_range
            $error("fringe_long_period: LP_W - LP_FRAC allows corrections of half a revolution (instance %m)");
        end
        if (USER_W < 1) begin : g_bad_user_w
            $error("fringe_long_period: USER_W = %0d must be >= 1 (instance %m)", USER_W);
        end
    endgenerate

    wire [WW-1:0] rev_w = REV64[WW-1:0];   // REV < 2^POS_W+1 fits

    // ---- 1: index product ------------------------------------------------------------------------
    wire [T_W-1:0] recip_w = LP_RECIP[T_W-1:0];
    wire [T_W-1:0] t = {{RECIP_W{1'b0}}, pos} * recip_w;
    reg  [LP_ADDR_W-1:0] s1_entry;
    reg  [LP_IF-1:0]     s1_frac;
    reg  [POS_W-1:0]     s1_pos, s1_zero;
    reg                  s1_bank, s1_dir;

    always @(posedge clk) begin
        if (ce) begin
            s1_entry <= t[LP_SHIFT +: LP_ADDR_W];
            s1_frac  <= t[LP_SHIFT-LP_IF +: LP_IF];
            s1_pos   <= pos;
            s1_zero  <= zero;
            s1_bank  <= bank;
            s1_dir   <= dir;
        end
    end

    // ---- 2: table read -----------------------------------------------------------------------------
    wire [2*LP_W-1:0] word;
    fringe_table_ram #(
        .ADDR_W(LP_ADDR_W), .DATA_W(2 * LP_W), .INIT_FILE(INIT_FILE)
    ) u_table (
        .clk(clk), .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),
        .rd_en(ce), .rd_addr({s1_bank, s1_entry}), .rd_data(word)
    );
    reg [LP_IF-1:0] s2_frac;
    reg [POS_W-1:0] s2_pos, s2_zero;
    reg             s2_dir;

    always @(posedge clk) begin
        if (ce) begin
            s2_frac <= s1_frac;
            s2_pos  <= s1_pos;
            s2_zero <= s1_zero;
            s2_dir  <= s1_dir;
        end
    end

    // ---- 3: slope x fraction -----------------------------------------------------------------------
    wire signed [LP_W-1:0]  value = word[LP_W-1:0];
    wire signed [LP_W-1:0]  slope = word[2*LP_W-1:LP_W];
    wire signed [PR_W-1:0]  prod = slope * $signed({1'b0, s2_frac});
    reg  signed [PR_W-1:0]  s3_prod;
    reg  signed [LP_W-1:0]  s3_value;
    reg  [POS_W-1:0]        s3_pos, s3_zero;
    reg                     s3_dir;

    always @(posedge clk) begin
        if (ce) begin
            s3_prod  <= prod;
            s3_value <= value;
            s3_pos   <= s2_pos;
            s3_zero  <= s2_zero;
            s3_dir   <= s2_dir;
        end
    end

    // ---- 4: correction, rounded to whole fine counts -----------------------------------------------
    wire signed [PR_W-1:0] prod_rnd = s3_prod + $signed({{(PR_W-LP_IF){1'b0}}, 1'b1, {(LP_IF-1){1'b0}}});
    wire signed [PR_W-1:0] prod_sh = prod_rnd >>> LP_IF;   // |slope * frac / 2^LP_IF| < 2^(LP_W-1)
    wire signed [C_W-1:0]  corr = $signed({{2{s3_value[LP_W-1]}}, s3_value}) + $signed(prod_sh[C_W-1:0]);
    wire signed [C_W-1:0]  step;
    generate
        if (LP_FRAC > 0) begin : g_round
            wire signed [C_W-1:0] corr_rnd = corr + $signed({{(C_W-LP_FRAC){1'b0}}, 1'b1, {(LP_FRAC-1){1'b0}}});
            assign step = corr_rnd >>> LP_FRAC;
        end else begin : g_no_round
            assign step = corr;
        end
    endgenerate
    reg signed [WW-1:0] s4_pos_c;
    reg [POS_W-1:0]     s4_zero;
    reg                 s4_dir;

    always @(posedge clk) begin
        if (ce) begin
            s4_pos_c <= $signed({{(WW-POS_W){1'b0}}, s3_pos}) - $signed({{(WW-C_W){step[C_W-1]}}, step});
            s4_zero  <= s3_zero;
            s4_dir   <= s3_dir;
        end
    end

    // ---- 5: wrap into [0, REV) -------------------------------------------------------------------
    wire signed [WW-1:0] rev_s = $signed(rev_w);
    wire signed [WW-1:0] wrapped = (s4_pos_c < 0) ? s4_pos_c + rev_s
                                 : ((s4_pos_c >= rev_s) ? s4_pos_c - rev_s : s4_pos_c);
    reg [POS_W-1:0] s5_pos_c, s5_zero;
    reg             s5_dir;

    always @(posedge clk) begin
        if (ce) begin
            s5_pos_c <= wrapped[POS_W-1:0];
            s5_zero  <= s4_zero;
            s5_dir   <= s4_dir;
        end
    end

    // ---- 6: direction and zero ---------------------------------------------------------------------
    wire signed [WW-1:0] zero_w = $signed({{(WW-POS_W){1'b0}}, s5_zero});
    wire signed [WW-1:0] pos_c_w = $signed({{(WW-POS_W){1'b0}}, s5_pos_c});
    wire signed [WW-1:0] out_raw = s5_dir ? zero_w - pos_c_w : pos_c_w + zero_w;
    wire signed [WW-1:0] out_wrap = (out_raw < 0) ? out_raw + rev_s
                                  : ((out_raw >= rev_s) ? out_raw - rev_s : out_raw);

    always @(posedge clk) begin
        if (ce) begin
            pos_out <= out_wrap[POS_W-1:0];
        end
    end

    // bits dropped by the index and the roundings, and the sign bits of wrapped positions
    wire unused = &{1'b0, t, prod_rnd, prod_sh, wrapped[WW-1:POS_W], out_wrap[WW-1:POS_W]};

    // ---- valid (reset) and sideband ------------------------------------------------------------------
    reg [LATENCY-1:0]        valid_sr;
    reg [LATENCY*USER_W-1:0] user_sr;

    always @(posedge clk) begin
        if (rst) begin
            valid_sr <= {LATENCY{1'b0}};
        end else if (ce) begin
            valid_sr <= {valid_sr[LATENCY-2:0], in_valid};
        end
        if (ce) begin
            user_sr <= {user_sr[(LATENCY-1)*USER_W-1:0], in_user};
        end
    end

    assign out_valid = valid_sr[LATENCY-1];
    assign out_user  = user_sr[LATENCY*USER_W-1 -: USER_W];

endmodule

`default_nettype wire
