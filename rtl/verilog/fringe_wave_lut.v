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
    output wire [WAVE_W-1:0]         x,         // s(WAVE_W), WAVE_W-2 fractional bits
    output wire                      clip,
    output wire [USER_W-1:0]         out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY = WAVE_LUT_LATENCY;
    localparam integer FB      = ADC_W - WAVE_ADDR_W;  // fraction bits of the index, >= 1

    generate
        `FRINGE_CHECK_RANGE(g_bad_adc_w, "fringe_wave_lut", "ADC_W", ADC_W, 4, 24)
        if (WAVE_ADDR_W < 2 || WAVE_ADDR_W > ADC_W - 1) begin : g_bad_wave_addr_w
            $error("fringe_wave_lut: WAVE_ADDR_W = %0d out of range 2..ADC_W-1 = %0d (instance %m)",
                   WAVE_ADDR_W, ADC_W - 1);
        end
        `FRINGE_CHECK_RANGE(g_bad_wave_w, "fringe_wave_lut", "WAVE_W", WAVE_W, 8, 32)
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_wave_lut", "USER_W", USER_W, 1)
    endgenerate

    // ---- stage 0 (combinational): index ----------------------------------------------------
    wire [ADC_W-1:0]       u0    = {~adc[ADC_W-1], adc[ADC_W-2:0]};  // adc + 2^(ADC_W-1)
    wire [WAVE_ADDR_W-1:0] addr0 = u0[ADC_W-1:FB];
    wire                   clip0 = (u0 == {ADC_W{1'b0}}) || (u0 == {ADC_W{1'b1}});

    // ---- stages 1..4: x = value + ((slope * frac + 2^(FB-1)) >>> FB) ----------------------------
    // Exact modulo 2^WAVE_W: x lies between value[k] and value[k+1].
    fringe_interp_table #(
        .ADDR_W(WAVE_ADDR_W + 1), .W(WAVE_W), .FB(FB), .OUT_W(WAVE_W), .ROUND_SHIFT(0),
        .INIT_FILE(INIT_FILE)
    ) u_table (
        .clk(clk), .ce(ce),
        .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),
        .rd_addr({bank, branch, addr0}), .frac(u0[FB-1:0]), .result(x)
    );

    // ---- valid (the only reset registers), clip and sideband, LATENCY stages ---------------------
    fringe_delay #(.WIDTH(USER_W + 1), .DEPTH(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data({clip0, in_user}),
        .out_valid(out_valid), .out_data({clip, out_user})
    );

endmodule

`default_nettype wire
