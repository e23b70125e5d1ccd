// fringe_top: fringe_core with AXI4-Stream sample input and position output.
//
// s_axis_tdata = {coarse lane, cos lane, sin lane}, m_axis_tdata = {status, position lane}, lanes of
// whole bytes; the whole pipeline advances on the registered clock enable ce (a flip-flop: the previous
// clock's !m_axis_tvalid || m_axis_tready, 1 after reset) and s_axis_tready = ce && the core's in_ready.
// A word the sink refuses while the pipeline advances over it waits in a one-word skid register, which
// m_axis_tdata shows while it is full (ce is 0 then): nothing lost or duplicated. rst (synchronous,
// active high) empties the pipeline and the skid register.
//
// LATENCY = fringe_core's: CORDIC_STAGES + 25 (+ 13 with TRIM = 1, + 4 with DRIFT = 1, + 4 with
// CANCEL = 1) clocks from the s_axis handshake to m_axis_tvalid when the sink does not stall.
// Parameters, ports and pipeline: docs/blocks/fringe_top.md. Bit-exact model: model/fringe/fixed/core.py.

`default_nettype none

module fringe_top #(
    `include "fringe_core_params.vh"  // generated: python sim/hdlgen.py
) (
    input  wire                clk,
    input  wire                rst,            // synchronous, active high
    // AXI4-Stream samples in
    // S_DATA_W = 2*ADC_LANE + COARSE_LANE bits
    input  wire [2*(8*((ADC_W+7)/8)) + 8*((COARSE_W+7)/8) - 1:0] s_axis_tdata,
    input  wire                s_axis_tvalid,
    output wire                s_axis_tready,
    // AXI4-Stream positions out
    // M_DATA_W = POS_LANE + 8 bits
    output wire [8*(($clog2(LINES)+FINE_W+7)/8) + 8 - 1:0] m_axis_tdata,
    output wire                m_axis_tvalid,
    input  wire                m_axis_tready,
    // configuration write port (fringe_core)
    input  wire                cfg_wr_en,
    input  wire [19:0]         cfg_wr_addr,
    input  wire [63:0]         cfg_wr_data,
    output wire                active_bank
);

    `include "fringe_pkg.vh"

    // The documented latency (fringe.fixed.core.core_latency); read by the testbench, not by the logic.
    /* verilator lint_off UNUSEDPARAM */
    localparam integer LATENCY = fringe_core_latency(CORDIC_STAGES, TRIM, DRIFT, CANCEL);
    // Clock enables from one sample to the next at full speed (fringe.fixed.config clocks_per_sample).
    localparam integer CLOCKS_PER_SAMPLE = 1 + COMPACT * (CORDIC_STAGES + CORDIC_ITER_CLOCKS_BASE - 1);  // COMPACT: 0 or 1
    /* verilator lint_on UNUSEDPARAM */
    localparam integer CW          = (COARSE_W > 0) ? COARSE_W : 1;  // coarse port width of the core
    localparam integer POS_W       = $clog2(LINES) + FINE_W;         // position bits
    localparam integer ADC_LANE    = 8 * ((ADC_W + 7) / 8);          // bits of the sin and cos lanes
    localparam integer POS_LANE    = 8 * ((POS_W + 7) / 8);          // bits of the position lane

    localparam integer M_W         = POS_LANE + 8;                   // bits of m_axis_tdata

    // The stream's clock enable is a register, so its fan-out to the whole pipeline starts at a
    // flip-flop and not at the sink's m_axis_tready: ce = the previous clock's
    // !m_axis_tvalid || m_axis_tready. The clock the sink refuses a word, the pipeline may still advance
    // over it (ce was decided a clock earlier): the word goes to the skid register, m_axis_tdata shows
    // it, and ce is 0 until the sink takes it. skid_valid = !ce except in the clock after a reset.
    reg            ce_r;                // the clock enable of the whole pipeline
    reg            skid_valid;          // the skid register holds the oldest word
    reg  [M_W-1:0] skid_data;
    wire           ce = ce_r;
    wire           core_valid;          // the core's registered out_valid
    wire [M_W-1:0] core_data;           // {status, position lane} of the core's registered output
    wire           in_ready;
    assign s_axis_tready = ce && in_ready;
    assign m_axis_tvalid = skid_valid || core_valid;
    assign m_axis_tdata  = skid_valid ? skid_data : core_data;

    always @(posedge clk) begin
        if (rst) begin
            ce_r       <= 1'b1;
            skid_valid <= 1'b0;
        end else begin
            ce_r       <= !m_axis_tvalid || m_axis_tready;
            skid_valid <= m_axis_tvalid && !m_axis_tready;
        end
        if (!skid_valid) skid_data <= core_data;   // the core's word, kept when the sink refuses it
    end

    wire [CW-1:0] coarse;

    generate
        if (COARSE_W > 0) begin : g_coarse
            assign coarse = s_axis_tdata[2*ADC_LANE +: COARSE_W];
        end else begin : g_no_coarse
            assign coarse = 1'b0;
        end
    endgenerate

    wire [POS_W-1:0] pos;
    wire [7:0]       status;

    fringe_core #(
        `include "fringe_core_map.vh"     // generated: every parameter passed on
    ) u_core (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(s_axis_tvalid), .in_ready(in_ready),
        .sin(s_axis_tdata[ADC_W-1:0]),
        .cos(s_axis_tdata[ADC_LANE +: ADC_W]),
        .coarse(coarse),
        .out_valid(core_valid), .pos(pos), .status(status),
        .cfg_wr_en(cfg_wr_en), .cfg_wr_addr(cfg_wr_addr), .cfg_wr_data(cfg_wr_data),
        .active_bank(active_bank)
    );

    generate
        if (POS_LANE > POS_W) begin : g_pos_pad
            assign core_data = {status, {(POS_LANE - POS_W){1'b0}}, pos};
        end else begin : g_pos_full
            assign core_data = {status, pos};
        end
    endgenerate

    // The padding bits of the input lanes carry nothing.
    wire unused_ok = &{1'b0, s_axis_tdata};

endmodule

`default_nettype wire
