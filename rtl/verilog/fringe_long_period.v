// fringe_long_period: the seed 000 harmonic (long-period) correction table with linear
// interpolation, then the output direction and zero.
//
// LATENCY = 8 clock enables, one sample per clock; ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_long_period.md.
// Bit-exact model: model/fringe/fixed/long_period.py.

`default_nettype none

module fringe_long_period #(
    parameter integer LINES     = 256,    // signal periods per revolution, 1..2^20; FINE_W + clog2(LINES) <= 48
    parameter integer FINE_W    = 16,     // fine phase bits per period, 8..30
    parameter integer LP_ADDR_W = 8,      // 2^LP_ADDR_W table entries per revolution, 2..16, 2^LP_ADDR_W <= REV
    parameter integer LP_W      = 18,     // width of value and slope, 8..32; 2^(LP_W - LP_FRAC) <= REV
    parameter integer LP_FRAC   = 4,      // fraction bits of the correction (fine counts), 0..16
    parameter integer LP_IF     = 8,      // interpolation fraction bits, 1..16
    parameter [63:0]  LP_RECIP  = 64'd1,  // index multiplier, from index_mapping() (checked at elaboration)
    parameter integer LP_SHIFT  = 16,     // index shift, LP_IF..127, from index_mapping() (checked)
    parameter         INIT_FILE = "",     // $readmemh image of the table, 2 banks x 2^LP_ADDR_W words; "" = zeros
    parameter integer USER_W    = 1       // sideband width, >= 1
) (
    input  wire                              clk,
    input  wire                              rst,       // synchronous, active high: clears valid only
    input  wire                              ce,        // clock enable: the pipeline advances when 1
    // sample in
    input  wire                              in_valid,
    input  wire [FINE_W+$clog2(LINES)-1:0]   pos,       // u(POS_W), in [0, REV)
    input  wire                              bank,      // table bank of this sample
    input  wire [FINE_W+$clog2(LINES)-1:0]   zero,      // u(POS_W), in [0, REV)
    input  wire                              dir,       // 1: the output runs the other way
    input  wire [USER_W-1:0]                 in_user,
    // table write port (software side), independent of ce
    input  wire                              wr_en,
    input  wire [LP_ADDR_W:0]                wr_addr,   // {bank, entry}
    input  wire [2*LP_W-1:0]                 wr_data,   // {slope, value}
    // position out
    output wire                              out_valid,
    output reg  [FINE_W+$clog2(LINES)-1:0]   pos_out,   // u(POS_W), in [0, REV)
    output wire [USER_W-1:0]                 out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY = LONG_PERIOD_LATENCY;
    localparam integer POS_W   = FINE_W + $clog2(LINES);      // clog2(REV)
    localparam [63:0]  LINES64 = LINES * 64'd1;
    localparam [63:0]  REV64   = LINES64 << FINE_W;           // < 2^48 when legal

    // ---- parameter checks -------------------------------------------------------------------------
    // the index mapping is exact for every position (check_index_mapping in the model)
    localparam           MAP_OK  = fringe_mapping_exact(LP_RECIP, LP_SHIFT, LP_ADDR_W, LINES, FINE_W);

    generate
        `FRINGE_CHECK_POSITION("fringe_long_period", FINE_W, LINES, 48)
        if (LP_ADDR_W < 2 || LP_ADDR_W > 16) begin : g_bad_addr_w
            $error("fringe_long_period: LP_ADDR_W = %0d out of range 2..16 (instance %m)", LP_ADDR_W);
        end else if ((64'd1 << LP_ADDR_W) > REV64) begin : g_bad_entries
            $error("fringe_long_period: 2^LP_ADDR_W = %0d entries exceed REV = LINES * 2^FINE_W (instance %m)",
                   1 << LP_ADDR_W);
        end
        `FRINGE_CHECK_RANGE(g_bad_lp_w, "fringe_long_period", "LP_W", LP_W, 8, 32)
        `FRINGE_CHECK_RANGE(g_bad_lp_frac, "fringe_long_period", "LP_FRAC", LP_FRAC, 0, 16)
        `FRINGE_CHECK_RANGE(g_bad_lp_if, "fringe_long_period", "LP_IF", LP_IF, 1, 16)
        if (LP_W - LP_FRAC >= 0 && (64'd1 << (LP_W - LP_FRAC)) > REV64) begin : g_bad_range
            $error("fringe_long_period: LP_W - LP_FRAC = %0d: corrections up to 2^%0d fine counts exceed REV = LINES * 2^FINE_W (instance %m)",
                   LP_W - LP_FRAC, LP_W - LP_FRAC);
        end
        if (LP_SHIFT < LP_IF || LP_SHIFT > 127) begin : g_bad_shift
            $error("fringe_long_period: LP_SHIFT = %0d out of range LP_IF = %0d .. 127 (instance %m)",
                   LP_SHIFT, LP_IF);
        end else if (!MAP_OK) begin : g_bad_map
            $error("fringe_long_period: LP_RECIP = %0d, LP_SHIFT = %0d do not map every position to floor(pos * 2^LP_ADDR_W / REV); take them from index_mapping() (instance %m)",
                   LP_RECIP, LP_SHIFT);
        end
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_long_period", "USER_W", USER_W, 1)
    endgenerate

    // ---- widths --------------------------------------------------------------------------------------
    localparam integer RECIP_W = (LP_RECIP > 64'd1) ? $clog2(LP_RECIP + 64'd1) : 1;
    localparam integer T_W0    = POS_W + RECIP_W;
    localparam integer T_W     = (T_W0 > LP_SHIFT + LP_ADDR_W) ? T_W0 : LP_SHIFT + LP_ADDR_W;  // index product
    localparam integer PR_W    = LP_W + LP_IF + 1;    // slope x frac: |.| < 2^(LP_W-1+LP_IF)
    localparam integer C_W     = ((LP_W > LP_FRAC) ? LP_W : LP_FRAC) + 2;  // value + 2^(LP_FRAC-1) + ip
    localparam integer SX_W    = C_W + LP_IF;         // {value, 2^(LP_IF-1)} + product
    localparam [LP_IF:0]   RND_X  = {1'b1, {LP_IF{1'b0}}} >> 1;
    localparam [LP_IF-1:0] RND_IF = RND_X[LP_IF-1:0];  // 2^(LP_IF-1), concatenated below value
    localparam integer WW      = POS_W + 2;           // signed positions: pos - step, zero +- REV
    localparam [255:0]   RECIP_X = {192'd0, LP_RECIP};
    localparam [T_W-1:0] RECIP_T = RECIP_X[T_W-1:0];   // T_W >= RECIP_W: no bit lost
    localparam [WW-1:0]  REV_W   = REV64[WW-1:0];

    // ---- valid (the only reset registers) and sideband, LATENCY stages --------------------------
    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(out_valid), .out_data(out_user)
    );

    // ---- 1: index product ----------------------------------------------------------------------------
    wire [T_W-1:0] t = {{(T_W-POS_W){1'b0}}, pos} * RECIP_T;
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

    // ---- 2: table read ---------------------------------------------------------------------------------
`ifdef FRINGE_TECH_ECP5
    wire [2*LP_W-1:0] word;         // the DP16KD's output register: read register and word in one

    fringe_ram_ecp5 #(
        .AW(LP_ADDR_W + 1), .DW(2 * LP_W), .INIT_FILE(INIT_FILE)
    ) u_table (
        .clk(clk),
        .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),
        .ce(ce), .rd_addr({s1_bank, s1_entry}), .rd_data(word)
    );
`else
    wire [2*LP_W-1:0] word_ram;
    reg  [2*LP_W-1:0] word;         // the RAM's output register (its clock-to-out then feeds no logic)

    fringe_table_ram #(
        .ADDR_W(LP_ADDR_W), .DATA_W(2 * LP_W), .INIT_FILE(INIT_FILE)
    ) u_table (
        .clk(clk),
        .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),
        .rd_en(ce), .rd_addr({s1_bank, s1_entry}), .rd_data(word_ram)
    );
`endif

    reg [LP_IF-1:0] s1b_frac;
    reg signed [LP_IF-1:0] s2_fc;   // frac - 2^(LP_IF-1)
    reg [POS_W-1:0] s1b_pos, s1b_zero, s2_pos, s2_zero;
    reg             s1b_dir, s2_dir;

    always @(posedge clk) begin
        if (ce) begin
            s1b_frac <= s1_frac;
            s1b_pos  <= s1_pos;
            s1b_zero <= s1_zero;
            s1b_dir  <= s1_dir;
`ifndef FRINGE_TECH_ECP5
            word     <= word_ram;
`endif
            s2_fc    <= s1b_frac ^ RND_IF;
            s2_pos   <= s1b_pos;
            s2_zero  <= s1b_zero;
            s2_dir   <= s1b_dir;
        end
    end

    // ---- 3: slope x fraction (registered bare), value + 2^(LP_FRAC-1) ------------------------------
    wire signed [LP_W-1:0]  value = word[LP_W-1:0];
    wire signed [LP_W-1:0]  slope = word[2*LP_W-1:LP_W];
    wire signed [C_W-1:0]   value_x = {{(C_W-LP_W){value[LP_W-1]}}, value};
    wire signed [C_W-1:0]   value_rnd;
    wire signed [PR_W-1:0]  s3_prod;                    // after stage 3b: slope * fc
    reg  signed [C_W-1:0]   s3a_value;
    reg  [SX_W-1:0]         s3_base;                    // {s3a_value, 2^(LP_IF-1)} + slope * 2^(LP_IF-1)
    reg  [POS_W-1:0]        s3a_pos, s3a_zero, s3_pos, s3_zero;
    reg                     s3a_dir, s3_dir;

    generate
        if (LP_FRAC > 0) begin : g_round
            assign value_rnd = value_x + $signed({{(C_W-LP_FRAC){1'b0}}, 1'b1, {(LP_FRAC-1){1'b0}}});
        end else begin : g_no_round
            assign value_rnd = value_x;
        end
    endgenerate

    // slope x fc (fc = frac - 2^(LP_IF-1), a live sign bit) in 16x16 partial products (stages 3a, 3b:
    // slope split above 15 bits); the base takes slope * 2^(LP_IF-1) back, modulo 2^SX_W
    wire [LP_W+LP_IF-1:0]  prod;
    reg  signed [LP_W-1:0] s3a_slope;
    wire [SX_W-1:0]        diff = {{(SX_W-LP_W){s3a_slope[LP_W-1]}}, s3a_slope} << (LP_IF - 1);

    fringe_split_mul #(.A_W(LP_W), .A_SIGNED(1), .B_W(LP_IF), .B_SIGNED(1), .LATENCY(2), .LO_W(15)) u_prod (
        .clk(clk), .ce(ce), .a(slope), .b(s2_fc), .p(prod)
    );
    assign s3_prod = {prod[LP_W+LP_IF-1], prod};

    always @(posedge clk) begin
        if (ce) begin
            s3a_slope <= slope;
            s3_base   <= {s3a_value, RND_IF} + diff;
        end
    end

    always @(posedge clk) begin
        if (ce) begin
            s3a_value <= value_rnd;                         // value + 2^(LP_FRAC-1)
            s3a_pos   <= s2_pos;
            s3a_zero  <= s2_zero;
            s3a_dir   <= s2_dir;
            s3_pos    <= s3a_pos;
            s3_zero   <= s3a_zero;
            s3_dir    <= s3a_dir;
        end
    end

    // ---- 4: step = (value + round(slope * frac / 2^LP_IF) + 2^(LP_FRAC-1)) >>> LP_FRAC ----------------
    // (base + product) >>> LP_IF = ({value + 2^(LP_FRAC-1), 2^(LP_IF-1)} + slope * frac) >>> LP_IF
    // = corr + 2^(LP_FRAC-1): one add, exact modulo 2^SX_W.
    // In parallel pos + REV and pos - REV, the wrapped alternatives' starting points for stage 5.
    wire signed [SX_W-1:0] prod_x = {{(SX_W-PR_W){s3_prod[PR_W-1]}}, s3_prod};
    wire signed [SX_W-1:0] sum4   = $signed(s3_base) + prod_x;   // |corr| <= 2^LP_W + 2^(LP_FRAC-1)
    wire [WW-1:0]          pos_x  = {2'b00, s3_pos};
    reg  signed [C_W-LP_FRAC-1:0] s4_step;
    reg  signed [WW-1:0]   s4_pos, s4_pos_up, s4_pos_dn;
    reg  [POS_W-1:0]       s4_zero;
    reg                    s4_dir;

    always @(posedge clk) begin
        if (ce) begin
            s4_step   <= sum4[SX_W-1:LP_IF+LP_FRAC];     // >>> (LP_IF + LP_FRAC)
            s4_pos    <= pos_x;
            s4_pos_up <= pos_x + REV_W;
            s4_pos_dn <= pos_x - REV_W;
            s4_zero   <= s3_zero;
            s4_dir    <= s3_dir;
        end
    end

    // ---- 5: pos_c = (pos - step) mod REV: the three differences in parallel, chosen by sign bits -----
    // |step| <= 2^(LP_W-LP_FRAC) <= REV <= 2^POS_W: pos -+ REV - step fits s(POS_W+2)
    wire signed [WW-1:0] step_x = {{(WW-C_W+LP_FRAC){s4_step[C_W-LP_FRAC-1]}}, s4_step};
    wire signed [WW-1:0] c_mid  = s4_pos - step_x;
    wire signed [WW-1:0] c_up   = s4_pos_up - step_x;
    wire signed [WW-1:0] c_down = s4_pos_dn - step_x;
    wire signed [WW-1:0] c_wrap = c_mid[WW-1] ? c_up : (c_down[WW-1] ? c_mid : c_down);
    wire        [WW-1:0] zero_x = {2'b00, s4_zero};
    reg  [POS_W-1:0]     s5_pos_c;
    reg  [WW-1:0]        s5_zero, s5_zero_alt;
    reg                  s5_dir;

    always @(posedge clk) begin
        if (ce) begin
            s5_pos_c    <= c_wrap[POS_W-1:0];
            s5_zero     <= zero_x;
            // the wrapped alternative of stage 6: dir ? zero + REV - pos_c : zero - REV + pos_c
            s5_zero_alt <= s4_dir ? zero_x + REV_W : zero_x - REV_W;
            s5_dir      <= s4_dir;
        end
    end

    // ---- 6: zero and direction, wrap -----------------------------------------------------------------
    // dir = 0: a = pos_c + zero in [0, 2 REV - 2], b = a - REV; take b when b >= 0.
    // dir = 1: a = zero - pos_c in (-REV, REV),    b = a + REV; take b when a < 0.
    wire [WW-1:0] pc_x = {2'b00, s5_pos_c};
    wire [WW-1:0] a    = s5_dir ? s5_zero - pc_x : s5_zero + pc_x;
    wire [WW-1:0] b    = s5_dir ? s5_zero_alt - pc_x : s5_zero_alt + pc_x;
    wire          use_b = s5_dir ? a[WW-1] : ~b[WW-1];
    wire [WW-1:0] o    = use_b ? b : a;

    always @(posedge clk) begin
        if (ce) begin
            pos_out <= o[POS_W-1:0];
        end
    end

    // Bits that carry nothing: the index product above the entry and below the fraction, the
    // sum's rounded-off bits, the sign bits of wrapped positions (in [0, REV)).
    wire unused = &{1'b0, t, sum4[LP_IF+LP_FRAC-1:0], c_wrap[WW-1:POS_W], o[WW-1:POS_W]};

endmodule

`default_nettype wire
