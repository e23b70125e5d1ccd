// fringe_period_count: coarse/fine combination, or period counting without a coarse code.
//
// Formats (docs/architecture.md, "fringe_period_count"), REV = LINES * 2^FINE_W fine counts per
// revolution, POS_W = FINE_W + clog2(LINES):
//   delta      s(FINE_W) = phase - phase of the previous valid sample (modulo 2^FINE_W)
//   overspeed  |delta| >= 2^(FINE_W-2) (a quarter period); never on the first sample after reset
//   COARSE_W > 0:
//     centre   = (coarse * LINES << (FINE_W - COARSE_W)) + coarse_ofs       (coarse_ofs s(POS_W+1))
//     d        = centre - phase;  n = (d + 2^(FINE_W-1)) >>> FINE_W;  r = d - n * 2^FINE_W
//     coarse_err = |r| > COARSE_TOL = (LINES << (FINE_W-COARSE_W-2)) + 2^(FINE_W-2)
//     pos      = (n mod LINES) * 2^FINE_W + phase      (|coarse_ofs| <= 2^FINE_W: n in [-1, LINES])
//   COARSE_W = 0:
//     pos      = (pos_prev + delta) mod REV; the first valid sample after reset gives pos = phase
// Bit-exact model: model/fringe/fixed/period_count.py.
//
// LATENCY = 2 clock enables from in_valid to out_valid:
//   1: delta, overspeed, coarse centre   2: period number, wrap, position (and the counter)
// rst (synchronous, active high, wins over ce) clears the valid pipeline and the "have a previous
// sample" state, so counting restarts at the next sample.

`default_nettype none

module fringe_period_count #(
    parameter integer FINE_W   = 16,   // fine phase bits per signal period, 8..30
    parameter integer LINES    = 256,  // signal periods per revolution, 1..2^20, any integer
    parameter integer COARSE_W = 9,    // coarse code bits, 0 = none; else FINE_W >= COARSE_W + 2, 2^COARSE_W >= LINES
    parameter integer USER_W   = 1,    // sideband width, >= 1
    // derived: do not override
    parameter integer POS_W    = FINE_W + ((LINES > 1) ? $clog2(LINES) : 0),
    parameter integer CW       = (COARSE_W > 0) ? COARSE_W : 1
) (
    input  wire               clk,
    input  wire               rst,
    input  wire               ce,
    input  wire               in_valid,
    input  wire [FINE_W-1:0]  phase,       // u(FINE_W)
    input  wire [CW-1:0]      coarse,      // u(COARSE_W), ignored when COARSE_W = 0
    input  wire [POS_W:0]     coarse_ofs,  // s(POS_W+1), fine counts, |value| <= 2^FINE_W
    input  wire [USER_W-1:0]  in_user,
    output wire               out_valid,
    output reg  [POS_W-1:0]   pos,         // u(POS_W), in [0, REV)
    output reg                overspeed,
    output reg                coarse_err,
    output wire [USER_W-1:0]  out_user
);

    localparam integer LATENCY = 2;
    localparam integer W = POS_W + 3;       // working width of the signed position arithmetic
    localparam integer SH = (COARSE_W > 0) ? FINE_W - COARSE_W : 0;
    localparam [W-1:0] HALF = {{(W-FINE_W){1'b0}}, 1'b1, {(FINE_W-1){1'b0}}};
    localparam [63:0] LINES64 = {32'd0, LINES};
    localparam [63:0] TOL64 = (COARSE_W > 0)
                              ? ((LINES64 << (FINE_W - COARSE_W - 2)) + (64'd1 << (FINE_W - 2))) : 64'd0;

    generate
        if (FINE_W < 8 || FINE_W > 30) begin : g_bad_fine_w
            $error("fringe_period_count: FINE_W = %0d out of range 8..30 (instance %m)", FINE_W);
        end
        if (LINES < 1 || LINES > (1 << 20)) begin : g_bad_lines
            $error("fringe_period_count: LINES = %0d out of range 1..2^20 (instance %m)", LINES);
        end
        if (COARSE_W != 0 && (COARSE_W < 1 || COARSE_W > 24 || FINE_W < COARSE_W + 2)) begin : g_bad_coarse_w
            $error("fringe_period_count: COARSE_W = %0d must be 0 or 1..24 with FINE_W >= COARSE_W + 2 (instance %m)",
                   COARSE_W);
        end
        if (COARSE_W > 0 && (1 << COARSE_W) < LINES) begin : g_bad_coarse_lines
            $error("fringe_period_count: 2^COARSE_W < LINES (instance %m)");
        end
        if (USER_W < 1) begin : g_bad_user_w
            $error("fringe_period_count: USER_W = %0d must be >= 1 (instance %m)", USER_W);
        end
    endgenerate

    // ---- stage 1: delta to the previous sample, overspeed, coarse centre ------------------------
    reg  [FINE_W-1:0] prev_phase;
    reg               have_prev;      // state: a valid sample has been seen since reset
    wire [FINE_W-1:0] delta = phase - prev_phase;
    wire [FINE_W-1:0] delta_abs = delta[FINE_W-1] ? -delta : delta;
    wire              fast = have_prev && (delta_abs >= (1 << (FINE_W - 2)));

    wire [W-1:0] lines_w = LINES64[W-1:0];
    wire [W-1:0] tol = TOL64[W-1:0];
    wire [W-1:0] coarse_w = {{(W-CW){1'b0}}, coarse};
    wire [W-1:0] ofs_w = {{(W-POS_W-1){coarse_ofs[POS_W]}}, coarse_ofs};
    wire [W-1:0] centre = ((coarse_w * lines_w) << SH) + ofs_w;

    reg  [W-1:0]      s1_centre;
    reg  [FINE_W-1:0] s1_phase, s1_delta;
    reg               s1_fast, s1_first;

    always @(posedge clk) begin
        if (rst) begin
            have_prev <= 1'b0;
        end else if (ce && in_valid) begin
            have_prev <= 1'b1;
        end
        if (ce) begin
            if (in_valid) prev_phase <= phase;
            s1_centre <= centre;
            s1_phase  <= phase;
            s1_delta  <= delta;
            s1_fast   <= fast;
            s1_first  <= !have_prev;
        end
    end

    // ---- stage 2: period number and position ----------------------------------------------------
    wire [W-1:0] phase_w = {{(W-FINE_W){1'b0}}, s1_phase};
    wire [W-1:0] rev_w = lines_w << FINE_W;
    wire [W-1:0] d = s1_centre - phase_w;
    wire [W-1:0] d_half = d + HALF;
    wire [W-1:0] n_raw = {{FINE_W{d_half[W-1]}}, d_half[W-1:FINE_W]};      // floor((d + half) / 2^FINE_W)
    wire [W-1:0] r = {{(W-FINE_W){1'b0}}, d_half[FINE_W-1:0]} - HALF;      // d - n * 2^FINE_W
    wire [W-1:0] r_abs = r[W-1] ? -r : r;
    wire [W-1:0] n_wrap = n_raw[W-1] ? n_raw + lines_w
                        : (n_raw >= lines_w ? n_raw - lines_w : n_raw);
    wire [W-1:0] pos_coarse = (n_wrap << FINE_W) | phase_w;

    reg  [POS_W-1:0] pos_count;       // state of the incremental counter (previous output)
    wire [W-1:0] delta_w = {{(W-FINE_W){s1_delta[FINE_W-1]}}, s1_delta};
    wire [W-1:0] pos_prev_w = {{(W-POS_W){1'b0}}, pos_count};
    wire [W-1:0] sum = pos_prev_w + delta_w;
    wire [W-1:0] pos_next = sum[W-1] ? sum + rev_w : (sum >= rev_w ? sum - rev_w : sum);

    always @(posedge clk) begin
        if (ce && valid_sr[0]) begin
            pos_count <= s1_first ? {{(POS_W-FINE_W){1'b0}}, s1_phase} : pos_next[POS_W-1:0];
        end
        if (ce) begin
            overspeed <= s1_fast;
            if (COARSE_W > 0) begin
                pos        <= pos_coarse[POS_W-1:0];
                coarse_err <= r_abs > tol;
            end else begin
                pos        <= s1_first ? {{(POS_W-FINE_W){1'b0}}, s1_phase} : pos_next[POS_W-1:0];
                coarse_err <= 1'b0;
            end
        end
    end

    // bits that carry no information in a configuration
    wire unused = &{1'b0, n_wrap[W-1:POS_W-FINE_W], pos_coarse[W-1:POS_W], pos_next[W-1:POS_W], r_abs[W-1],
                    n_raw[W-1]};

    // ---- valid (reset) and sideband, LATENCY stages ----------------------------------------------
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
