// fringe_cordic: phase (arctan) and magnitude of the corrected vector, vectoring CORDIC.
//
// LATENCY = STAGES + 2 clock enables. ITERATIVE = 0: fully pipelined, one sample per clock, ready = 1.
// ITERATIVE = 1: one x/y/z register and one micro-rotation stage iterated STAGES times (the same
// micro-rotations in the same order, so the same words and the same LATENCY), one sample per
// STAGES + CORDIC_ITER_CLOCKS_BASE (= 0) clock enables; ready = 0 while a sample is in the register, and an
// in_valid while ready = 0 is ignored. ce = 0 freezes every register, rst (synchronous, active high)
// clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_cordic.md.
// Bit-exact model: model/fringe/fixed/cordic.py.

`default_nettype none

module fringe_cordic #(
    parameter integer IN_W   = 18,  // width of the x and y inputs, s(IN_W), 8..30
    parameter integer FINE_W = 16,  // output phase bits per period, 8..30
    parameter integer STAGES = 18,  // CORDIC micro-rotations, 4..32 (>= FINE_W+1 for full precision)
    parameter integer GUARD  = 3,   // extra fractional bits of x, y and the angle accumulator, 0..8
    parameter integer USER_W = 1,   // sideband width, >= 1
    parameter integer ITERATIVE = 0 // 1 = one micro-rotation stage iterated (one sample per STAGES clocks)
) (
    input  wire                 clk,
    input  wire                 rst,       // synchronous, active high: clears valid only
    input  wire                 ce,        // clock enable: the pipeline advances when 1
    // vector in
    input  wire                 in_valid,
    input  wire [IN_W-1:0]      x,         // s(IN_W), cosine
    input  wire [IN_W-1:0]      y,         // s(IN_W), sine
    input  wire [USER_W-1:0]    in_user,
    output wire                 ready,     // 1: in_valid at this clock is taken (always 1 when ITERATIVE = 0)
    // phase and magnitude out
    output wire                 out_valid,
    output reg  [FINE_W-1:0]    phase,     // u(FINE_W), fraction of a period
    output reg  [IN_W:0]        mag,       // u(IN_W+1), magnitude times the CORDIC gain
    output wire [USER_W-1:0]    out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY = STAGES + CORDIC_LATENCY_BASE;
    localparam integer ACC_W   = FINE_W + GUARD;   // angle accumulator, one turn = 2^ACC_W
    localparam integer DP_W    = IN_W + 2 + GUARD; // x/y datapath
    localparam [ACC_W-1:0] HALF_TURN = {1'b1, {(ACC_W-1){1'b0}}};

    generate
        `FRINGE_CHECK_RANGE(g_bad_in_w, "fringe_cordic", "IN_W", IN_W, 8, 30)
        `FRINGE_CHECK_RANGE(g_bad_fine_w, "fringe_cordic", "FINE_W", FINE_W, 8, 30)
        `FRINGE_CHECK_RANGE(g_bad_stages, "fringe_cordic", "STAGES", STAGES, 4, 32)
        `FRINGE_CHECK_RANGE(g_bad_guard, "fringe_cordic", "GUARD", GUARD, 0, 8)
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_cordic", "USER_W", USER_W, 1)
        `FRINGE_CHECK_BIT(g_bad_iterative, "fringe_cordic", "ITERATIVE", ITERATIVE)
    endgenerate

    // atan(2^-i) / (2 pi) as a 62-bit fraction of a turn, round half up (i = 0..31). The same
    // table is ATAN62 in model/fringe/fixed/cordic.py and in rtl/vhdl/fringe_cordic.vhd.
    function [63:0] atan62;
        input integer i;
        begin
            case (i)
                 0: atan62 = 64'h0800000000000000; // atan(2^-0) = 45.0000000000 deg
                 1: atan62 = 64'h04B90147677CC21A; // atan(2^-1) = 26.5650511771 deg
                 2: atan62 = 64'h027ECE16D7B8E7A3; // atan(2^-2) = 14.0362434679 deg
                 3: atan62 = 64'h0144447507776687; // atan(2^-3) = 7.1250163489 deg
                 4: atan62 = 64'h00A2C350C39626BB; // atan(2^-4) = 3.5763343750 deg
                 5: atan62 = 64'h005175F85641189E; // atan(2^-5) = 1.7899106082 deg
                 6: atan62 = 64'h0028BD87970A098A; // atan(2^-6) = 0.8951737102 deg
                 7: atan62 = 64'h00145F15447510AC; // atan(2^-7) = 0.4476141709 deg
                 8: atan62 = 64'h000A2F94D1B430CE; // atan(2^-8) = 0.2238105004 deg
                 9: atan62 = 64'h000517CBAECC2ACE; // atan(2^-9) = 0.1119056771 deg
                10: atan62 = 64'h00028BE600246E9F; // atan(2^-10) = 0.0559528919 deg
                11: atan62 = 64'h000145F3052A032E; // atan(2^-11) = 0.0279764526 deg
                12: atan62 = 64'h0000A2F98337FB18; // atan(2^-12) = 0.0139882271 deg
                13: atan62 = 64'h0000517CC1B05CBD; // atan(2^-13) = 0.0069941137 deg
                14: atan62 = 64'h000028BE60DABA44; // atan(2^-14) = 0.0034970569 deg
                15: atan62 = 64'h0000145F306DAE9F; // atan(2^-15) = 0.0017485284 deg
                16: atan62 = 64'h00000A2F9836E17F; // atan(2^-16) = 0.0008742642 deg
                17: atan62 = 64'h00000517CC1B7205; // atan(2^-17) = 0.0004371321 deg
                18: atan62 = 64'h0000028BE60DB92B; // atan(2^-18) = 0.0002185661 deg
                19: atan62 = 64'h00000145F306DC9B; // atan(2^-19) = 0.0001092830 deg
                20: atan62 = 64'h000000A2F9836E4E; // atan(2^-20) = 0.0000546415 deg
                21: atan62 = 64'h000000517CC1B727; // atan(2^-21) = 0.0000273208 deg
                22: atan62 = 64'h00000028BE60DB94; // atan(2^-22) = 0.0000136604 deg
                23: atan62 = 64'h000000145F306DCA; // atan(2^-23) = 0.0000068302 deg
                24: atan62 = 64'h0000000A2F9836E5; // atan(2^-24) = 0.0000034151 deg
                25: atan62 = 64'h0000000517CC1B72; // atan(2^-25) = 0.0000017075 deg
                26: atan62 = 64'h000000028BE60DB9; // atan(2^-26) = 0.0000008538 deg
                27: atan62 = 64'h0000000145F306DD; // atan(2^-27) = 0.0000004269 deg
                28: atan62 = 64'h00000000A2F9836E; // atan(2^-28) = 0.0000002134 deg
                29: atan62 = 64'h00000000517CC1B7; // atan(2^-29) = 0.0000001067 deg
                30: atan62 = 64'h0000000028BE60DC; // atan(2^-30) = 0.0000000534 deg
                31: atan62 = 64'h00000000145F306E; // atan(2^-31) = 0.0000000267 deg
                default: atan62 = 64'h0000000000000000;
            endcase
        end
    endfunction

    // ---- pre-rotation into the right half plane, scale by 2^GUARD ------------------------------
    wire signed [DP_W-1:0] x_ext = {{(DP_W-IN_W){x[IN_W-1]}}, x};
    wire signed [DP_W-1:0] y_ext = {{(DP_W-IN_W){y[IN_W-1]}}, y};
    wire                   x_neg = x[IN_W-1];
    wire signed [DP_W-1:0] x_abs = x_neg ? -x_ext : x_ext;
    wire signed [DP_W-1:0] y_pre = x_neg ? -y_ext : y_ext;

    // the rotated vector and angle after the last micro-rotation, rounded below
    wire signed [DP_W-1:0]  x_last;
    wire        [ACC_W-1:0] z_last;

    genvar k;
    generate
        if (ITERATIVE == 0) begin : g_pipelined
            // ---- stage 1: pre-rotation register; stages 2..STAGES+1: micro-rotations -----------
            // Stage k of these vectors holds the values after k micro-rotations (k = 0: pre-rotated).
            // y after the last micro-rotation is not needed, hence STAGES slices only.
            reg [(STAGES+1)*DP_W-1:0]  x_p;
            reg [STAGES*DP_W-1:0]      y_p;
            reg [(STAGES+1)*ACC_W-1:0] z_p;

            always @(posedge clk) begin
                if (ce) begin
                    x_p[0 +: DP_W]  <= x_abs <<< GUARD;
                    y_p[0 +: DP_W]  <= y_pre <<< GUARD;
                    z_p[0 +: ACC_W] <= x_neg ? HALF_TURN : {ACC_W{1'b0}};
                end
            end

            // ---- stages 2..STAGES+1: micro-rotations ----------------------------------------
            for (k = 0; k < STAGES; k = k + 1) begin : g_stage
                localparam [63:0] ATAN_FULL = (atan62(k) + (64'd1 << (61 - ACC_W))) >> (62 - ACC_W);
                localparam [ACC_W-1:0] ATAN_K = ATAN_FULL[ACC_W-1:0];  // < 2^(ACC_W-3)

                wire signed [DP_W-1:0]  xi  = x_p[k*DP_W +: DP_W];
                wire signed [DP_W-1:0]  yi  = y_p[k*DP_W +: DP_W];
                wire        [ACC_W-1:0] zi  = z_p[k*ACC_W +: ACC_W];
                wire signed [DP_W-1:0]  ysh = yi >>> k;
                wire                    neg = yi[DP_W-1];  // y < 0: rotate counter-clockwise

                // a +- b as one adder with carry-in, a + (b ^ {s}) + s (half the LUTs of a mux of a
                // sum and a difference): x + (y >>> k) or x - (y >>> k); z + ATAN[k] or z - ATAN[k].
                always @(posedge clk) begin
                    if (ce) begin
                        x_p[(k+1)*DP_W +: DP_W]   <= xi + (ysh ^ {DP_W{neg}}) + {{(DP_W-1){1'b0}}, neg};
                        z_p[(k+1)*ACC_W +: ACC_W] <= zi + (ATAN_K ^ {ACC_W{neg}}) + {{(ACC_W-1){1'b0}}, neg};
                    end
                end

                if (k < STAGES - 1) begin : g_y
                    wire signed [DP_W-1:0] xsh = xi >>> k;

                    // y - (x >>> k) or y + (x >>> k)
                    always @(posedge clk) begin
                        if (ce) begin
                            y_p[(k+1)*DP_W +: DP_W] <= yi + (xsh ^ {DP_W{~neg}}) + {{(DP_W-1){1'b0}}, ~neg};
                        end
                    end
                end
            end

            assign x_last = x_p[STAGES*DP_W +: DP_W];
            assign z_last = z_p[STAGES*ACC_W +: ACC_W];
            assign ready  = 1'b1;

            // ---- valid (the only reset registers) and sideband, LATENCY stages ----------------
            fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY)) u_valid (
                .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
                .out_valid(out_valid), .out_data(out_user)
            );
        end else begin : g_iterative
            // One register holds the sample: step k while micro-rotation k is applied (k = 0 after
            // the clock enable that takes the sample, which loads it pre-rotated). The last one's
            // result goes to a register of its own (the output register's input, as the last
            // pipeline stage), so the same clock enable loads the next sample: one micro-rotation
            // every clock enable, a sample every STAGES. Same LATENCY as the pipeline. The step is
            // one-hot, so the shifts are AND-OR selections (fewer logic levels than a barrel shifter
            // on the loop x/y -> shift -> add -> x/y), and the angle ATAN[k] is a register of its
            // own, chosen a clock enable ahead (off the loop).
            reg                    busy;
            reg [STAGES-1:0]       step;     // step[k]: micro-rotation k this clock enable
            reg signed [DP_W-1:0]  xr, yr, x_done;
            reg [ACC_W-1:0]        zr, z_done;
            reg [USER_W-1:0]       user_r, user_done, user_o;
            reg                    valid_done, valid_o;

            // the angle table, ATAN[k] at [k*ACC_W +: ACC_W]
            wire [STAGES*ACC_W-1:0] atan_all;
            for (k = 0; k < STAGES; k = k + 1) begin : g_atan
                localparam [63:0] ATAN_FULL = (atan62(k) + (64'd1 << (61 - ACC_W))) >> (62 - ACC_W);
                assign atan_all[k*ACC_W +: ACC_W] = ATAN_FULL[ACC_W-1:0];
            end

            wire                    last = busy && step[STAGES-1];
            wire                    take = in_valid && (!busy || last);
            wire                    neg  = yr[DP_W-1];  // y < 0: rotate counter-clockwise
            reg  [ACC_W-1:0]        atan_k;             // ATAN[k] for the step k: registered with it
            integer i;

            // y >>> k and x >>> k for the one k with step[k] = 1, as an AND-OR tree in fixed levels:
            // a pair of steps per LUT, up to four pairs per group, then the groups' OR with the
            // add/subtract select. The kept wires stop the mapper from sharing the loop's logic
            // across x and y and across bits, which made the loop 7 LUTs deep on the iCE40.
            localparam integer PAIRS  = (STAGES + 1) / 2;
            localparam integer GROUPS = (PAIRS + 3) / 4;
            (* keep *) wire [PAIRS*DP_W-1:0]  x_pair, y_pair;
            (* keep *) wire [GROUPS*DP_W-1:0] x_group, y_group;
            for (k = 0; k < PAIRS; k = k + 1) begin : g_pair
                wire signed [DP_W-1:0] x_a = xr >>> (2 * k);
                wire signed [DP_W-1:0] y_a = yr >>> (2 * k);
                if (2 * k + 1 < STAGES) begin : g_two
                    wire signed [DP_W-1:0] x_b = xr >>> (2 * k + 1);
                    wire signed [DP_W-1:0] y_b = yr >>> (2 * k + 1);
                    assign x_pair[k*DP_W +: DP_W] = (x_a & {DP_W{step[2*k]}}) | (x_b & {DP_W{step[2*k+1]}});
                    assign y_pair[k*DP_W +: DP_W] = (y_a & {DP_W{step[2*k]}}) | (y_b & {DP_W{step[2*k+1]}});
                end else begin : g_one
                    assign x_pair[k*DP_W +: DP_W] = x_a & {DP_W{step[2*k]}};
                    assign y_pair[k*DP_W +: DP_W] = y_a & {DP_W{step[2*k]}};
                end
            end
            for (k = 0; k < GROUPS; k = k + 1) begin : g_group
                reg [DP_W-1:0] x_or, y_or;
                integer j;
                always @(*) begin
                    x_or = {DP_W{1'b0}};
                    y_or = {DP_W{1'b0}};
                    for (j = 4 * k; j < 4 * k + 4 && j < PAIRS; j = j + 1) begin
                        x_or = x_or | x_pair[j*DP_W +: DP_W];
                        y_or = y_or | y_pair[j*DP_W +: DP_W];
                    end
                end
                assign x_group[k*DP_W +: DP_W] = x_or;
                assign y_group[k*DP_W +: DP_W] = y_or;
            end
            reg [DP_W-1:0] xsh, ysh;
            always @(*) begin
                xsh = {DP_W{1'b0}};
                ysh = {DP_W{1'b0}};
                for (i = 0; i < GROUPS; i = i + 1) begin
                    xsh = xsh | x_group[i*DP_W +: DP_W];
                    ysh = ysh | y_group[i*DP_W +: DP_W];
                end
            end

            // the micro-rotation as in the pipeline, each value one adder whose carry-in is the
            // subtraction's +1: {a, 1} + {b, c} = 2 (a + b + c) + 1, so the top bits are a + b + c
            wire [DP_W:0]  x_sum = {xr, 1'b1} + {ysh ^ {DP_W{neg}}, neg};
            wire [DP_W:0]  y_sum = {yr, 1'b1} + {xsh ^ {DP_W{~neg}}, ~neg};
            wire [ACC_W:0] z_sum = {zr, 1'b1} + {atan_k ^ {ACC_W{neg}}, neg};
            wire signed [DP_W-1:0]  x_next = x_sum[DP_W:1];
            wire signed [DP_W-1:0]  y_next = y_sum[DP_W:1];
            wire        [ACC_W-1:0] z_next = z_sum[ACC_W:1];
            wire unused_carry_in = &{1'b0, x_sum[0], y_sum[0], z_sum[0]};

            // ATAN[k+1] for the step k (0 after the last: never used)
            reg [ACC_W-1:0] atan_next;
            integer n;
            always @(*) begin
                atan_next = {ACC_W{1'b0}};
                for (n = 0; n + 1 < STAGES; n = n + 1)
                    atan_next = atan_next | (atan_all[(n+1)*ACC_W +: ACC_W] & {ACC_W{step[n]}});
            end

            assign ready = !busy || last;

            always @(posedge clk) begin
                if (ce) begin
                    busy       <= take || (busy && !last);
                    valid_done <= last;
                    valid_o    <= valid_done;
                    if (take) begin
                        xr     <= x_abs <<< GUARD;
                        yr     <= y_pre <<< GUARD;
                        zr     <= x_neg ? HALF_TURN : {ACC_W{1'b0}};
                        step   <= {{(STAGES-1){1'b0}}, 1'b1};
                        atan_k <= atan_all[0 +: ACC_W];
                        user_r <= in_user;
                    end else if (busy) begin
                        xr     <= x_next;
                        yr     <= y_next;
                        zr     <= z_next;
                        step   <= step << 1;
                        atan_k <= atan_next;
                    end
                    x_done    <= x_next;    // read only after the last micro-rotation
                    z_done    <= z_next;
                    user_done <= user_r;
                    user_o    <= user_done; // with the output registers below
                end
                if (rst) begin          // the control only, after the step: rst wins over ce
                    busy       <= 1'b0;
                    valid_done <= 1'b0;
                    valid_o    <= 1'b0;
                end
            end

            assign x_last    = x_done;
            assign z_last    = z_done;
            assign out_valid = valid_o;
            assign out_user  = user_o;
        end
    endgenerate

    // ---- stage STAGES+2: output rounding --------------------------------------------------------
    wire signed [DP_W-1:0]  x_rnd;
    wire        [ACC_W-1:0] z_rnd;

    generate
        if (GUARD > 0) begin : g_round
            assign x_rnd = x_last + ({{(DP_W-1){1'b0}}, 1'b1} << (GUARD - 1));
            assign z_rnd = z_last + ({{(ACC_W-1){1'b0}}, 1'b1} << (GUARD - 1));
            // The GUARD low bits are dropped by the rounding.
            wire unused_low = &{1'b0, x_rnd[GUARD-1:0], z_rnd[GUARD-1:0]};
        end else begin : g_no_round
            assign x_rnd = x_last;
            assign z_rnd = z_last;
        end
    endgenerate

    always @(posedge clk) begin
        if (ce) begin
            phase <= z_rnd[ACC_W-1:GUARD];
            mag   <= x_rnd[IN_W+GUARD:GUARD];
        end
    end

    // x >= 0 after the pre-rotation and only grows, below 1.17 * 2^(IN_W+GUARD): its sign bit is 0.
    wire unused_sign = &{1'b0, x_rnd[DP_W-1]};

endmodule

`default_nettype wire
