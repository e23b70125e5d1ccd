// Formal miter of fringe_top (sim/formal/run.py): two copies, a and b, compared word by word.
//
// MODE = 0, bank (CHECK_BANK = 0 or 1): both copies get the same samples, backpressure, resets
//   and configuration writes, except that the data of a write to the other bank (1 - CHECK_BANK;
//   writes go to the inactive bank, so: issued while CHECK_BANK is active) may differ, CTRL writes
//   excepted (both swap together). Bank CHECK_BANK then holds the same contents in both copies,
//   the other bank anything, at any time, around any pattern of swaps. Every sample served by bank
//   CHECK_BANK (status BANK) must give the same position and status in both: no stage of it read
//   the other bank. OVERSPEED is left out: it compares the sample with the previous one, which may
//   be from the other bank (a property of the stream, not of one sample). Needs COARSE_W > 0 (the
//   position of one sample is then its own; a counted position carries the previous ones).
// MODE = 1, reset: before a reset chosen by the solver (sync_now) the copies get different samples
//   and backpressure; from the clock after it the same. Their outputs must be equal from then on:
//   a reset leaves nothing of the past in the pipeline (valid bits, the period counter's state).
//   Configuration writes are shared (the tables and registers survive a reset by design).

`default_nettype none

module fringe_top_miter #(
    // fringe_top's parameters (generated: python sim/hdlgen.py); run.py sets every one of its configuration
    `include "fringe_core_params.vh"
    , parameter integer MODE = 0, parameter integer CHECK_BANK = 0
) (
    input wire clk,
    input wire rst,
    input wire [2*(8*((ADC_W+7)/8)) + 8*((COARSE_W+7)/8) - 1:0] a_tdata, b_tdata,
    input wire a_tvalid, b_tvalid,
    input wire a_tready, b_tready,
    input wire cfg_wr_en,
    input wire [19:0] cfg_wr_addr,
    input wire [63:0] a_wr_data, b_wr_data,
    input wire sync_now
);
    localparam integer POS_W    = $clog2(LINES) + FINE_W;
    localparam integer POS_LANE = 8 * ((POS_W + 7) / 8);
    localparam integer M_W      = POS_LANE + 8;
    `include "fringe_pkg.vh"   // the status bits and the register map, generated from the model (sim/hdlgen.py)
    localparam integer BANK = STATUS_BANK, OVERSPEED = STATUS_OVERSPEED;
    localparam [19:0]  CTRL = {SPACE_REGS, CTRL_WORD};   // the register space's word CTRL

    wire           a_s_tready, a_m_tvalid, a_bank, b_s_tready, b_m_tvalid, b_bank;
    wire [M_W-1:0] a_m_tdata, b_m_tdata;

    // copy X of fringe_top: its own samples, write data and backpressure (X_tdata, X_wr_data, X_tready ...)
`define FRINGE_MITER_PORTS(X) \
        .clk(clk), .rst(rst), \
        .s_axis_tdata(X``_tdata), .s_axis_tvalid(X``_tvalid), .s_axis_tready(X``_s_tready), \
        .m_axis_tdata(X``_m_tdata), .m_axis_tvalid(X``_m_tvalid), .m_axis_tready(X``_tready), \
        .cfg_wr_en(cfg_wr_en), .cfg_wr_addr(cfg_wr_addr), .cfg_wr_data(X``_wr_data), .active_bank(X``_bank)

    fringe_top #(
        `include "fringe_core_map.vh"   // generated: every parameter passed on
    ) a (`FRINGE_MITER_PORTS(a));
    fringe_top #(
        `include "fringe_core_map.vh"
    ) b (`FRINGE_MITER_PORTS(b));
`undef FRINGE_MITER_PORTS

    reg f_init = 1'b1;          // the first cycle: a reset
    always @(posedge clk) f_init <= 1'b0;
    always @(*) if (f_init) assume(rst);

    wire same_stream = a_tdata == b_tdata && a_tvalid == b_tvalid && a_tready == b_tready;

    generate
        if (MODE == 0) begin : g_bank
            // the same stream; write data differ only for the other bank's words
            always @(*) begin
                assume (same_stream);
                if (!(cfg_wr_en && a_bank == CHECK_BANK[0] && cfg_wr_addr != CTRL)) assume (a_wr_data == b_wr_data);
                if (!f_init) begin
                    assert (a_bank == b_bank && a_m_tvalid == b_m_tvalid);
                    if (a_m_tvalid && a_m_tdata[POS_LANE + BANK] == CHECK_BANK[0]) begin
                        assert (a_m_tdata[POS_LANE-1:0] == b_m_tdata[POS_LANE-1:0]);
                        assert ((a_m_tdata[M_W-1:POS_LANE] ^ b_m_tdata[M_W-1:POS_LANE]) == (8'd1 << OVERSPEED)
                                || a_m_tdata[M_W-1:POS_LANE] == b_m_tdata[M_W-1:POS_LANE]);
                    end
                end
            end
        end else begin : g_reset
            reg synced = 1'b0;      // the clock after the chosen reset, and every later one
            always @(posedge clk) if (rst && sync_now) synced <= 1'b1;
            always @(*) begin
                assume (a_wr_data == b_wr_data);
                if (synced) begin
                    assume (same_stream);
                    assert (a_s_tready == b_s_tready && a_m_tvalid == b_m_tvalid);
                    if (a_m_tvalid) assert (a_m_tdata == b_m_tdata);
                end
            end
        end
    endgenerate

endmodule

`default_nettype wire
