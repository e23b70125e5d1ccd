// fringe_wave_lut: waveform inverse of one channel as an interpolated table (seed 001).
//
// LATENCY = 4 clock enables, one sample per clock; ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_wave_lut.md.
// Bit-exact model: model/fringe/fixed/wave_lut.py.

`default_nettype none

module fringe_wave_lut #(
    parameter integer ADC_W       = 12,  // ADC code width, 4..24
    parameter integer WAVE_ADDR_W = 8,   // table address bits per branch, 2..ADC_W-1
    parameter integer WAVE_W      = 18,  // table value and output width, 8..32
    parameter         INIT_FILE   = "",  // $readmemh image of both banks (4*2^WAVE_ADDR_W words); "" = zeros
    parameter integer USER_W      = 1    // sideband width, >= 1
) (
    input  wire                      clk,
    input  wire                      rst,       // synchronous, active high: clears valid only
    input  wire                      ce,        // clock enable: the pipeline advances when 1
    // sample in
    input  wire                      in_valid,
    input  wire [ADC_W-1:0]          adc,       // s(ADC_W)
    input  wire                      branch,    // other channel on its positive side
    input  wire                      bank,      // table bank serving this sample
    input  wire [USER_W-1:0]         in_user,
    // table write port: address {bank, branch, addr}, word {slope, value}
    input  wire                      wr_en,
    input  wire [WAVE_ADDR_W+1:0]    wr_addr,
    input  wire [2*WAVE_W-1:0]       wr_data,
    // sample out
    output wire                      out_valid,
    output reg  [WAVE_W-1:0]         x,         // s(WAVE_W), WAVE_W-2 fractional bits
    output reg                       clip,
    output wire [USER_W-1:0]         out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY = WAVE_LUT_LATENCY;
    localparam integer FB      = ADC_W - WAVE_ADDR_W;  // fraction bits of the index, >= 1
    localparam integer PROD_W  = WAVE_W + FB;           // s(WAVE_W) * s(FB)
    localparam [FB:0]   RND_X = {1'b1, {FB{1'b0}}} >> 1;
    localparam [FB-1:0] RND   = RND_X[FB-1:0];            // 2^(FB-1), the rounding constant

    generate
        if (ADC_W < 4 || ADC_W > 24) begin : g_bad_adc_w
            $error("fringe_wave_lut: ADC_W = %0d out of range 4..24 (instance %m)", ADC_W);
        end
        if (WAVE_ADDR_W < 2 || WAVE_ADDR_W > ADC_W - 1) begin : g_bad_wave_addr_w
            $error("fringe_wave_lut: WAVE_ADDR_W = %0d out of range 2..ADC_W-1 = %0d (instance %m)",
                   WAVE_ADDR_W, ADC_W - 1);
        end
        if (WAVE_W < 8 || WAVE_W > 32) begin : g_bad_wave_w
            $error("fringe_wave_lut: WAVE_W = %0d out of range 8..32 (instance %m)", WAVE_W);
        end
        if (USER_W < 1) begin : g_bad_user_w
            $error("fringe_wave_lut: USER_W = %0d must be >= 1 (instance %m)", USER_W);
        end
    endgenerate

    // ---- stage 0 (combinational): index ----------------------------------------------------
    wire [ADC_W-1:0]       u0    = {~adc[ADC_W-1], adc[ADC_W-2:0]};  // adc + 2^(ADC_W-1)
    wire [WAVE_ADDR_W-1:0] addr0 = u0[ADC_W-1:FB];
    wire [FB-1:0]          fc0   = u0[FB-1:0] ^ RND;    // frac - 2^(FB-1), s(FB)
    wire                   clip0 = (u0 == {ADC_W{1'b0}}) || (u0 == {ADC_W{1'b1}});

    // ---- stage 1: table read ----------------------------------------------------------------
    wire [2*WAVE_W-1:0] word1;

    fringe_table_ram #(
        .ADDR_W    (WAVE_ADDR_W + 1),
        .DATA_W    (2 * WAVE_W),
        .INIT_FILE (INIT_FILE)
    ) u_table (
        .clk     (clk),
        .wr_en   (wr_en),
        .wr_addr (wr_addr),
        .wr_data (wr_data),
        .rd_en   (ce),
        .rd_addr ({bank, branch, addr0}),
        .rd_data (word1)
    );

    reg          [FB-1:0] fc0r;
    reg  signed  [FB-1:0] fc1;
    reg                   clip0r, clip1;
    reg  [2*WAVE_W-1:0]   word1r;

    // stage 1b: the RAM's output register (a block RAM's clock-to-out then feeds no logic)
    always @(posedge clk) begin
        if (ce) begin
            fc0r   <= fc0;
            clip0r <= clip0;
            word1r <= word1;
            fc1    <= fc0r;
            clip1  <= clip0r;
        end
    end

    wire signed [WAVE_W-1:0] slope1 = word1r[2*WAVE_W-1:WAVE_W];
    wire signed [WAVE_W-1:0] value1 = word1r[WAVE_W-1:0];

    // ---- stage 2: slope * fc; base = {value, 2^(FB-1)} + slope * 2^(FB-1) -----------------------
    // Both modulo 2^(WAVE_W+FB), the width of the sum below (base's FB-1 low bits are zero).
    reg signed [PROD_W-1:0]      prod2;
    reg        [WAVE_W+FB-1:0]   base2;
    reg                          clip2;

    wire [WAVE_W+FB-1:0] slope1_x = {{FB{slope1[WAVE_W-1]}}, slope1} << (FB - 1);  // slope * 2^(FB-1)

    always @(posedge clk) begin
        if (ce) begin
            prod2 <= slope1 * fc1;
            base2 <= {value1, RND} + slope1_x;
            clip2 <= clip1;
        end
    end

    // ---- stage 3: x = (base + product) >>> FB ----------------------------------------------------
    // = value + ((slope * frac + 2^(FB-1)) >>> FB), one add. The interpolated step lies between 0
    // and slope, and x between value[k] and value[k+1]: the sum is exact modulo 2^WAVE_W.
    wire [WAVE_W+FB-1:0] sum2 = base2 + prod2;

    always @(posedge clk) begin
        if (ce) begin
            x    <= sum2[WAVE_W+FB-1:FB];
            clip <= clip2;
        end
    end

    // ---- valid (the only reset registers) and sideband, LATENCY stages --------------------------
    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(out_valid), .out_data(out_user)
    );

    // The sum's low bits are rounded off.
    wire unused_ok = &{1'b0, sum2[FB-1:0]};

endmodule

`default_nettype wire
