// fringe_synth_wrap: fringe_top behind 17 pins, for synthesis and timing runs only (sim/synth.py).
//
// The core's ports are wide (seed configuration: s_axis_tdata 32 bits, m_axis_tdata 32 bits, the
// configuration port 18 + 64 bits, about 150 pins); an iCE40 UP5K in the SG48 package has 39 I/O.
// Here:
//   - every input word (s_axis_tdata, cfg_wr_addr, cfg_wr_data) is a slice of one shift register
//     fed by the serial pin sdi, so each bit is a register a synthesis tool cannot predict:
//     no input is constant and no logic behind it can be folded away;
//   - the single-bit controls (rst, s_valid, cfg_we, m_ready) are registered from their pins;
//   - the output word m_axis_tdata is XOR-folded onto 8 registered pins (bit i into dout[i % 8]),
//     and s_ready, m_valid, active_bank are registered: every output bit is observed, so no
//     logic in front of it can be removed;
//   - all I/O is registered, so the timing report measures the core (register to register), not
//     the pads. The wrapper adds S_W + 84 + 4 + 11 flip-flops and about M_W / 4 LUTs.
// The tables and registers stay writable (cfg_we), as in a real design: the ROM images (INIT files)
// are initial contents, not constants.

`default_nettype none

// The file keeps the name sim/synth.py and the Makefile use; the module carries the fringe_ prefix.
/* verilator lint_off DECLFILENAME */
module fringe_synth_wrap #(
    `include "fringe_core_params.vh"  // generated: python sim/hdlgen.py
) (
    input  wire       clk,
    input  wire       rst,
    input  wire       sdi,        // serial data into the input shift register
    input  wire       s_valid,
    input  wire       cfg_we,
    input  wire       m_ready,
    output reg        s_ready,
    output reg        m_valid,
    output reg        bank,
    output reg  [7:0] dout        // XOR fold of the output word
);
    localparam integer S_W = 2 * (8 * ((ADC_W + 7) / 8)) + 8 * ((COARSE_W + 7) / 8);
    localparam integer M_W = 8 * (($clog2(LINES) + FINE_W + 7) / 8) + 8;
    localparam integer SR_W = S_W + 20 + 64;

    reg  [SR_W-1:0] sr;
    reg             s_valid_r, cfg_we_r, m_ready_r, rst_r;
    wire [M_W-1:0]  m_data;
    wire            s_ready_w, m_valid_w, bank_w;

    always @(posedge clk) begin
        sr        <= {sr[SR_W-2:0], sdi};
        s_valid_r <= s_valid;
        cfg_we_r  <= cfg_we;
        m_ready_r <= m_ready;
        rst_r     <= rst;
    end

    fringe_top #(
        `include "fringe_core_map.vh"     // generated: every parameter passed on
    ) u_top (
        .clk(clk), .rst(rst_r),
        .s_axis_tdata(sr[S_W-1:0]), .s_axis_tvalid(s_valid_r), .s_axis_tready(s_ready_w),
        .m_axis_tdata(m_data), .m_axis_tvalid(m_valid_w), .m_axis_tready(m_ready_r),
        .cfg_wr_en(cfg_we_r), .cfg_wr_addr(sr[S_W +: 20]), .cfg_wr_data(sr[S_W+20 +: 64]),
        .active_bank(bank_w)
    );

    integer i;
    reg [7:0] fold;
    always @(*) begin
        fold = 8'd0;
        for (i = 0; i < M_W; i = i + 1) fold[i % 8] = fold[i % 8] ^ m_data[i];
    end

    always @(posedge clk) begin
        s_ready <= s_ready_w;
        m_valid <= m_valid_w;
        bank    <= bank_w;
        dout    <= fold;
    end
endmodule
/* verilator lint_on DECLFILENAME */

`default_nettype wire
