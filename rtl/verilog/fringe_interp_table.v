// fringe_interp_table: two-bank table of {slope, value} words, linearly interpolated.
//
// LATENCY = 4 clock enables from rd_addr/frac to result (5 with PIECE_W > 0); ce = 0 freezes every
// register; no reset (data only: the caller's fringe_delay carries valid).
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_interp_table.md.
// Model: model/fringe/fixed/interp_table.py (fringe.fixed.table_ram.interpolate with the offset and width).

`default_nettype none

module fringe_interp_table #(
    parameter integer ADDR_W      = 8,   // address bits of one bank, 1..24
    parameter integer W           = 18,  // slope and value field width (word = {slope, value}), 2..32
    parameter integer FB          = 4,   // fraction bits, 1..30
    parameter integer OUT_W       = 19,  // result width, W..W+40 (W: the result wraps modulo 2^W)
    parameter integer ROUND_SHIFT = 0,   // adds 2^(ROUND_SHIFT-1) to the result (0: nothing), 0..40
    parameter         INIT_FILE   = "",  // $readmemh image, 2*2^ADDR_W words; "" = zeros
    parameter integer PIECE_W     = 0    // 0: one RAM; 1..25: RAMs of 2^PIECE_W words, each registered, then a
                                         // registered select (one clock enable more); 0..25
) (
    input  wire                    clk,
    input  wire                    ce,       // clock enable: the pipeline advances when 1
    // write port (software side)
    input  wire                    wr_en,
    input  wire [ADDR_W:0]         wr_addr,  // {bank, address}
    input  wire [2*W-1:0]          wr_data,  // {slope, value}, both s(W)
    // read (sample side)
    input  wire [ADDR_W:0]         rd_addr,  // {bank, address}
    input  wire [FB-1:0]           frac,     // u(FB): position between entry and entry + 1
    output reg  [OUT_W-1:0]        result    // s(OUT_W): value + ((slope * frac + 2^(FB-1)) >>> FB) + offset
);

    `include "fringe_pkg.vh"

    // The testbench reads LATENCY (tb/test_fringe_interp_table.py); the pipeline below spells it out.
    /* verilator lint_off UNUSEDPARAM */
    localparam integer LATENCY = (PIECE_W > 0) ? 5 : 4;
    /* verilator lint_on UNUSEDPARAM */
    localparam integer S_W     = OUT_W + FB;                                  // {result, fraction}
    localparam [FB:0]    RND_X = {1'b1, {FB{1'b0}}} >> 1;
    localparam [FB-1:0]  RND   = RND_X[FB-1:0];                                // 2^(FB-1)
    localparam [S_W-1:0] OFFSET = (ROUND_SHIFT > 0) ? ({{(S_W-1){1'b0}}, 1'b1} << (ROUND_SHIFT - 1 + FB))
                                                    : {S_W{1'b0}};             // 2^(ROUND_SHIFT-1), above the fraction

    generate
        `FRINGE_CHECK_RANGE(g_bad_w, "fringe_interp_table", "W", W, 2, 32)
        `FRINGE_CHECK_RANGE(g_bad_fb, "fringe_interp_table", "FB", FB, 1, 30)
        if (OUT_W < W || OUT_W > W + 40) begin : g_bad_out_w
            $error("fringe_interp_table: OUT_W = %0d out of range W..W+40 = %0d..%0d (instance %m)",
                   OUT_W, W, W + 40);
        end
        `FRINGE_CHECK_RANGE(g_bad_round_shift, "fringe_interp_table", "ROUND_SHIFT", ROUND_SHIFT, 0, 40)
        `FRINGE_CHECK_RANGE(g_bad_piece_w, "fringe_interp_table", "PIECE_W", PIECE_W, 0, 25)
    endgenerate

    // ---- 1: table read (the RAM's read register) ---------------------------------------------------
    // ---- 2: the RAM's output register (a block RAM's clock-to-out then feeds no logic) -----------
    // The multiplier takes fc = frac - 2^(FB-1) = frac ^ 2^(FB-1), an s(FB) with a live sign bit (a
    // zero-extended {0, frac} has a constant one: Yosys's ice40_dsp then leaves that operand's register
    // outside the SB_MAC16, whose multiply delay nextpnr-ice40 does not time).
    // PIECE_W > 0: the words lie in NP RAMs of 2^PW words, piece k holding words k * 2^PW .. of the one
    // INIT_FILE and no others (FRINGE_MEM_INIT_SLICE); stage 2 registers each piece's word, stage 3
    // selects the sample's (a deep table's read multiplexer then lies between registers, not behind a
    // block RAM's clock-to-out).
    localparam integer A_W = ADDR_W + 1;                                  // {bank, address}
    localparam integer PW  = (PIECE_W > 0 && PIECE_W < A_W) ? PIECE_W : A_W;
    localparam integer NP  = 1 << (A_W - PW);
    reg  [FB-1:0]  fc1, fc2;
    wire [FB-1:0]  fcm;                                                   // fc beside wordm
    wire [2*W-1:0] wordm;                                                 // the word into stage M

    always @(posedge clk) begin
        if (ce) begin
            fc1 <= frac ^ RND;
            fc2 <= fc1;
        end
    end

    genvar gp;
    generate
        if (PIECE_W == 0) begin : g_one
`ifdef FRINGE_TECH_ECP5
            // the RAM's read register and the word register in one DP16KD (its output register)
            fringe_ram_ecp5 #(
                .AW(ADDR_W + 1), .DW(2 * W), .INIT_FILE(INIT_FILE)
            ) u_table (
                .clk(clk),
                .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),
                .ce(ce), .rd_addr(rd_addr), .rd_data(wordm)
            );
`else
            wire [2*W-1:0] word_q;
            reg  [2*W-1:0] word2;

            fringe_table_ram #(
                .ADDR_W(ADDR_W), .DATA_W(2 * W), .INIT_FILE(INIT_FILE)
            ) u_table (
                .clk(clk),
                .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),
                .rd_en(ce), .rd_addr(rd_addr), .rd_data(word_q)
            );

            always @(posedge clk) begin
                if (ce) begin
                    word2 <= word_q;
                end
            end
            assign wordm = word2;
`endif
            assign fcm   = fc2;
        end else begin : g_pieces
`ifdef FRINGE_TECH_ECP5
            wire [NP*2*W-1:0] piece2;                           // the DP16KDs' output registers
`else
            wire [NP*2*W-1:0] piece_q;
            reg  [NP*2*W-1:0] piece2;
`endif
            reg  [FB-1:0]     fc3;
            reg  [2*W-1:0]    word3;
            wire [A_W:0]      wr_hi = {1'b0, wr_addr} >> PW;        // the piece numbers (one bit wider:
            wire [A_W:0]      rd_hi = {1'b0, rd_addr} >> PW;        // A_W = PW leaves piece 0 only)
            reg  [A_W-PW:0]   sel1, sel2;

            for (gp = 0; gp < NP; gp = gp + 1) begin : g_piece
                localparam [A_W:0]  K     = gp;                      // piece number, above PW bits
                localparam integer  FIRST = gp << PW;                // its first word in INIT_FILE
                wire [A_W:0] wa = (K << PW) | {{(A_W+1-PW){1'b0}}, wr_addr[PW-1:0]};
                wire [A_W:0] ra = (K << PW) | {{(A_W+1-PW){1'b0}}, rd_addr[PW-1:0]};
`ifdef FRINGE_TECH_ECP5
                // the piece's read register and its piece2 register in one DP16KD (output register)
                fringe_ram_ecp5 #(
                    .AW(PW), .DW(2 * W), .INIT_FILE(INIT_FILE), .INIT_FIRST(FIRST)
                ) u_piece (
                    .clk(clk),
                    .wr_en(wr_en && wr_hi == K), .wr_addr(wr_addr[PW-1:0]), .wr_data(wr_data),
                    .ce(ce), .rd_addr(rd_addr[PW-1:0]), .rd_data(piece2[gp*2*W +: 2*W])
                );
                wire unused_k = &{1'b0, wa, ra};
`else
                reg  [2*W-1:0] q;

                // Only the piece's own 2^PW words, indexed by their image address (as fringe_table_ram,
                // no_rw_check: the caller never reads the bank it writes).
                (* no_rw_check *)
                reg [2*W-1:0] mem [FIRST:FIRST+(1<<PW)-1];

                `FRINGE_MEM_INIT_SLICE(INIT_FILE, mem, FIRST, 1 << PW, 2 * W)

                // The index is the image address {K, low bits}: wider than 2^PW words need, by design.
                /* verilator lint_off WIDTH */
                always @(posedge clk) begin
                    if (wr_en && wr_hi == K) begin
                        mem[wa[A_W-1:0]] <= wr_data;
                    end
                end

                always @(posedge clk) begin
                    if (ce) begin
                        q <= mem[ra[A_W-1:0]];
                    end
                end
                /* verilator lint_on WIDTH */
                assign piece_q[gp*2*W +: 2*W] = q;
                wire unused_k = &{1'b0, wa[A_W], ra[A_W]};
`endif
            end
            wire unused_hi = &{1'b0, rd_hi};

            always @(posedge clk) begin
                if (ce) begin
                    sel1   <= rd_hi[A_W-PW:0];
                    sel2   <= sel1;
`ifndef FRINGE_TECH_ECP5
                    piece2 <= piece_q;
`endif
                    fc3    <= fc2;
                    word3  <= piece2[sel2 * (2 * W) +: 2 * W];
                end
            end
            assign wordm = word3;
            assign fcm   = fc3;
        end
    endgenerate

    // ---- M (3; 4 with PIECE_W > 0): slope * fc (bare); base = {value, 2^(FB-1)} + slope * 2^(FB-1)
    // + offset * 2^FB; slope * frac = slope * fc + slope * 2^(FB-1) exactly; everything modulo 2^S_W.
    wire signed [W-1:0]  slope2 = wordm[2*W-1:W];
    wire signed [W-1:0]  value2 = wordm[W-1:0];
    // sign extensions written S_W bits too wide and cut (OUT_W = W leaves no bit to extend)
    wire [S_W+W-1:0]     slope2_e = {{S_W{slope2[W-1]}}, slope2};
    wire [OUT_W+W-1:0]   value2_e = {{OUT_W{value2[W-1]}}, value2};
    wire [S_W-1:0]       slope2_x = slope2_e[S_W-1:0] << (FB - 1);
    wire [S_W-1:0]       value2_x = {value2_e[OUT_W-1:0], RND};
`ifdef FRINGE_TECH_ECP5
    wire signed [W+FB-1:0] prod3;
    generate
        if (W <= 18 && FB <= 18) begin : g_prod_dsp
            // ECP5: the product registered in the MULT18X18D's output register
            fringe_mul_ecp5 #(.A_W(W), .B_W(FB)) u_prod (
                .clk(clk), .ce(ce), .a(slope2), .b(fcm), .p(prod3)
            );
        end else begin : g_prod
            reg signed [W+FB-1:0] prod3_r;
            always @(posedge clk) begin
                if (ce) begin
                    prod3_r <= slope2 * $signed(fcm);
                end
            end
            assign prod3 = prod3_r;
        end
    endgenerate
`elsif FRINGE_TECH_ICE40
    // iCE40, a fraction of 2 to 4 bits (BOOTH): slope * fc in the fabric (one adder) instead of an SB_MAC16, a
    // DSP of the UP5K's 8 for a 4-bit factor. Radix-4 Booth digits of fc (extended to s(4)): fc = 4 d1 + d0,
    // d1 = c2 + c1 - 2 c3, d0 = c0 - 2 c1, each in -2..2: the sum of two selected and inverted copies of the
    // slope, modulo 2^S_W (pb3); a negative digit's + 1 is the adder's carry-in (d1) or base3's bit 0 (d0:
    // value2_x has 0 there).
    localparam integer BOOTH = (FB >= 2 && FB <= 4) ? 1 : 0;
    wire signed [W+FB-1:0] prod3;
    wire [S_W-1:0]         pb3;
    wire                   bcorr;
    generate
        if (BOOTH != 0) begin : g_prod_booth
            wire [3:0]       c    = {{(4 - FB){fcm[FB-1]}}, fcm};
            wire             one1 = c[2] ^ c[1];
            wire             two1 = (c[3] & ~c[2] & ~c[1]) | (~c[3] & c[2] & c[1]);
            wire             one0 = c[0];
            wire             two0 = c[1] & ~c[0];
            wire [S_W+W-1:0] sl_e = {{S_W{slope2[W-1]}}, slope2};
            wire [S_W-1:0]   sl   = sl_e[S_W-1:0];
            wire [S_W-1:0]   x1   = (({S_W{one1}} & sl) | ({S_W{two1}} & (sl << 1))) << 2;
            wire [S_W-1:0]   x0   = ({S_W{one0}} & sl) | ({S_W{two0}} & (sl << 1));
            reg  [S_W-1:0]   pb3_r;
            always @(posedge clk) begin
                if (ce) begin
                    pb3_r <= (x1 ^ {S_W{c[3]}}) + (x0 ^ {S_W{c[1]}}) + {{(S_W-1){1'b0}}, c[3]};
                end
            end
            assign pb3   = pb3_r;
            assign bcorr = c[1];
            assign prod3 = {(W + FB){1'b0}};   // not built
            wire unused_booth = &{1'b0, sl_e[S_W+W-1:S_W]};
        end else begin : g_prod
            reg signed [W+FB-1:0] prod3_r;
            always @(posedge clk) begin
                if (ce) begin
                    prod3_r <= slope2 * $signed(fcm);
                end
            end
            assign prod3 = prod3_r;
            assign pb3   = {S_W{1'b0}};
            assign bcorr = 1'b0;
        end
    endgenerate
`else
    reg  signed [W+FB-1:0] prod3;
`endif
    reg  [S_W-1:0]       base3;

    always @(posedge clk) begin
        if (ce) begin
`ifdef FRINGE_TECH_ICE40
            base3 <= (value2_x | {{(S_W-1){1'b0}}, bcorr}) + slope2_x + OFFSET;
`else
`ifndef FRINGE_TECH_ECP5
            prod3 <= slope2 * $signed(fcm);
`endif
            base3 <= value2_x + slope2_x + OFFSET;
`endif
        end
    end

    // ---- R (4; 5 with PIECE_W > 0): result = (base + product) >>> FB, one add -------------------------------------------------
    // = value + offset + ((slope * frac + 2^(FB-1)) >>> FB), modulo 2^OUT_W.
    wire [S_W+W+FB-1:0] prod3_e = {{S_W{prod3[W+FB-1]}}, prod3};
`ifdef FRINGE_TECH_ICE40
    wire [S_W-1:0]   sum3    = base3 + ((BOOTH != 0) ? pb3 : prod3_e[S_W-1:0]);
`else
    wire [S_W-1:0]   sum3    = base3 + prod3_e[S_W-1:0];
`endif

    always @(posedge clk) begin
        if (ce) begin
            result <= sum3[S_W-1:FB];
        end
    end

    // The sum's fraction bits are rounded off.
    wire unused_ok = &{1'b0, sum3[FB-1:0], slope2_e[S_W+W-1:S_W], value2_e[OUT_W+W-1:OUT_W],
                       prod3_e[S_W+W+FB-1:S_W]};

endmodule

`default_nettype wire
