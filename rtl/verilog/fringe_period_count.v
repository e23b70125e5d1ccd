// fringe_period_count: coarse/fine combination (absolute position from a coarse code), or period
// counting without one; overspeed and coarse-code checks.
//
// With a coarse code, r (the sample's distance from its code's centre) says whether edge jitter can
// have flipped the code: a sample in the TRUST band, -2^(FINE_W-2) <= r < 2^(FINE_W-2) (the top two
// bits of r agree), sets pos from the code; any other sample is tracked, (pos_prev + delta) mod REV as
// the counter (a code of half a period or more flipped at its edge is a whole period off), except
// before the first trusted sample since reset: there the first sample, an overspeed and a sample
// nearer its code's centre than the start-up anchor (m < anchor_m, m = r XOR sign) set pos from the
// code, so a start at a jittered edge follows the best code so far instead of every flip (not
// flagged: edge jitter is not a wrong code). coarse_err: |r| > COARSE_TOL, or a trusted sample whose period number
// differs from a track not lost by an overspeed since the last absolute output (a really wrong code:
// pos resynchronises to the code), and every sample tracked from such a resync (track_bad).
//
// LATENCY = 4 clock enables, one sample per clock: the track (pos_prev + delta, a one-clock loop) is
// stage 3, the compare of its period number with the code's (resync, track_bad, coarse_err) stage 4,
// out of the loop, from registered values; pos and overspeed wait one stage with it. ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_period_count.md.
// Bit-exact model: model/fringe/fixed/period_count.py.

`default_nettype none

module fringe_period_count #(
    parameter integer FINE_W   = 16,   // fine phase bits per signal period, 8..30
    parameter integer LINES    = 256,  // signal periods per revolution, 1..2^20, any integer; FINE_W + clog2(LINES) <= 48
    parameter integer COARSE_W = 9,    // coarse code bits: 0 = none (periods counted), else 1..24, <= FINE_W-2, 2^COARSE_W >= LINES
    parameter integer USER_W   = 1     // sideband width, >= 1
) (
    input  wire                               clk,
    input  wire                               rst,         // synchronous, active high
    input  wire                               ce,          // clock enable: the pipeline advances when 1
    // sample in
    input  wire                               in_valid,
    input  wire [FINE_W-1:0]                  phase,       // u(FINE_W)
    input  wire [((COARSE_W > 0) ? COARSE_W : 1)-1:0] coarse,  // u(COARSE_W); unused when COARSE_W = 0
    input  wire [FINE_W+$clog2(LINES):0]      coarse_ofs,  // s(POS_W+1), fine counts, |value| <= 2^FINE_W
    input  wire [USER_W-1:0]                  in_user,
    // position out
    output wire                               out_valid,
    output reg  [FINE_W+$clog2(LINES)-1:0]    pos,         // u(POS_W), in [0, REV)
    output reg                                overspeed,
    output reg                                coarse_err,
    output wire [USER_W-1:0]                  out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY = PERIOD_COUNT_LATENCY;
    localparam integer POS_W   = FINE_W + $clog2(LINES);   // clog2(REV)
    localparam integer N_W     = POS_W - FINE_W;           // period number bits (0 when LINES = 1)
    localparam integer CW      = (COARSE_W > 0) ? COARSE_W : 1;

    generate
        `FRINGE_CHECK_POSITION("fringe_period_count", FINE_W, LINES, 48)
        if (COARSE_W != 0 && (COARSE_W < 1 || COARSE_W > 24 || COARSE_W > FINE_W - 2)) begin : g_bad_coarse_w
            $error("fringe_period_count: COARSE_W = %0d out of range: 0 (no coarse code) or 1..24 with COARSE_W <= FINE_W - 2 (instance %m)",
                   COARSE_W);
        end else if (COARSE_W > 0 && (1 << COARSE_W) < LINES) begin : g_bad_coarse_lines
            $error("fringe_period_count: 2^COARSE_W = %0d is less than LINES = %0d (instance %m)",
                   1 << COARSE_W, LINES);
        end
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_period_count", "USER_W", USER_W, 1)
    endgenerate

    // ---- valid (the only reset registers) and sideband: stages 1-2, stage 3, then stage 4 ----------
    wire              s2_valid;      // the sample in stage 2 (stage 3 takes it at the next clock enable)
    wire              s3_valid;      // the sample in stage 3 (it reaches the output at the next clock enable)
    wire [USER_W-1:0] s2_user, s3_user;

    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY - 2)) u_valid_12 (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(s2_valid), .out_data(s2_user)
    );
    fringe_delay #(.WIDTH(USER_W), .DEPTH(1)) u_valid_3 (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(s2_valid), .in_data(s2_user),
        .out_valid(s3_valid), .out_data(s3_user)
    );
    fringe_delay #(.WIDTH(USER_W), .DEPTH(1)) u_valid_4 (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(s3_valid), .in_data(s3_user),
        .out_valid(out_valid), .out_data(out_user)
    );

    wire take = ce & in_valid;       // stage 1 takes a sample
    wire step = ce & s2_valid;       // stage 3 takes a sample: the track's loop and the state it reads
    wire done = ce & s3_valid;       // stage 4 produces an output

    // ---- stage 1: delta to the previous valid sample -------------------------------------------
    reg  [FINE_W-1:0] phase_prev;    // data: the previous valid sample's phase
    reg               have_prev;     // state: a valid sample was taken since reset
    reg  [FINE_W-1:0] s1_phase;
    reg  [FINE_W-1:0] s1_delta;      // phase - phase_prev mod 2^FINE_W
    reg               s1_first;      // no previous sample: no overspeed, the counter starts at phase
    reg  [FINE_W-1:0] s2_phase;
    reg               s2_first;
    reg               s2_over;

    always @(posedge clk) begin
        if (take) begin
            phase_prev <= phase;
            have_prev  <= 1'b1;
        end
        if (ce) begin
            s1_phase <= phase;
            s1_delta <= phase - phase_prev;
            s1_first <= ~have_prev;
        end
        if (rst) begin                  // the state only, after the stage: rst wins
            have_prev <= 1'b0;
        end
    end

    // ---- stage 2: overspeed ---------------------------------------------------------------------
    // |delta| >= 2^(FINE_W-2) for delta as s(FINE_W) is delta in [2^(FINE_W-2), 3 * 2^(FINE_W-2)]
    // read as unsigned (the most negative delta, -2^(FINE_W-1), is inside).
    localparam [FINE_W-1:0] Q1 = {2'b01, {(FINE_W-2){1'b0}}};
    localparam [FINE_W-1:0] Q3 = {2'b11, {(FINE_W-2){1'b0}}};
    wire s1_over = ~s1_first & (s1_delta >= Q1) & (s1_delta <= Q3);

    always @(posedge clk) begin
        if (ce) begin
            s2_phase <= s1_phase;
            s2_first <= s1_first;
            s2_over  <= s1_over;
        end
    end

    // ---- stages 3 and 4: the position (stage 3's loop register) and the flag out ---------------------
    reg  [POS_W-1:0] s3_pos;         // data: the track's pos_prev, pos one stage before the output
    reg              s3_over;

    always @(posedge clk) begin
        if (ce) begin
            s3_over <= s2_over;
        end
        if (done) begin
            pos       <= s3_pos;
            overspeed <= s3_over;
        end
    end

    // ---- stage 2: the track's delta and its two wrapped alternatives, delta + REV and delta - REV, so
    // stage 3 adds once (s3_pos holds pos_prev: a loop of one clock); both modes track
    localparam integer SW = POS_W + 2;      // signed sum: [-2^(FINE_W-1), REV + 2^(FINE_W-1))
    localparam [63:0]   LINES64 = LINES * 64'd1;
    localparam [SW-1:0] REV_S   = LINES64[SW-1:0] << FINE_W;

    wire [SW-1:0] dx = {{(SW-FINE_W){s1_delta[FINE_W-1]}}, s1_delta};
    reg  [SW-1:0] s2_d, s2_d_up, s2_d_down;

    always @(posedge clk) begin
        if (ce) begin
            s2_d      <= dx;
            s2_d_up   <= dx + REV_S;
            s2_d_down <= dx - REV_S;
        end
    end

    // stage 3: the three sums in parallel, chosen by sign bits; trk < REV <= 2^POS_W. The low FINE_W
    // bits of trk are the sample's phase (pos_prev's are the previous valid sample's, delta is their
    // difference, REV a multiple of 2^FINE_W): s3_pos takes them from s2_phase, so the choice of
    // either mode drives the N_W period bits only (its select, after m < anchor_m, reaches fewer cells)
    wire [SW-1:0] sum      = {2'b00, s3_pos} + s2_d;
    wire [SW-1:0] sum_up   = {2'b00, s3_pos} + s2_d_up;
    wire [SW-1:0] sum_down = {2'b00, s3_pos} + s2_d_down;
    wire [SW-1:0] trk      = sum[SW-1] ? sum_up : (sum_down[SW-1] ? sum : sum_down);

    generate
        if (N_W == 0) begin : g_one_line
            // LINES = 1: n mod 1 = 0, the position is the phase in either mode (the track's too)
            always @(posedge clk) begin
                if (step) begin
                    s3_pos <= s2_phase;
                end
            end
        end

        if (COARSE_W > 0) begin : g_coarse
            // ---- absolute position from the coarse code -----------------------------------------
            localparam integer W  = POS_W + 3;      // signed: centre and d for any s(POS_W+1) offset
            localparam integer SH = FINE_W - COARSE_W;
            localparam integer NR = W - FINE_W;     // signed period number before the wrap
            localparam [W-1:0]  LINES_W = LINES64[W-1:0];
            localparam [NR-1:0] LINES_N = LINES64[NR-1:0];
            // COARSE_TOL < 2^(FINE_W-1) + 1, as s(FINE_W+1)
            localparam [FINE_W:0] TOL = (LINES_W[FINE_W:0] << (FINE_W - COARSE_W - 2))
                                      + {3'b001, {(FINE_W-2){1'b0}}};

            // stage 1: centre = (coarse * LINES << (FINE_W - COARSE_W)) + coarse_ofs (< REV + 2^POS_W)
            wire [W-1:0] cpos   = ({{(W-CW){1'b0}}, coarse} * LINES_W) << SH;
            wire [W-1:0] ofs_w  = {{(W-POS_W-1){coarse_ofs[POS_W]}}, coarse_ofs};
            reg  [W-1:0] s1_centre;

            always @(posedge clk) begin
                if (ce) begin
                    s1_centre <= cpos + ofs_w;
                end
            end

            // stage 2: dh = d + 2^(FINE_W-1) = centre - (phase - 2^(FINE_W-1)), one subtract: phase -
            // 2^(FINE_W-1) is phase with its top bit inverted, read as s(FINE_W). n = dh >>> FINE_W,
            // r = (dh mod 2^FINE_W) - 2^(FINE_W-1) is dh's low bits with the top one inverted, as s(FINE_W).
            wire [W-1:0] ph_h = {{(W-FINE_W+1){~s1_phase[FINE_W-1]}}, s1_phase[FINE_W-2:0]};
            wire [W-1:0] dh   = s1_centre - ph_h;
            reg  [NR-1:0]     s2_n;          // floor((d + half) / 2^FINE_W), in [-2, LINES+1]
            reg  [FINE_W-1:0] s2_r;          // s(FINE_W), in [-2^(FINE_W-1), 2^(FINE_W-1))
            reg  [FINE_W-2:0] s2_m;          // r XOR sign: r for r >= 0, -r-1 below (no carry)
            // registered here so that stage 3's choice is one LUT after m < anchor_m (4 inputs)
            reg               s2_trusted;    // -TRUST <= r < TRUST: the top two bits of r agree
            reg               s2_restart;    // the first sample or an overspeed: a start-up anchor

            always @(posedge clk) begin
                if (ce) begin
                    s2_n       <= dh[W-1:FINE_W];
                    s2_r       <= {~dh[FINE_W-1], dh[FINE_W-2:0]};
                    s2_m       <= dh[FINE_W-2:0] ^ {(FINE_W-1){~dh[FINE_W-1]}};
                    s2_trusted <= ~dh[FINE_W-1] == dh[FINE_W-2];
                    s2_restart <= s1_first | s1_over;
                end
            end

            // stage 3: |r| > tol (two compares in parallel), n mod LINES, the choice absolute/tracked
            wire signed [FINE_W:0] r   = $signed({s2_r[FINE_W-1], s2_r});
            wire signed [FINE_W:0] tol = $signed(TOL);
            wire err = (r > tol) | (r < -tol);
            wire trusted  = s2_trusted;                         // -TRUST <= r < TRUST
            reg  trusted_seen;                                  // state: a trusted sample since reset
            reg  track_lost;                                    // state: an overspeed since the last absolute output
            // anchor_m: m of the last start-up anchor (start_up: the first sample, an overspeed, m <
            // anchor_m), read only before the first trusted sample (where those are the absolute samples
            // besides the trusted one that ends it) and after the first sample since reset, which writes
            // it: data, not reset (as s3_pos). Its write enable leaves trusted out (the m loop is a
            // compare and one LUT).
            reg  [FINE_W-2:0] anchor_m;
            wire closer   = s2_m < anchor_m;                    // in parallel with the track's sums
            wire start_up = s2_restart | closer;                // the start-up anchor moves here
            wire absolute = trusted | (~trusted_seen & start_up);   // this sample's pos is the code's
            wire lost     = track_lost | s2_over;

            always @(posedge clk) begin
                if (step) begin
                    trusted_seen <= trusted_seen | trusted;
                    track_lost   <= ~absolute & lost;
                end
                if (step & start_up) begin
                    anchor_m <= s2_m;
                end
                if (rst) begin              // the state only, after the stage: rst wins
                    trusted_seen <= 1'b0;
                    track_lost   <= 1'b0;
                end
            end

            // stage 4, out of the loop: a trusted sample after a trusted one, the track not lost
            // (checked), whose period number differs from the track's is a resync
            reg  s3_err, s3_absolute, s3_checked;
            wire differs;                                       // the code's period number is not the track's
            wire resync = s3_checked & differs;
            reg  track_bad;                                     // state: the last absolute output was a resync

            always @(posedge clk) begin
                if (ce) begin
                    s3_err      <= err;
                    s3_absolute <= absolute;
                    s3_checked  <= trusted & trusted_seen & ~lost;
                end
            end

            always @(posedge clk) begin
                if (rst) begin
                    track_bad <= 1'b0;
                end else if (done) begin
                    track_bad <= s3_absolute ? resync : track_bad;
                end
            end

            always @(posedge clk) begin
                if (done) begin
                    coarse_err <= s3_err | (s3_absolute ? resync : track_bad);
                end
            end

            if (N_W > 0) begin : g_lines
                // n in [-2, LINES+1]: n + LINES if n < 0, n - LINES if that is >= 0, else n; both
                // candidates in parallel, chosen by sign bits
                wire [NR-1:0] n_up   = s2_n + LINES_N;
                wire [NR-1:0] n_down = s2_n - LINES_N;
                wire [NR-1:0] n_wrap = s2_n[NR-1] ? n_up : (n_down[NR-1] ? s2_n : n_down);
                // trk and the code's position share their low FINE_W bits (the phase): their period
                // numbers, registered, are compared in stage 4
                reg  [N_W-1:0] s3_n, s3_trk_n;
                assign differs = s3_n != s3_trk_n;

                always @(posedge clk) begin
                    if (step) begin
                        // trk[FINE_W-1:0] is s2_phase: only the period number is chosen
                        s3_pos <= {absolute ? n_wrap[N_W-1:0] : trk[POS_W-1:FINE_W], s2_phase};
                    end
                    if (ce) begin
                        s3_n     <= n_wrap[N_W-1:0];
                        s3_trk_n <= trk[POS_W-1:FINE_W];
                    end
                end

                // n_wrap < LINES <= 2^N_W: its upper bits are zero
                wire unused_n = &{1'b0, n_wrap[NR-1:N_W]};
            end else begin : g_one_line_code
                // LINES = 1: one period number, the code's and the track's (s3_pos: g_one_line)
                assign differs = 1'b0;
                wire unused_n = &{1'b0, s2_n};
            end

            // the top bits of cpos are zero (cpos < REV); s2_first is in s2_restart
            wire unused_c = &{1'b0, cpos[W-1:POS_W], trk[SW-1:POS_W], trk[FINE_W-1:0], s2_first};
        end else begin : g_count
            // ---- incremental: pos = (pos_prev + delta) mod REV ----------------------------------
            if (N_W > 0) begin : g_count_lines
                always @(posedge clk) begin
                    if (step) begin
                        s3_pos <= {s2_first ? {N_W{1'b0}} : trk[POS_W-1:FINE_W], s2_phase};
                    end
                end
            end else begin : g_count_one_line
                // LINES = 1: the position is the phase, first sample or not (s3_pos: g_one_line)
                wire unused_f = &{1'b0, s2_first};
            end

            always @(posedge clk) begin
                if (done) begin
                    coarse_err <= 1'b0;
                end
            end

            // no coarse code
            wire unused_c = &{1'b0, coarse, coarse_ofs, trk[SW-1:POS_W], trk[FINE_W-1:0]};
        end
    endgenerate

endmodule

`default_nettype wire
