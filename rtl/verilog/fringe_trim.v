// fringe_trim: closed-loop angle trim: an error map over (direction, sector of the revolution,
// fine phase) and two fine-phase-dependent gains (speed, magnitude) give a correction
// subtracted from the position.
//
// LATENCY = 13 clock enables, one sample per clock; ce = 0 freezes
// every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_trim.md.
// Bit-exact model: model/fringe/fixed/trim.py.

`default_nettype none

module fringe_trim #(
    parameter integer LINES      = 256,    // signal periods per revolution, 1..2^20; POS_W = FINE_W + clog2(LINES) <= 31
    parameter integer FINE_W     = 16,     // fine phase bits per period, 8..30
    parameter integer AMP_W      = 12,     // magnitude width, 4..32
    parameter integer SPEED_LOG2 = 5,      // speed window 2^SPEED_LOG2 samples, 0..8
    parameter integer MAP_PSI_W  = 4,      // 2^MAP_PSI_W map sectors per revolution, 0..8
    parameter integer MAP_PHI_W  = 6,      // 2^MAP_PHI_W bins per signal period, 2..min(10, FINE_W-1)
    parameter integer TRIM_W     = 18,     // width of table values and slopes, 8..24
    parameter integer TRIM_FRAC  = 4,      // fraction bits of map values and of the sum (fine counts), 0..16
    parameter integer G_SHIFT    = 20,     // right shift of the gain products into the sum, 1..48
    parameter [63:0]  SECT_RECIP = 64'd1,  // sector multiplier, from sector_mapping() (checked; unused if MAP_PSI_W = 0)
    parameter integer SECT_SHIFT = 20,     // sector shift, 0..127, from sector_mapping() (checked; unused if MAP_PSI_W = 0)
    parameter integer START_SPEED = 0,     // the first sample's speed after reset (no window yet), -REV/2..REV/2-1
    parameter integer MAG_SMOOTH_LOG2 = 0, // the magnitude terms take mag's running average over ~2^K samples, 0 (off)..12
    parameter         MAP_INIT   = "",     // $readmemh image of the map, 2 banks x 2^(1+MAP_PSI_W+MAP_PHI_W) words; "" = zeros
    parameter         SPEED_INIT = "",     // $readmemh image of the speed table, 2 banks x 2^MAP_PHI_W words; "" = zeros
    parameter         AMP_INIT   = "",     // $readmemh image of the amp table, 2 banks x 2^MAP_PHI_W words; "" = zeros
    parameter integer USER_W     = 1       // sideband width, >= 1
) (
    input  wire                                  clk,
    input  wire                                  rst,       // synchronous, active high: clears valid and the fill counter
    input  wire                                  ce,        // clock enable: the pipeline advances when 1
    // sample in
    input  wire                                  in_valid,
    input  wire [FINE_W+$clog2(LINES)-1:0]       pos,       // u(POS_W), in [0, REV)
    input  wire [AMP_W-1:0]                      mag,       // u(AMP_W)
    input  wire                                  bank,      // table bank of this sample
    input  wire [USER_W-1:0]                     in_user,
    // table write port (software side), independent of ce
    input  wire                                  wr_en,
    input  wire [1:0]                            wr_sel,    // 0 map, 1 speed table, 2 amp table, 3 ignored
    input  wire [MAP_PSI_W+MAP_PHI_W+1:0]        wr_addr,   // {bank, dir, sector, bin} (small tables: {bank, .., bin})
    input  wire [2*TRIM_W-1:0]                   wr_data,   // {slope, value}
    // position out
    output wire                                  out_valid,
    output reg  [FINE_W+$clog2(LINES)-1:0]       pos_out,   // u(POS_W), in [0, REV)
    output reg                                   dir,       // 1: moving backwards (speed < 0)
    output reg                                   sat,       // the trim was clipped
    output wire [USER_W-1:0]                     out_user
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY = TRIM_LATENCY;
    localparam integer POS_W   = FINE_W + $clog2(LINES);      // clog2(REV)
    localparam [63:0]  LINES64 = LINES * 64'd1;
    localparam [63:0]  REV64   = LINES64 << FINE_W;           // < 2^31 when legal
    localparam [63:0]  HALF_E  = REV64 >> 1;
    localparam integer HALF_I  = HALF_E[31:0];                // REV/2, the speed's range (< 2^31 when legal)

    // ---- parameter checks -------------------------------------------------------------------------
    // the index mapping is exact for every position (check_sector_mapping in the model)
    localparam           MAP_OK  = fringe_mapping_exact(SECT_RECIP, SECT_SHIFT, MAP_PSI_W, LINES, FINE_W);
    localparam integer   PHI_MAX = (FINE_W - 1 < 10) ? FINE_W - 1 : 10;

    generate
        `FRINGE_CHECK_POSITION("fringe_trim", FINE_W, LINES, 31)
        `FRINGE_CHECK_RANGE(g_bad_amp_w, "fringe_trim", "AMP_W", AMP_W, 4, 32)
        `FRINGE_CHECK_RANGE(g_bad_speed_log2, "fringe_trim", "SPEED_LOG2", SPEED_LOG2, 0, 8)
        `FRINGE_CHECK_RANGE(g_bad_psi_w, "fringe_trim", "MAP_PSI_W", MAP_PSI_W, 0, 8)
        if (MAP_PHI_W < 2 || MAP_PHI_W > PHI_MAX) begin : g_bad_phi_w
            $error("fringe_trim: MAP_PHI_W = %0d out of range 2..min(10, FINE_W-1) = %0d (instance %m)",
                   MAP_PHI_W, PHI_MAX);
        end
        `FRINGE_CHECK_RANGE(g_bad_trim_w, "fringe_trim", "TRIM_W", TRIM_W, 8, 24)
        `FRINGE_CHECK_RANGE(g_bad_trim_frac, "fringe_trim", "TRIM_FRAC", TRIM_FRAC, 0, 16)
        `FRINGE_CHECK_RANGE(g_bad_g_shift, "fringe_trim", "G_SHIFT", G_SHIFT, 1, 48)
        `FRINGE_CHECK_RANGE(g_bad_mag_smooth, "fringe_trim", "MAG_SMOOTH_LOG2", MAG_SMOOTH_LOG2, 0, 12)
        if (FINE_W + $clog2(LINES) <= 31 && (START_SPEED < -HALF_I || START_SPEED > HALF_I - 1)) begin : g_bad_start_speed
            $error("fringe_trim: START_SPEED = %0d out of range -REV/2..REV/2-1 = %0d..%0d (instance %m)",
                   START_SPEED, -HALF_I, HALF_I - 1);
        end
        if (MAP_PSI_W > 0) begin : g_check_map
            if (SECT_SHIFT < 0 || SECT_SHIFT > 127) begin : g_bad_shift
                $error("fringe_trim: SECT_SHIFT = %0d out of range 0..127 (instance %m)", SECT_SHIFT);
            end else if (!MAP_OK) begin : g_bad_map
                $error("fringe_trim: SECT_RECIP = %0d, SECT_SHIFT = %0d do not map every position to floor(pos * 2^MAP_PSI_W / REV); take them from sector_mapping() (instance %m)",
                       SECT_RECIP, SECT_SHIFT);
            end
        end
        `FRINGE_CHECK_MIN(g_bad_user_w, "fringe_trim", "USER_W", USER_W, 1)
    endgenerate

    // ---- widths ------------------------------------------------------------------------------------
    localparam integer N       = 1 << SPEED_LOG2;              // speed window
    localparam integer FB      = FINE_W - MAP_PHI_W;           // fraction bits within a bin, >= 1
    localparam integer MA_W    = 1 + MAP_PSI_W + MAP_PHI_W;    // map word address in a bank: {dir, sector, bin}
    localparam integer PSI_R   = (MAP_PSI_W > 0) ? MAP_PSI_W : 1;   // sector register width
    localparam integer TW      = TRIM_W;
    localparam integer GW      = TW + 1;                       // gs, ga: value + interpolated step, s(TW+1)
    localparam integer P1_W    = POS_W + GW;                   // speed x gs, s(POS_W) x s(TW+1)
    localparam integer P2_W0   = AMP_W + GW;                   // mag x ga, u(AMP_W) x s(TW+1)
    localparam integer P2_W    = ((P2_W0 > G_SHIFT) ? P2_W0 : G_SHIFT) + 1;   // + 2^(G_SHIFT-1)
    localparam integer S_W     = ((P1_W > P2_W) ? P1_W : P2_W) + 1;           // their sum
    localparam integer SS_W    = S_W - G_SHIFT;                // the sum >>> G_SHIFT
    localparam integer VR_W    = ((TW > TRIM_FRAC) ? TW : TRIM_FRAC) + 2;     // value + 2^(TRIM_FRAC-1)
    localparam integer MR_W    = VR_W + 1;                     // + the interpolated step
    localparam integer TT_W    = ((MR_W > SS_W) ? MR_W : SS_W) + 1;           // total (+ 2^(TRIM_FRAC-1))
    localparam integer C_W     = TT_W - TRIM_FRAC;             // corr before clipping
    localparam integer CX_W    = ((C_W > FINE_W) ? C_W : FINE_W) + 1;         // corr, sign-extended
    localparam integer WW      = POS_W + 2;                    // signed positions
    localparam integer RECIP_W = (SECT_RECIP > 64'd1) ? $clog2(SECT_RECIP + 64'd1) : 1;
    localparam integer T_W0    = POS_W + RECIP_W;
    localparam integer T_W     = (T_W0 > SECT_SHIFT + PSI_R) ? T_W0 : SECT_SHIFT + PSI_R;   // sector product
    localparam [255:0]   RECIP_X = {192'd0, SECT_RECIP};
    localparam [T_W-1:0] RECIP_T = RECIP_X[T_W-1:0];
    localparam [WW-1:0]  REV_W   = REV64[WW-1:0];
    localparam [SPEED_LOG2:0] N_HA = N[SPEED_LOG2:0];         // N as a history address (bit SPEED_LOG2)
    localparam integer SC_W    = POS_W + SPEED_LOG2;           // the speed scaled from a start-up window
    localparam integer SX_W    = SC_W + 1;                     // and -+ REV/2 beside it
    localparam [63:0]  HALF64  = REV64 >> 1;
    localparam [SX_W-1:0]  HALF_X  = HALF64[SX_W-1:0];
    localparam [63:0]  SAT_HI64 = HALF64 - 64'd1;              // REV/2 - 1
    localparam [63:0]  SAT_LO64 = 64'd0 - HALF64;              // -REV/2
    localparam [POS_W-1:0] SAT_HI = SAT_HI64[POS_W-1:0];
    localparam [POS_W-1:0] SAT_LO = SAT_LO64[POS_W-1:0];
    localparam [31:0]      START_32 = START_SPEED;
    localparam [POS_W-1:0] START_P  = START_32[POS_W-1:0];    // START_SPEED in s(POS_W)
    localparam integer MAP_PIECE_W = 11;                       // map RAM pieces of 2048 words (u_map)

    // ---- valid (the only reset registers) and sideband, LATENCY stages --------------------------
    fringe_delay #(.WIDTH(USER_W), .DEPTH(LATENCY)) u_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(in_valid), .in_data(in_user),
        .out_valid(out_valid), .out_data(out_user)
    );

    // ---- speed history: 2N words, written at wp, read at wp - win (win accepted samples earlier): -----
    // win = N (wp ^ N) once N samples came since the reset, before that the longest power-of-two window
    // there is, 2^floor(log2(fill)) (1, 2, 4, ...: a stream that starts in motion has a speed from its
    // second sample on), START_SPEED for the first sample (no window)
    wire accept = ce & in_valid & ~rst;
    reg  [SPEED_LOG2:0] wp;            // write pointer: any start value works (no reset)
    reg  [SPEED_LOG2:0] fill;          // accepted samples since reset, saturating at N (bit SPEED_LOG2)
    reg  [SPEED_LOG2:0] win;           // the window, one-hot (the top bit of fill), 0 when fill = 0
    integer j;

    always @* begin
        win = {(SPEED_LOG2+1){1'b0}};
        for (j = 0; j <= SPEED_LOG2; j = j + 1) begin
            if (fill[j]) begin
                win    = {(SPEED_LOG2+1){1'b0}};
                win[j] = 1'b1;
            end
        end
    end

    // the first sample reads N back (its speed is START_SPEED): never the word being written
    wire [SPEED_LOG2:0] back = (fill == {(SPEED_LOG2+1){1'b0}}) ? N_HA : win;
`ifdef FRINGE_TECH_ECP5
    // ECP5: the RAM's read register and s2_old in one DP16KD (its output register)
    wire [POS_W-1:0]    s2_old_ram;

    fringe_ram_ecp5 #(.AW(SPEED_LOG2 + 1), .DW(POS_W)) u_hist (
        .clk(clk),
        .wr_en(accept), .wr_addr(wp), .wr_data(pos),
        .ce(ce), .rd_addr(wp - back), .rd_data(s2_old_ram)
    );

    always @(posedge clk) begin
        if (accept) begin
            wp <= wp + 1'b1;
        end
    end
`else
    (* no_rw_check *)
    reg  [POS_W-1:0]    hist [0:2*N-1];
    reg  [POS_W-1:0]    hist_q;        // the RAM's read register
    integer i;

    initial begin
        for (i = 0; i < 2 * N; i = i + 1) begin
            hist[i] = {POS_W{1'b0}};
        end
    end

    always @(posedge clk) begin
        if (accept) begin
            hist[wp] <= pos;
            wp       <= wp + 1'b1;
        end
    end

    always @(posedge clk) begin
        if (ce) begin
            hist_q <= hist[wp - back];
        end
    end
`endif

    always @(posedge clk) begin
        if (rst) begin
            fill <= {(SPEED_LOG2+1){1'b0}};
        end else if (accept && !fill[SPEED_LOG2]) begin
            fill <= fill + 1'b1;
        end
    end

    // ---- the magnitude the terms take: mag itself, or its running average (MAG_SMOOTH_LOG2 = K > 0):
    // acc = mag << K at the first sample since reset, then acc + mag - (acc >> K); avg = acc >> K. acc
    // stays in u(AMP_W + K) (model: trim.magnitudes). A one-sample recursion: it cannot be pipelined. ----
    wire [AMP_W-1:0] avg;

    generate
        if (MAG_SMOOTH_LOG2 > 0) begin : g_mag_avg
            localparam integer K = MAG_SMOOTH_LOG2;
            reg  [AMP_W+K-1:0] acc;
            reg                acc_started;   // a sample came since reset
            wire [AMP_W+K-1:0] mag_x    = {{K{1'b0}}, mag};
            wire [AMP_W+K-1:0] acc_next = acc_started ? acc + mag_x - (acc >> K) : mag_x << K;

            always @(posedge clk) begin
                if (rst) begin
                    acc_started <= 1'b0;
                end else if (accept) begin
                    acc_started <= 1'b1;
                end
            end

            always @(posedge clk) begin
                if (accept) begin
                    acc <= acc_next;
                end
            end

            assign avg = acc_next[AMP_W+K-1:K];
        end else begin : g_mag_direct
            assign avg = mag;
        end
    endgenerate

    // ---- 1: input registers ---------------------------------------------------------------------------
    reg  [POS_W-1:0] s1_pos;
    reg  [AMP_W-1:0] s1_mag;
    reg              s1_bank;
    reg  [SPEED_LOG2:0] s1_win;

    always @(posedge clk) begin
        if (ce) begin
            s1_pos  <= pos;
            s1_mag  <= avg;
            s1_bank <= bank;
            s1_win  <= win;
        end
    end

    // ---- 2: history output register; sector product -----------------------------------------------
    reg  [POS_W-1:0] s2_pos;
`ifdef FRINGE_TECH_ECP5
    wire [POS_W-1:0] s2_old = s2_old_ram;
`else
    reg  [POS_W-1:0] s2_old;
`endif
    reg  [AMP_W-1:0] s2_mag;
    reg              s2_bank;
    reg  [SPEED_LOG2:0] s2_win;
    reg  [PSI_R-1:0] s2_sector;

    generate
        if (MAP_PSI_W > 0) begin : g_sector
            wire [T_W-1:0] t = {{(T_W-POS_W){1'b0}}, s1_pos} * RECIP_T;
            always @(posedge clk) begin
                if (ce) begin
                    s2_sector <= t[SECT_SHIFT +: PSI_R];
                end
            end
            wire unused_t = &{1'b0, t};
        end else begin : g_no_sector
            always @(posedge clk) begin
                if (ce) begin
                    s2_sector <= 1'b0;
                end
            end
        end
    endgenerate

    always @(posedge clk) begin
        if (ce) begin
            s2_pos  <= s1_pos;
`ifndef FRINGE_TECH_ECP5
            s2_old  <= hist_q;
`endif
            s2_mag  <= s1_mag;
            s2_bank <= s1_bank;
            s2_win  <= s1_win;
        end
    end

    // ---- 3..6: pos - old; gs, ga = value + ((slope * frac + 2^(FB-1)) >>> FB) at {bank, bin} ---------
    wire [MAP_PHI_W-1:0] s2_bin = s2_pos[FINE_W-1:FB];
    wire wr_small = (wr_addr[MA_W-1:MAP_PHI_W] == {(MA_W-MAP_PHI_W){1'b0}});
    wire [MAP_PHI_W:0] wr_addr_small = {wr_addr[MA_W], wr_addr[MAP_PHI_W-1:0]};
    wire signed [GW-1:0] s6_gs, s6_ga;

    fringe_interp_table #(
        .ADDR_W(MAP_PHI_W), .W(TW), .FB(FB), .OUT_W(GW), .ROUND_SHIFT(0), .INIT_FILE(SPEED_INIT)
    ) u_speed (
        .clk(clk), .ce(ce),
        .wr_en(wr_en && wr_sel == 2'd1 && wr_small), .wr_addr(wr_addr_small), .wr_data(wr_data),
        .rd_addr({s2_bank, s2_bin}), .frac(s2_pos[FB-1:0]), .result(s6_gs)
    );

    fringe_interp_table #(
        .ADDR_W(MAP_PHI_W), .W(TW), .FB(FB), .OUT_W(GW), .ROUND_SHIFT(0), .INIT_FILE(AMP_INIT)
    ) u_amp (
        .clk(clk), .ce(ce),
        .wr_en(wr_en && wr_sel == 2'd2 && wr_small), .wr_addr(wr_addr_small), .wr_data(wr_data),
        .rd_addr({s2_bank, s2_bin}), .frac(s2_pos[FB-1:0]), .result(s6_ga)
    );

    reg  signed [POS_W:0] s3_d;        // pos - old, in (-REV, REV)
    reg  [POS_W-1:0]      s3_pos;
    reg  [AMP_W-1:0]      s3_mag;
    reg                   s3_bank;
    reg  [SPEED_LOG2:0]   s3_win;
    reg  [PSI_R-1:0]      s3_sector;

    always @(posedge clk) begin
        if (ce) begin
            s3_d      <= $signed({1'b0, s2_pos}) - $signed({1'b0, s2_old});
            s3_pos    <= s2_pos;
            s3_mag    <= s2_mag;
            s3_bank   <= s2_bank;
            s3_win    <= s2_win;
            s3_sector <= s2_sector;
        end
    end

    // ---- 4: speed wrapped into [-REV/2, REV/2), dir; the first sample since reset (no window yet) takes
    // START_SPEED as if measured over N samples (the generator's guess: the calibration's mean speed) ----
    // 2d >= REV <=> d - REV/2 >= 0;  2d < -REV <=> d + REV/2 < 0 (REV is even); the candidates in parallel.
    wire signed [WW-1:0] d_x    = {s3_d[POS_W], s3_d};
    wire signed [WW-1:0] d_hi   = d_x - $signed(REV_W >> 1);
    wire signed [WW-1:0] d_lo   = d_x + $signed(REV_W >> 1);
    wire signed [WW-1:0] d_dn   = d_x - $signed(REV_W);
    wire signed [WW-1:0] d_up   = d_x + $signed(REV_W);
    wire signed [WW-1:0] d_wrap = !d_hi[WW-1] ? d_dn : (d_lo[WW-1] ? d_up : d_x);
    wire signed [POS_W-1:0] speed4 = (|s3_win) ? d_wrap[POS_W-1:0] : START_P;
    reg  signed [POS_W-1:0] s4_speed;
    reg  [SPEED_LOG2:0]   s4_win;
    reg                   s4_dir;
    reg  [POS_W-1:0]      s4_pos;
    reg  [AMP_W-1:0]      s4_mag;
    reg                   s4_bank;
    reg  [PSI_R-1:0]      s4_sector;

    always @(posedge clk) begin
        if (ce) begin
            s4_speed  <= speed4;
            s4_dir    <= speed4[POS_W-1];   // the scaling and saturation below keep the sign
            s4_win    <= (|s3_win) ? s3_win : N_HA;
            s4_pos    <= s3_pos;
            s4_mag    <= s3_mag;
            s4_bank   <= s3_bank;
            s4_sector <= s3_sector;
        end
    end

    // ---- 5..9: map at {bank, dir, sector, bin}: m + 2^(TRIM_FRAC-1) = value + 2^(TRIM_FRAC-1)
    // + ((slope * frac + 2^(FB-1)) >>> FB). The map is deep (8192 words for the seed): it lies in RAM
    // pieces of 2^MAP_PIECE_W words, each registered before the registered select (fringe_interp_table
    // PIECE_W), so no read multiplexer follows a block RAM's clock-to-out. 2048 words of 2 TRIM_W bits
    // are 2 TRIM_W / 9 ECP5 DP16KD in their 2048 x 9 mode, the one Yosys picks for the seed's map. ----
    wire [MAP_PHI_W-1:0] s4_bin  = s4_pos[FINE_W-1:FB];
    wire [MA_W:0]        map_rd_addr;
    wire signed [MR_W-1:0] s9_m;

    generate
        if (MAP_PSI_W > 0) begin : g_addr_sector
            assign map_rd_addr = {s4_bank, s4_dir, s4_sector, s4_bin};
        end else begin : g_addr_no_sector
            assign map_rd_addr = {s4_bank, s4_dir, s4_bin};
            wire unused_sector = &{1'b0, s4_sector};
        end
    endgenerate

    fringe_interp_table #(
        .ADDR_W(MA_W), .W(TW), .FB(FB), .OUT_W(MR_W), .ROUND_SHIFT(TRIM_FRAC), .INIT_FILE(MAP_INIT),
        .PIECE_W(MAP_PIECE_W)
    ) u_map (
        .clk(clk), .ce(ce),
        .wr_en(wr_en && wr_sel == 2'd0), .wr_addr(wr_addr), .wr_data(wr_data),
        .rd_addr(map_rd_addr), .frac(s4_pos[FB-1:0]), .result(s9_m)
    );

    // 5, 6: the speed scaled to N samples and saturated beside the tables (a stage each, so the wrap's
    // carry chain gets nothing added); 5, 6: magnitude carried; 5..11: direction and position
    // 5: speed * 2^(SPEED_LOG2 - k) for win = 2^k (N: unchanged), a one-hot select of shifts
    wire signed [SC_W-1:0] speed_x = {{(SPEED_LOG2+1){s4_speed[POS_W-1]}}, s4_speed[POS_W-2:0]};
    reg  signed [SC_W-1:0] scaled5;
    reg  signed [SC_W-1:0] s5_scaled;

    always @* begin
        scaled5 = {SC_W{1'b0}};
        for (j = 0; j <= SPEED_LOG2; j = j + 1) begin
            scaled5 = scaled5 | ({SC_W{s4_win[j]}} & (speed_x <<< (SPEED_LOG2 - j)));
        end
    end

    always @(posedge clk) begin
        if (ce) begin
            s5_scaled <= scaled5;
        end
    end

    // 6: saturated to [-REV/2, REV/2 - 1]: scaled - REV/2 >= 0 above, scaled + REV/2 < 0 below (the
    // compares in parallel, SX_W bits: shorter than the sum's A_W >= POS_W + TRIM_W + 3)
    wire signed [SX_W-1:0] sc_x  = {s5_scaled[SC_W-1], s5_scaled};
    wire signed [SX_W-1:0] sc_hi = sc_x - $signed(HALF_X);
    wire signed [SX_W-1:0] sc_lo = sc_x + $signed(HALF_X);
    reg  signed [POS_W-1:0] s6_speed;

    always @(posedge clk) begin
        if (ce) begin
            s6_speed <= !sc_hi[SX_W-1] ? SAT_HI : (sc_lo[SX_W-1] ? SAT_LO : sc_x[POS_W-1:0]);
        end
    end

    wire [AMP_W-1:0]        s6_mag;
    wire                    s11_dir;
    wire [POS_W-1:0]        s11_pos;
    wire                    s6_carry_valid, s11_carry_valid;

    fringe_delay #(.WIDTH(AMP_W), .DEPTH(2)) u_gain_carry (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(1'b0), .in_data(s4_mag),
        .out_valid(s6_carry_valid), .out_data(s6_mag)
    );

    fringe_delay #(.WIDTH(1 + POS_W), .DEPTH(7)) u_pos_carry (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(1'b0), .in_data({s4_dir, s4_pos}),
        .out_valid(s11_carry_valid), .out_data({s11_dir, s11_pos})
    );

    // ---- 7..10: speed x gs (4 stages: products, pairs, product, a register) and mag x ga (3 stages:
    // products, product, a register) in 18x18 partial products (fringe_split_mul); every stage one
    // two-input carry chain for the seed widths; each product ends a clock enable after it is formed
    // (it crosses the chip to the sum)
    wire [POS_W+GW-1:0] p_sg;
    wire [AMP_W+GW-1:0] p_ma;

    fringe_split_mul #(.A_W(POS_W), .A_SIGNED(1), .B_W(GW), .B_SIGNED(1), .LATENCY(4)) u_speed_gain (
        .clk(clk), .ce(ce), .a(s6_speed), .b(s6_gs), .p(p_sg)
    );

    fringe_split_mul #(.A_W(AMP_W), .A_SIGNED(0), .B_W(GW), .B_SIGNED(1), .LATENCY(3)) u_amp_gain (
        .clk(clk), .ce(ce), .a(s6_mag), .b(s6_ga), .p(p_ma)
    );

    // ---- 10: mag x ga + (m + 2^(TRIM_FRAC-1)) * 2^G_SHIFT + 2^(G_SHIFT-1) (bit fields) -------------
    // From here on the sum A = (m + 2^(TRIM_FRAC-1)) * 2^G_SHIFT + 2^(G_SHIFT-1) + speed * gs + mag * ga
    // is formed, A >>> G_SHIFT = total + 2^(TRIM_FRAC-1) (m * 2^G_SHIFT has no bits below G_SHIFT):
    // A = total' * 2^G_SHIFT + r, 0 <= r < 2^G_SHIFT, fits s(TT_W + G_SHIFT); every adder works modulo
    // 2^A_W, so partial sums may wrap, the final one is exact. Terms in E_W bits (wider than any).
    localparam integer A_W  = TT_W + G_SHIFT;
    localparam integer E_W  = A_W + 64;
    localparam [E_W-1:0] ONE_E = {{(E_W-1){1'b0}}, 1'b1};
    wire [E_W-1:0] t_sg = {{(E_W-POS_W-GW){p_sg[POS_W+GW-1]}}, p_sg};
    wire [E_W-1:0] t_ma = {{(E_W-AMP_W-GW){p_ma[AMP_W+GW-1]}}, p_ma};
    wire [E_W-1:0] t_m  = ({{(E_W-MR_W){s9_m[MR_W-1]}}, s9_m} << G_SHIFT) | (ONE_E << (G_SHIFT - 1));
    reg  [A_W-1:0]         s10_am;

    always @(posedge clk) begin
        if (ce) begin
            s10_am <= t_ma[A_W-1:0] + t_m[A_W-1:0];
        end
    end

    // ---- 11: A; A >>> G_SHIFT = total + 2^(TRIM_FRAC-1) ---------------------------------------------
    reg  [A_W-1:0]         s11_a;

    always @(posedge clk) begin
        if (ce) begin
            s11_a <= t_sg[A_W-1:0] + s10_am;
        end
    end

    // ---- 12: corr = total >>> TRIM_FRAC, clipped to s(FINE_W); pos -+ REV for stage 13 -------------
    wire signed [C_W-1:0]  corr  = s11_a[A_W-1:G_SHIFT+TRIM_FRAC];
    wire signed [CX_W-1:0] corr_x = {{(CX_W-C_W){corr[C_W-1]}}, corr};
    wire                   neg   = corr_x[CX_W-1];
    // in range <=> bits CX_W-1 .. FINE_W-1 all equal the sign
    wire                   over  = neg ? ~&corr_x[CX_W-1:FINE_W-1] : |corr_x[CX_W-1:FINE_W-1];
    wire [FINE_W-1:0]      clip  = neg ? {1'b1, {(FINE_W-1){1'b0}}} : {1'b0, {(FINE_W-1){1'b1}}};
    wire [WW-1:0]          pos_x = {2'b00, s11_pos};
    reg  [FINE_W-1:0]      s12_corr;
    reg                    s12_sat, s12_dir, s12_neg;
    reg  [WW-1:0]          s12_pos, s12_alt;

    always @(posedge clk) begin
        if (ce) begin
            s12_corr <= over ? clip : corr_x[FINE_W-1:0];
            s12_sat  <= over;
            s12_neg  <= neg;
            s12_dir  <= s11_dir;
            s12_pos  <= pos_x;
            // corr < 0: pos - corr may reach REV, alternative pos - REV - corr;
            // corr >= 0: pos - corr may fall below 0, alternative pos + REV - corr
            s12_alt  <= neg ? pos_x - REV_W : pos_x + REV_W;
        end
    end

    // ---- 13: pos - corr, wrapped into [0, REV) ------------------------------------------------------
    wire [WW-1:0] corr_w = {{(WW-FINE_W){s12_corr[FINE_W-1]}}, s12_corr};
    wire [WW-1:0] a      = s12_pos - corr_w;
    wire [WW-1:0] b      = s12_alt - corr_w;
    wire          use_b  = s12_neg ? ~b[WW-1] : a[WW-1];
    wire [WW-1:0] o      = use_b ? b : a;

    always @(posedge clk) begin
        if (ce) begin
            pos_out <= o[POS_W-1:0];
            dir     <= s12_dir;
            sat     <= s12_sat;
        end
    end

    // Bits that carry nothing: the products' rounded-off bits and sign extension, the terms beyond
    // A_W bits, the fraction bits of A, the sign bits of the wrapped speed and of positions in [0, REV),
    // the saturation's compares but their signs and the scaled speed above POS_W bits (the compares
    // read them), the valid outputs of the delays that carry data only.
    wire unused = &{1'b0, t_sg, t_ma, t_m, s6_carry_valid, s11_carry_valid,
                    s11_a[G_SHIFT+TRIM_FRAC:0], d_wrap[WW-1:POS_W], o[WW-1:POS_W], corr_x,
                    sc_x[SX_W-1:POS_W], sc_hi[SX_W-2:0], sc_lo[SX_W-2:0]};

endmodule

`default_nettype wire
