// Formal wrapper of fringe_top (sim/formal/run.py): the AXI4-Stream properties, one copy.
//
// Every input is free (any s_axis_tvalid / m_axis_tready pattern, any sample, any configuration
// write, resets at any time); the first cycle is a reset. A reference pipeline of LATENCY stages
// (fringe.fixed.core.core_latency, passed by run.py) advances on the documented clock enable, a
// register: ce = the previous clock's !m_axis_tvalid || m_axis_tready (1 after a reset), and carries,
// for every accepted sample, a tag the solver chooses freely: {the bank it takes (active_bank at the
// handshake), CLIP_COS, CLIP_SIN} (the flags of the raw codes). Behind it a one-word reference skid
// buffer takes the last stage's word when the sink refuses it while ce advances the pipeline over it,
// and is the output while it is full. fringe_top returns each tag in its status byte.
//   stream:  m_axis_tvalid equals the reference's output valid bit (skid or last stage) and the
//            output's tag its tag, so every sample comes out once, after exactly LATENCY clock
//            enables, in order (a lost, duplicated or reordered sample shifts the tag sequence, which
//            the solver can make differ at any place); s_axis_tready is the clock enable, and with
//            COMPACT = 1 it is 0 for CLOCKS_PER_SAMPLE - 1 clock enables after every handshake (the
//            documented admission).
//   stable:  m_axis_tdata and m_axis_tvalid hold while m_axis_tvalid && !m_axis_tready (AXI4-Stream).
//   reset:   the clock after rst, m_axis_tvalid = 0 and fringe_period_count has no previous sample;
//            with stream (the reference is emptied by rst): no sample accepted before a reset ever
//            comes out after it.
//   bank_taps: every bank select of fringe_core takes the bank of the sample it serves (below).
// None of this depends on the data widths: run.py uses a small legal parameter set.

`default_nettype none

module fringe_top_stream #(
    // fringe_top's parameters (generated: python sim/hdlgen.py); run.py sets every one of its configuration
    `include "fringe_core_params.vh"
    , parameter integer LATENCY = 28,
    parameter integer CLOCKS_PER_SAMPLE = 1   // fringe.fixed.config clocks_per_sample, passed by run.py
) (
    input wire clk,
    input wire rst,
    input wire [2*(8*((ADC_W+7)/8)) + 8*((COARSE_W+7)/8) - 1:0] s_axis_tdata,
    input wire s_axis_tvalid,
    input wire m_axis_tready,
    input wire cfg_wr_en,
    input wire [19:0] cfg_wr_addr,
    input wire [63:0] cfg_wr_data
);
    localparam integer ADC_LANE = 8 * ((ADC_W + 7) / 8);
    localparam integer POS_W    = $clog2(LINES) + FINE_W;
    localparam integer POS_LANE = 8 * ((POS_W + 7) / 8);
    localparam integer M_W      = POS_LANE + 8;
    `include "fringe_pkg.vh"   // the status bits and block latencies, generated from the model (sim/hdlgen.py)
    localparam integer BANK = STATUS_BANK, CLIP_COS = STATUS_CLIP_COS, CLIP_SIN = STATUS_CLIP_SIN;

    wire             s_axis_tready, m_axis_tvalid, active_bank;
    wire [M_W-1:0]   m_axis_tdata;

    fringe_top #(
        `include "fringe_core_map.vh"   // generated: every parameter passed on
    ) dut (
        .clk(clk), .rst(rst),
        .s_axis_tdata(s_axis_tdata), .s_axis_tvalid(s_axis_tvalid), .s_axis_tready(s_axis_tready),
        .m_axis_tdata(m_axis_tdata), .m_axis_tvalid(m_axis_tvalid), .m_axis_tready(m_axis_tready),
        .cfg_wr_en(cfg_wr_en), .cfg_wr_addr(cfg_wr_addr), .cfg_wr_data(cfg_wr_data), .active_bank(active_bank)
    );

    // ---- the tag of the sample presented now
    wire [ADC_W-1:0] s_sin = s_axis_tdata[ADC_W-1:0];
    wire [ADC_W-1:0] s_cos = s_axis_tdata[ADC_LANE +: ADC_W];
    wire [ADC_W-1:0] most_neg = {1'b1, {(ADC_W-1){1'b0}}};
    wire [ADC_W-1:0] most_pos = {1'b0, {(ADC_W-1){1'b1}}};
    wire [2:0] in_tag = {active_bank, s_cos == most_neg || s_cos == most_pos, s_sin == most_neg || s_sin == most_pos};
    wire [2:0] out_tag = {m_axis_tdata[POS_LANE + BANK], m_axis_tdata[POS_LANE + CLIP_COS],
                          m_axis_tdata[POS_LANE + CLIP_SIN]};

    // ---- reference pipeline: the documented clock enable (a register) and the one-word skid buffer
    reg ref_ce = 1'b1;
    reg ref_skid_valid;
    reg [2:0] ref_skid_tag;
    wire ce = ref_ce;
    wire accepted = s_axis_tvalid && s_axis_tready;
    // the documented admission: a sample, then CLOCKS_PER_SAMPLE - 1 clock enables without one
    integer ref_wait;
    always @(posedge clk) begin
        if (rst) begin
            ref_wait <= 0;
        end else if (ce) begin
            ref_wait <= accepted ? CLOCKS_PER_SAMPLE - 1 : (ref_wait > 0 ? ref_wait - 1 : 0);
        end
    end
    reg [LATENCY-1:0] ref_valid;
    reg [2:0]         ref_tag [0:LATENCY-1];
    integer i;
    always @(posedge clk) begin
        if (rst) begin
            ref_valid <= {LATENCY{1'b0}};
        end else if (ce) begin
            ref_valid <= {ref_valid[LATENCY-2:0], accepted};
        end
        if (ce) begin
            ref_tag[0] <= in_tag;
            for (i = 1; i < LATENCY; i = i + 1) ref_tag[i] <= ref_tag[i-1];
        end
    end
    // the output: the skid's word while it holds one, else the last stage's
    wire       ref_out_valid = ref_skid_valid || ref_valid[LATENCY-1];
    wire [2:0] ref_out_tag   = ref_skid_valid ? ref_skid_tag : ref_tag[LATENCY-1];
    always @(posedge clk) begin
        if (rst) begin
            ref_ce         <= 1'b1;
            ref_skid_valid <= 1'b0;
        end else begin
            ref_ce         <= !ref_out_valid || m_axis_tready;
            ref_skid_valid <= ref_out_valid && !m_axis_tready;
        end
        if (!ref_skid_valid) ref_skid_tag <= ref_tag[LATENCY-1];
    end

    reg f_init = 1'b1;          // the first cycle: a reset
    reg f_past_valid = 1'b0;
    always @(posedge clk) begin
        f_init       <= 1'b0;
        f_past_valid <= 1'b1;
    end
    always @(*) if (f_init) assume(rst);

`ifdef CHECK_STREAM
    always @(*) begin
        if (!f_init) begin
            assert (s_axis_tready == (ce && ref_wait == 0));
            assert (m_axis_tvalid == ref_out_valid);
            if (m_axis_tvalid) assert (out_tag == ref_out_tag);
        end
    end
`endif

`ifdef CHECK_STABLE
    always @(posedge clk) begin
        if (f_past_valid && !f_init && $past(!rst && m_axis_tvalid && !m_axis_tready)) begin
            assert (m_axis_tvalid);
`ifndef STABLE_VALID_ONLY   // the tdata half pulls the whole datapath into the solver's cone
            assert (m_axis_tdata == $past(m_axis_tdata));
`endif
        end
    end
`endif

`ifdef CHECK_BANK_TAPS
    // bank_taps (white-box): every bank select of fringe_core equals the bank of the sample it
    // serves. The probes are connected by run.py (Yosys `connect` after flattening) to the core's
    // wires; a sample of age A (clock enables since its handshake) sits in ref_tag[A-1]. The ages
    // come from the block latencies of fringe_pkg.vh (docs/architecture.md): a block taking its
    // sample at age A reads its tables with the sample's bank then, and fringe_core reads a block's
    // registers one clock enable ahead, at age A-1.
    localparam integer AGE_LUT  = CORE_INPUT_LATENCY;                                     // fringe_wave_lut
    localparam integer AGE_QUAD = AGE_LUT + WAVE_LUT_LATENCY;                             // fringe_quadrature
    localparam integer AGE_CNT  = AGE_QUAD + QUADRATURE_LATENCY + CORDIC_STAGES + CORDIC_LATENCY_BASE;
    localparam integer AGE_TRIM = AGE_CNT + PERIOD_COUNT_LATENCY;                         // fringe_trim
    localparam integer AGE_LONG = AGE_TRIM + TRIM * TRIM_LATENCY;                         // fringe_long_period
    wire probe_lut_sin, probe_lut_cos, probe_quad_regs, probe_count_regs, probe_long_regs, probe_long;
    always @(*) begin
        if (!f_init) begin
            if (ref_valid[AGE_LUT-1])  assert (probe_lut_sin == ref_tag[AGE_LUT-1][2]);
            if (ref_valid[AGE_LUT-1])  assert (probe_lut_cos == ref_tag[AGE_LUT-1][2]);
            if (ref_valid[AGE_QUAD-2]) assert (probe_quad_regs == ref_tag[AGE_QUAD-2][2]);
            if (ref_valid[AGE_CNT-2])  assert (probe_count_regs == ref_tag[AGE_CNT-2][2]);
            if (ref_valid[AGE_LONG-2]) assert (probe_long_regs == ref_tag[AGE_LONG-2][2]);
            if (ref_valid[AGE_LONG-1]) assert (probe_long == ref_tag[AGE_LONG-1][2]);
        end
    end
    generate
        if (TRIM != 0) begin : g_trim_bank
            wire probe_trim;    // fringe_trim's table bank
            always @(*) if (!f_init && ref_valid[AGE_TRIM-1]) assert (probe_trim == ref_tag[AGE_TRIM-1][2]);
        end
    endgenerate
`endif

`ifdef CHECK_RESET
    // and the state that links a sample to the one before it starts afresh: fringe_period_count's
    // "a previous sample exists" (white-box: run.py connects the probe), so the first sample after a
    // reset is counted from its own phase, with no overspeed against a sample from before the reset
    wire probe_have_prev;
    always @(posedge clk) begin
        if (f_past_valid && $past(rst)) begin
            assert (!m_axis_tvalid);
            assert (!probe_have_prev);
        end
    end
`endif

endmodule

`default_nettype wire
