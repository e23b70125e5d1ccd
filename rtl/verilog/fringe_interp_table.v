// fringe_interp_table: two-bank table of {slope, value} words, linearly interpolated.
//
// LATENCY = 4 clock enables from rd_addr/frac to result; ce = 0 freezes every register; no reset
// (data only: the caller's fringe_delay carries valid).
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_interp_table.md.
// Model: tb/interp_table_model.py (fringe.fixed.table_ram.interpolate with the offset and width).

`default_nettype none

module fringe_interp_table #(
    parameter integer ADDR_W      = 8,   // address bits of one bank, 1..24
    parameter integer W           = 18,  // slope and value field width (word = {slope, value}), 2..32
    parameter integer FB          = 4,   // fraction bits, 1..24
    parameter integer OUT_W       = 19,  // result width, W..W+40 (W: the result wraps modulo 2^W)
    parameter integer ROUND_SHIFT = 0,   // adds 2^(ROUND_SHIFT-1) to the result (0: nothing), 0..40
    parameter         INIT_FILE   = ""   // $readmemh image, 2*2^ADDR_W words; "" = zeros
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

    // The testbench reads LATENCY (tb/test_fringe_interp_table.py); the pipeline below spells it out.
    /* verilator lint_off UNUSEDPARAM */
    localparam integer LATENCY = 4;
    /* verilator lint_on UNUSEDPARAM */
    localparam integer IP_W    = W + FB + 1;                                  // slope x {0, frac}
    localparam integer VX_W    = (ROUND_SHIFT > 0) ? ((W > ROUND_SHIFT) ? W : ROUND_SHIFT) + 2 : W;
    localparam integer EX_W    = OUT_W + IP_W + VX_W;                         // wide enough for any field
    localparam [VX_W-1:0] OFFSET = (ROUND_SHIFT > 0) ? ({{(VX_W-1){1'b0}}, 1'b1} << (ROUND_SHIFT - 1))
                                                     : {VX_W{1'b0}};

    generate
        if (W < 2 || W > 32) begin : g_bad_w
            $error("fringe_interp_table: W = %0d out of range 2..32 (instance %m)", W);
        end
        if (FB < 1 || FB > 24) begin : g_bad_fb
            $error("fringe_interp_table: FB = %0d out of range 1..24 (instance %m)", FB);
        end
        if (OUT_W < W || OUT_W > W + 40) begin : g_bad_out_w
            $error("fringe_interp_table: OUT_W = %0d out of range W..W+40 = %0d..%0d (instance %m)",
                   OUT_W, W, W + 40);
        end
        if (ROUND_SHIFT < 0 || ROUND_SHIFT > 40) begin : g_bad_round_shift
            $error("fringe_interp_table: ROUND_SHIFT = %0d out of range 0..40 (instance %m)", ROUND_SHIFT);
        end
    endgenerate

    // ---- 1: table read (the RAM's read register) -------------------------------------------------
    wire [2*W-1:0] word_q;

    fringe_table_ram #(
        .ADDR_W(ADDR_W), .DATA_W(2 * W), .INIT_FILE(INIT_FILE)
    ) u_table (
        .clk(clk),
        .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),
        .rd_en(ce), .rd_addr(rd_addr), .rd_data(word_q)
    );

    // ---- 2: the RAM's output register (a block RAM's clock-to-out then feeds no logic) -----------
    reg  [FB-1:0]  frac1, frac2;
    reg  [2*W-1:0] word2;

    always @(posedge clk) begin
        if (ce) begin
            frac1 <= frac;
            frac2 <= frac1;
            word2 <= word_q;
        end
    end

    // ---- 3: slope x frac (bare), value + offset ----------------------------------------------------
    wire signed [W-1:0]    slope2 = word2[2*W-1:W];
    wire signed [W-1:0]    value2 = word2[W-1:0];
    wire signed [FB:0]     frac2_s = {1'b0, frac2};
    reg  signed [IP_W-1:0] prod3;
    reg  signed [VX_W-1:0] value3;

    always @(posedge clk) begin
        if (ce) begin
            prod3  <= slope2 * frac2_s;
            value3 <= $signed({{(VX_W-W){value2[W-1]}}, value2}) + $signed(OFFSET);
        end
    end

    // ---- 4: value + offset + ((product + 2^(FB-1)) >>> FB), modulo 2^OUT_W ---------------------------
    // (p + 2^(FB-1)) >>> FB = (p >>> FB) + p[FB-1]: the rounding bit is the adder's carry in.
    wire [EX_W-1:0] ip_x  = {{(EX_W-IP_W){prod3[IP_W-1]}}, prod3} >> FB;
    wire [EX_W-1:0] val_x = {{(EX_W-VX_W){value3[VX_W-1]}}, value3};
    wire [OUT_W-1:0] rb   = {{(OUT_W-1){1'b0}}, prod3[FB-1]};

    always @(posedge clk) begin
        if (ce) begin
            result <= val_x[OUT_W-1:0] + ip_x[OUT_W-1:0] + rb;
        end
    end

    // The product's rounded-off bits and the sign extension beyond OUT_W carry nothing.
    wire unused_ok = &{1'b0, ip_x[EX_W-1:OUT_W], val_x[EX_W-1:OUT_W], prod3[FB-1:0]};

endmodule

`default_nettype wire
