// fringe_drift_observer: the back half of the drift tracker (docs/drift.md): from each sample's fine
// phase and normalised codes, block sums of the error against the calibrated waveform, and per block the
// tracker's next state (offset and inverse gain steps at the gear), held as the pending update until
// fringe_drift_normaliser takes it.
//
// LATENCY = 16 clock enables (obs_valid of a block's last sample to its resolved update), one sample per
// clock; ce = 0 freezes every register, rst (synchronous, active high) clears only the valid pipeline and
// the state, never the data registers.
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_drift_observer.md.
// Bit-exact model: model/fringe/fixed/drift_observer.py.

`default_nettype none

module fringe_drift_observer #(
    parameter integer ADC_W        = 14,   // ADC code width, 4..24
    parameter integer FINE_W       = 16,   // fine phase bits per period, 8..30
    parameter integer BLOCK_LOG2   = 8,    // B = 2^BLOCK_LOG2 samples per update block, 4..12
    parameter integer MU_LOG2      = 3,    // final step 2^-MU_LOG2 (gear shift from 1), 0..8
    parameter integer OFS_FRAC     = 4,    // fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
    parameter integer GINV_W       = 18,   // GINV width (GINV_W - 2 fraction bits), 8..24
    parameter integer FWD_W        = 6,    // 2^FWD_W bins per period in the forward tables, 2..min(10, FINE_W-1)
    parameter integer TABLE_W      = 18,   // forward table value and slope width, 8..24
    parameter integer TABLE_FRAC   = 2,    // fraction bits of the table values and of W0 (ADC codes), 0..12
    parameter integer KG_W         = 18,   // KG width (unsigned), 8..24
    parameter integer KG_SHIFT     = 40,   // right shift of SEA * KG, 1..60
    parameter integer HOLD         = 1,    // 1: the window is the whole block; 0: its second half
    parameter         FWD_SIN_INIT = "",   // $readmemh image of the sine table, 2 banks x 2^FWD_W words; "" = zeros
    parameter         FWD_COS_INIT = ""    // $readmemh image of the cosine table, 2 banks x 2^FWD_W words; "" = zeros
) (
    input  wire                              clk,
    input  wire                              rst,        // synchronous, active high
    input  wire                              ce,         // clock enable
    // in
    input  wire                              obs_valid,
    input  wire [FINE_W-1:0]                 obs_phase,  // u(FINE_W)
    input  wire signed [ADC_W-1:0]           obs_y_sin,  // the same sample's normalised codes
    input  wire signed [ADC_W-1:0]           obs_y_cos,
    input  wire                              obs_bank,   // table (and W0, KG) bank of this sample
    input  wire signed [ADC_W+TABLE_FRAC-1:0] w0_sin,    // W0 of this sample's bank, s(ADC_W + TABLE_FRAC)
    input  wire signed [ADC_W+TABLE_FRAC-1:0] w0_cos,
    input  wire [KG_W-1:0]                   kg_sin,     // KG of this sample's bank (taken with a block's last sample)
    input  wire [KG_W-1:0]                   kg_cos,
    // table write port (software side), independent of ce
    input  wire                              wr_en,
    input  wire                              wr_sel,     // 0 sine table, 1 cosine table
    input  wire [FWD_W:0]                    wr_addr,    // {bank, bin}
    input  wire [2*TABLE_W-1:0]              wr_data,    // {slope, value}
    // the state the normaliser uses now (the update steps from it)
    input  wire signed [ADC_W+OFS_FRAC-1:0]  off_sin,    // OFF, s(ADC_W + OFS_FRAC)
    input  wire signed [ADC_W+OFS_FRAC-1:0]  off_cos,
    input  wire [GINV_W-1:0]                 ginv_sin,   // GINV, u(GINV_W)
    input  wire [GINV_W-1:0]                 ginv_cos,
    // the update (to fringe_drift_normaliser)
    output reg                               upd_valid,     // an update is pending
    output reg  signed [ADC_W+OFS_FRAC-1:0]  upd_off_sin,   // its state
    output reg  signed [ADC_W+OFS_FRAC-1:0]  upd_off_cos,
    output reg  [GINV_W-1:0]                 upd_ginv_sin,
    output reg  [GINV_W-1:0]                 upd_ginv_cos,
    output reg                               upd_sat,       // it saturated (OFF or GINV, either channel)
    output reg                               upd_resolved,  // the last complete block's update is known (pending or skipped)
    input  wire                              upd_take       // the normaliser takes it (its application sample is accepted)
);

    `include "fringe_pkg.vh"

    localparam integer LATENCY  = DRIFT_OBS_LATENCY;
    localparam integer SWEEP_LO = FINE_W - DRIFT_SWEEP_MIN_LOG2;   // log2 of the least SWEEP that updates
    localparam [0:0]   PARTIAL  = (MU_LOG2 >= DRIFT_PARTIAL_MU_MIN) ? 1'b1 : 1'b0;   // blocks < a period update
    localparam integer WL       = BLOCK_LOG2 - 1 + ((HOLD != 0) ? 1 : 0);   // log2(W), W samples accumulated

    // ---- parameter checks ---------------------------------------------------------------------------
    generate
        `FRINGE_CHECK_DRIFT_STATE("fringe_drift_observer")
        `FRINGE_CHECK_DRIFT_OBSERVER("fringe_drift_observer")
    endgenerate

    // ---- widths ---------------------------------------------------------------------------------------
    localparam integer OW     = ADC_W + OFS_FRAC;                     // OFF
    localparam integer TW     = TABLE_W;
    localparam integer FB     = FINE_W - FWD_W;                       // >= 1
    localparam integer AW     = TW + 1;                               // a
    localparam integer YW     = ADC_W + TABLE_FRAC + 1;               // y * 2^TABLE_FRAC - W0
    localparam integer E_W    = ((YW > AW) ? YW : AW) + 1;            // e
    localparam integer EA_W   = E_W + AW;                             // e * a
    localparam integer SE_W   = E_W + WL;
    localparam integer SEA_W  = EA_W + WL;
    // offset step shift at gear 0 (+ G), 1 less than log2(W) + TABLE_FRAC: the phase comes from the same
    // codes, so the observer sees half of an offset error; the doubled step removes it (>= 2: WL >= 3)
    localparam integer SH_B   = WL + TABLE_FRAC - 1;
    localparam integer XW     = SE_W + OFS_FRAC + 1;                  // SE * 2^OFS_FRAC
    localparam integer OS_W   = XW + 1;                               // OFF + step
    localparam integer KP_W   = SEA_W + KG_W + MU_LOG2 + 1;           // SEA * KG * 2^(MU_LOG2 - G)
    localparam integer PR_W   = ((KP_W > KG_SHIFT) ? KP_W : KG_SHIFT) + 1;   // + 2^(KG_SHIFT-1)
    localparam integer DG_W   = PR_W - KG_SHIFT;                      // the GINV step
    localparam integer GS_W   = (((GINV_W + 1) > DG_W) ? GINV_W + 1 : DG_W) + 1;   // GINV - step
    localparam [BLOCK_LOG2-1:0] CNT_LAST = {BLOCK_LOG2{1'b1}};

    // ---- observer: counters --------------------------------------------------------------------------
    wire                  acc_o = ce & obs_valid & ~rst;
    reg  [BLOCK_LOG2-1:0] ocnt;           // accepted observer samples since reset, mod B
    reg                   o_at_last;      // ocnt == CNT_LAST, registered with ocnt (no compare behind ce)
    reg                   ohave;          // a previous phase exists (not the first sample after reset)
    reg  [FINE_W-1:0]     last_phase;
    reg  [KG_W-1:0]       kg_hold_s, kg_hold_c;
    // KG taken one clock enable after the block's last sample, from a register of every sample's KG: the
    // hold's enable is ce and one register (not ce, obs_valid, reset and the count; read at stage 10)
    reg  [KG_W-1:0]       kg_in_s, kg_in_c;
    reg                   kg_take;

    always @(posedge clk) begin
        if (rst) begin
            ocnt      <= {BLOCK_LOG2{1'b0}};
            o_at_last <= 1'b0;
            ohave     <= 1'b0;
        end else if (acc_o) begin
            ocnt      <= ocnt + 1'b1;
            o_at_last <= (ocnt == CNT_LAST - 1'b1);
            ohave     <= 1'b1;
        end
    end

    always @(posedge clk) begin
        if (rst) begin
            kg_take <= 1'b0;
        end else if (ce) begin
            kg_take <= obs_valid & o_at_last;
        end
    end

    always @(posedge clk) begin
        if (acc_o) begin
            last_phase <= obs_phase;
        end
        if (ce) begin
            kg_in_s <= kg_sin;
            kg_in_c <= kg_cos;
            if (kg_take) begin
                kg_hold_s <= kg_in_s;
                kg_hold_c <= kg_in_c;
            end
        end
    end

    // ---- observer: tables, stages 1..4: a = value + ((slope * frac + 2^(FB-1)) >>> FB) --------------
    wire [FWD_W:0]       rd_addr = {obs_bank, obs_phase[FINE_W-1:FB]};
    wire signed [AW-1:0] o4_as, o4_ac;

    fringe_interp_table #(
        .ADDR_W(FWD_W), .W(TW), .FB(FB), .OUT_W(AW), .ROUND_SHIFT(0), .INIT_FILE(FWD_SIN_INIT)
    ) u_fwd_sin (
        .clk(clk), .ce(ce),
        .wr_en(wr_en && !wr_sel), .wr_addr(wr_addr), .wr_data(wr_data),
        .rd_addr(rd_addr), .frac(obs_phase[FB-1:0]), .result(o4_as)
    );

    fringe_interp_table #(
        .ADDR_W(FWD_W), .W(TW), .FB(FB), .OUT_W(AW), .ROUND_SHIFT(0), .INIT_FILE(FWD_COS_INIT)
    ) u_fwd_cos (
        .clk(clk), .ce(ce),
        .wr_en(wr_en && wr_sel), .wr_addr(wr_addr), .wr_data(wr_data),
        .rd_addr(rd_addr), .frac(obs_phase[FB-1:0]), .result(o4_ac)
    );

    // ---- observer: pipeline --------------------------------------------------------------------------
    wire o8_valid, o8_last, o8_win;   // stage 8: valid, the block's last sample, in the window (9: o9_go)
    // the window: the block's last W samples (HOLD = 0: the second half, normalised with the latest state)
    wire obs_win = (HOLD != 0) | ocnt[BLOCK_LOG2-1];

    fringe_delay #(.WIDTH(2), .DEPTH(8)) u_obs_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(obs_valid), .in_data({obs_win, o_at_last}),
        .out_valid(o8_valid), .out_data({o8_win, o8_last})
    );

    // 1
    reg  [FINE_W-1:0]        o1_phase, o1_prev;
    reg  signed [ADC_W-1:0]  o1_ys, o1_yc;
    reg  signed [YW-2:0]     o1_w0s, o1_w0c;
    // 2
    reg  [FINE_W-1:0]        o2_dl;
    reg  signed [YW-1:0]     o2_yws, o2_ywc;
    // 3
    reg  signed [YW-1:0]     o3_yws, o3_ywc;
    reg  [FINE_W-1:0]        o3_abs;
    // 4
    reg  signed [YW-1:0]     o4_yws, o4_ywc;
    reg  [FINE_W-1:0]        o4_abs;
    // 5
    reg  signed [E_W-1:0]    o5_es, o5_ec;
    reg  signed [AW-1:0]     o5_as, o5_ac;
    reg  [FINE_W-1:0]        o5_abs;
    // 6..8 (e * a in g_ch)
    wire signed [E_W-1:0]    o8_es, o8_ec;
    wire [FINE_W-1:0]        o8_abs;

    wire signed [YW-1:0] ys_x  = {{(TABLE_FRAC+1){o1_ys[ADC_W-1]}}, o1_ys} <<< TABLE_FRAC;
    wire signed [YW-1:0] yc_x  = {{(TABLE_FRAC+1){o1_yc[ADC_W-1]}}, o1_yc} <<< TABLE_FRAC;
    wire [FINE_W-1:0]    delta = o1_phase - o1_prev;     // wraps into [-2^(FINE_W-1), 2^(FINE_W-1))

    always @(posedge clk) begin
        if (ce) begin
            // 1: input registers (the table read is in the RAMs)
            o1_phase <= obs_phase;
            // the first sample after reset is its own previous phase (delta 0): a choice of two inputs
            // here, not a clear of o2_dl (the LSR pin, with ce in front of it)
            o1_prev  <= ohave ? last_phase : obs_phase;
            o1_ys    <= obs_y_sin;
            o1_yc    <= obs_y_cos;
            o1_w0s   <= w0_sin;
            o1_w0c   <= w0_cos;
            // 2: phase delta; y * 2^TABLE_FRAC - W0
            o2_dl   <= delta;
            o2_yws  <= ys_x - {o1_w0s[YW-2], o1_w0s};
            o2_ywc  <= yc_x - {o1_w0c[YW-2], o1_w0c};
            // 3: |delta| (2^(FINE_W-1) fits unsigned)
            o3_yws <= o2_yws;
            o3_ywc <= o2_ywc;
            o3_abs <= o2_dl[FINE_W-1] ? -o2_dl : o2_dl;
            // 4: a from the tables
            o4_yws <= o3_yws;
            o4_ywc <= o3_ywc;
            o4_abs <= o3_abs;
            // 5: e = yw - a
            o5_es  <= {{(E_W-YW){o4_yws[YW-1]}}, o4_yws} - {{(E_W-AW){o4_as[AW-1]}}, o4_as};
            o5_ec  <= {{(E_W-YW){o4_ywc[YW-1]}}, o4_ywc} - {{(E_W-AW){o4_ac[AW-1]}}, o4_ac};
            o5_as  <= o4_as;
            o5_ac  <= o4_ac;
            o5_abs <= o4_abs;
        end
    end

    // ---- e * a (stages 6..8): 18x18 partial products (fringe_split_mul); e and |delta| carried along --
    wire o8_carry_valid;

    fringe_delay #(.WIDTH(2 * E_W + FINE_W), .DEPTH(3)) u_obs_carry (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(1'b0), .in_data({o5_es, o5_ec, o5_abs}),
        .out_valid(o8_carry_valid), .out_data({o8_es, o8_ec, o8_abs})
    );

    wire [2*E_W-1:0]  ea_e = {o5_ec, o5_es};        // {cosine, sine}
    wire [2*AW-1:0]   ea_a = {o5_ac, o5_as};
    wire [2*EA_W-1:0] ea_p;
    // (the two channels' multipliers: g_ch below)
    wire signed [EA_W-1:0] o8_eas = ea_p[0 +: EA_W];
    wire signed [EA_W-1:0] o8_eac = ea_p[EA_W +: EA_W];

    // 9: accumulators. The block's last sample is added like the others, so after it the accumulators
    // hold the block's sums (read by stage 10 at the next clock enable, before a new sample can change
    // them: no snapshot copies). `fresh` (set by that sample and by a reset) makes the next window sample
    // start from 0 instead of a clear: a synchronous clear of the wide registers is the LSR pin, which
    // took the block-end enable (and ce) across the chip to ~170 flip-flops (issue 11). One copy of it per
    // accumulator (se_s, se_c, sea_s, sea_c, sweep), each written with its own feedback so that synthesis
    // does not merge them: one register in front of ~170 LUTs was the next critical path.
    reg  signed [SE_W-1:0]  se_s, se_c;
    reg  signed [SEA_W-1:0] sea_s, sea_c;
    // SWEEP as its low FINE_W bits and a flag for the bits above (|delta| >= 0: once set, they stay
    // nonzero): the period test is the flag or the low sum's carry, not an OR over an adder's top bits
    reg  [FINE_W-1:0]       sweep;
    reg                     sweep_hi;
    reg  [4:0]              fresh;        // the accumulators hold a finished block (or nothing): start from 0
    reg                     o9_go;
    wire signed [SE_W-1:0]  se_s_b  = fresh[0] ? {SE_W{1'b0}} : se_s;
    wire signed [SE_W-1:0]  se_c_b  = fresh[1] ? {SE_W{1'b0}} : se_c;
    wire signed [SEA_W-1:0] sea_s_b = fresh[2] ? {SEA_W{1'b0}} : sea_s;
    wire signed [SEA_W-1:0] sea_c_b = fresh[3] ? {SEA_W{1'b0}} : sea_c;
    wire [FINE_W-1:0]       sweep_b = fresh[4] ? {FINE_W{1'b0}} : sweep;
    wire signed [SE_W-1:0]  se_s_n  = se_s_b + {{WL{o8_es[E_W-1]}}, o8_es};
    wire signed [SE_W-1:0]  se_c_n  = se_c_b + {{WL{o8_ec[E_W-1]}}, o8_ec};
    wire signed [SEA_W-1:0] sea_s_n = sea_s_b + {{WL{o8_eas[EA_W-1]}}, o8_eas};
    wire signed [SEA_W-1:0] sea_c_n = sea_c_b + {{WL{o8_eac[EA_W-1]}}, o8_eac};
    wire [FINE_W:0]         sweep_n = {1'b0, sweep_b} + {1'b0, o8_abs};   // with its carry
    wire                    full_n  = (sweep_hi & ~fresh[4]) | sweep_n[FINE_W];   // SWEEP >= a period
    wire                    blk_end = o8_valid & o8_last;   // (in the window: the block's last sample)
    wire                    acc_w   = o8_valid & o8_win;

    always @(posedge clk) begin
        if (rst) begin
            o9_go <= 1'b0;
            fresh <= 5'b11111;
        end else if (ce) begin
            o9_go <= blk_end;
            fresh <= {5{blk_end}} | (fresh & ~{5{acc_w}});   // set by the block's end, cleared by a sample
        end
    end

    // data only: no reset, no clear
    always @(posedge clk) begin
        if (ce && acc_w) begin
            se_s  <= se_s_n;
            se_c  <= se_c_n;
            sea_s <= sea_s_n;
            sea_c <= sea_c_n;
            sweep    <= sweep_n[FINE_W-1:0];
            sweep_hi <= full_n;
        end
    end

    // The block's SWEEP test, registered at its last sample. A block that swept less than a period (but at
    // least 2^SWEEP_LO) updates at the final gear, if that is 2^-2 or smaller, and does not count. The gear
    // changes only at stage 16, long before the next block's end (B >= 16 samples later), so stages 10 and 14
    // see the block's gear G.
    reg  [3:0] gear;
    reg  [8:0] g_left;
    reg        snap_full, snap_ok;   // a whole period swept; enough to update
    reg  [3:0] g_up;                 // MU_LOG2 - G: the gain step's left shift (stage 14)

    always @(posedge clk) begin
        if (ce && blk_end) begin
            snap_full  <= full_n;
            snap_ok    <= full_n | (PARTIAL & |sweep_n[FINE_W-1:SWEEP_LO]);
        end
    end

    // g_up: a function of snap_full and the gear, both constant from stage 10 to 16 (and frozen by ce = 0),
    // registered every clock: no enable, and no block-end term in front of its flip-flops.
    always @(posedge clk) begin
        g_up <= snap_full ? MU_LOG2[3:0] - gear : 4'd0;
    end

    // ---- the update (stages 10..16) -------------------------------------------------------------------
    // 10..13 P = SEA * KG: 18x18 partial products (fringe_split_mul); 10 the offset step at the gear,
    // 11 OFF + step, 12 OFF saturated, SWEEP test carried along; 14 P * 2^(MU_LOG2 - G) >>> KG_SHIFT and
    // its rounding bit; 15 GINV - that - the bit (the rounding as a borrow); 16 GINV saturated: resolved.
    localparam integer P_W = SEA_W + KG_W;                  // SEA * KG, exact
    wire [2*SEA_W-1:0] kg_e = {sea_c, sea_s};   // {cosine, sine}: the block's sums at stage 10
    wire [2*KG_W-1:0]  kg_k = {kg_hold_c, kg_hold_s};
    wire [2*P_W-1:0]   kg_p;

    // the multipliers of one channel (0 sine, 1 cosine): e * a (stages 6..8), SEA * KG (10..13)
    genvar gch;
    generate
        for (gch = 0; gch < 2; gch = gch + 1) begin : g_ch
            fringe_split_mul #(.A_W(E_W), .A_SIGNED(1), .B_W(AW), .B_SIGNED(1), .LATENCY(3)) u_ea (
                .clk(clk), .ce(ce), .a(ea_e[gch*E_W +: E_W]), .b(ea_a[gch*AW +: AW]), .p(ea_p[gch*EA_W +: EA_W])
            );
            fringe_split_mul #(.A_W(SEA_W), .A_SIGNED(1), .B_W(KG_W), .B_SIGNED(0), .LATENCY(4)) u_kg (
                .clk(clk), .ce(ce), .a(kg_e[gch*SEA_W +: SEA_W]), .b(kg_k[gch*KG_W +: KG_W]), .p(kg_p[gch*P_W +: P_W])
            );
        end
    endgenerate

    // Gear shift: update number u (updates resolved with a whole period swept since reset, i.e. applied or
    // about to be) runs at G_u = min(MU_LOG2, bit_length(u)); g_left counts the updates left at this gear. The
    // gear changes only at stage 16, after the stages 10 and 14 of the same block read it (stage 10 directly,
    // stage 14 through g_up).

    // P sign-extended to PR_W bits, times 2^(MU_LOG2 - G) (fits: PR_W > P_W + MU_LOG2 + 1)
    wire signed [PR_W-1:0] px_s = {{(PR_W-P_W){kg_p[P_W-1]}}, kg_p[0 +: P_W]};
    wire signed [PR_W-1:0] px_c = {{(PR_W-P_W){kg_p[2*P_W-1]}}, kg_p[P_W +: P_W]};
    wire signed [PR_W-1:0] pk_s = px_s <<< g_up;
    wire signed [PR_W-1:0] pk_c = px_c <<< g_up;

    wire signed [XW-1:0]   sex_s = {{(OFS_FRAC+1){se_s[SE_W-1]}}, se_s};
    wire signed [XW-1:0]   sex_c = {{(OFS_FRAC+1){se_c[SE_W-1]}}, se_c};
    wire signed [XW-1:0]   sxo_s = sex_s <<< OFS_FRAC;
    wire signed [XW-1:0]   sxo_c = sex_c <<< OFS_FRAC;
    // the offset step's shift, log2(W) + TABLE_FRAC - 1 + G at a whole period, else at the final gear
    // MU_LOG2: a shift by the gear register and a fixed one, chosen by the SWEEP test's register after
    // them (no test or adder in front of the shift amount)
    wire signed [XW-1:0]   sxg_s = (sxo_s >>> SH_B) >>> gear;
    wire signed [XW-1:0]   sxg_c = (sxo_c >>> SH_B) >>> gear;
    wire signed [XW-1:0]   sxm_s = sxo_s >>> (SH_B + MU_LOG2);
    wire signed [XW-1:0]   sxm_c = sxo_c >>> (SH_B + MU_LOG2);
    reg  signed [XW-1:0]   u1_ss, u1_sc;   // 10: the offset steps
    reg  signed [OS_W-1:0] u2_os, u2_oc;   // 11: OFF + step
    reg  signed [OW-1:0]   u3_os, u3_oc;   // 12: saturated
    reg                    u3_sat;
    wire                   u5_valid, u5_ok, u5_full; // stage 14: valid, the SWEEP tests
    wire signed [OW-1:0]   u6_os, u6_oc;
    wire                   u6_sat, u6_carry_valid;
    reg  signed [DG_W-1:0] u5_dg_s, u5_dg_c; // 14: (P * 2^(MU_LOG2 - G)) >>> KG_SHIFT
    reg                    u5_rb_s, u5_rb_c; //     and bit KG_SHIFT-1 (the rounding)
    reg  signed [GS_W-1:0] u6_gs, u6_gc;
    wire [GS_W-1:0]        dgn_s = ~{{(GS_W-DG_W){u5_dg_s[DG_W-1]}}, u5_dg_s};
    wire [GS_W-1:0]        dgn_c = ~{{(GS_W-DG_W){u5_dg_c[DG_W-1]}}, u5_dg_c};
    wire [GS_W-1:0]        rbn_s = {{(GS_W-1){1'b0}}, ~u5_rb_s};
    wire [GS_W-1:0]        rbn_c = {{(GS_W-1){1'b0}}, ~u5_rb_c};
    // OFF + step in range of s(OW) <=> bits OS_W-1 .. OW-1 all equal the sign
    wire os_over = `FRINGE_OUTSIDE(u2_os, OS_W, OW);
    wire oc_over = `FRINGE_OUTSIDE(u2_oc, OS_W, OW);
    // GINV - step: below 0 -> 0, above 2^GINV_W - 1 -> 2^GINV_W - 1
    wire gs_neg  = u6_gs[GS_W-1];
    wire gc_neg  = u6_gc[GS_W-1];
    wire gs_high = ~gs_neg & |u6_gs[GS_W-2:GINV_W];
    wire gc_high = ~gc_neg & |u6_gc[GS_W-2:GINV_W];

    // stages 10..14: LATENCY - 11 (1..8 before the accumulators, 9 the block's end, 15 and 16 after)
    fringe_delay #(.WIDTH(2), .DEPTH(LATENCY - 11)) u_upd_valid (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(o9_go), .in_data({snap_full, snap_ok}),
        .out_valid(u5_valid), .out_data({u5_full, u5_ok})
    );

    // 13..15: OFF carried along
    fringe_delay #(.WIDTH(2 * OW + 1), .DEPTH(3)) u_upd_carry (
        .clk(clk), .rst(rst), .ce(ce), .in_valid(1'b0), .in_data({u3_os, u3_oc, u3_sat}),
        .out_valid(u6_carry_valid), .out_data({u6_os, u6_oc, u6_sat})
    );

    always @(posedge clk) begin
        if (ce) begin
            // 10: (SE * 2^OFS_FRAC) >>> (log2(W) + TABLE_FRAC - 1 + G)
            u1_ss  <= snap_full ? sxg_s : sxm_s;
            u1_sc  <= snap_full ? sxg_c : sxm_c;
            // 11
            u2_os  <= {{(OS_W-OW){off_sin[OW-1]}}, off_sin} + {u1_ss[XW-1], u1_ss};
            u2_oc  <= {{(OS_W-OW){off_cos[OW-1]}}, off_cos} + {u1_sc[XW-1], u1_sc};
            // 12
            u3_os  <= `FRINGE_SATURATE(u2_os, OS_W, OW);
            u3_oc  <= `FRINGE_SATURATE(u2_oc, OS_W, OW);
            u3_sat <= os_over | oc_over;
            // 14: the gain step at the gear, (P * 2^(MU_LOG2 - G) + 2^(KG_SHIFT-1)) >>> KG_SHIFT in two parts
            u5_dg_s <= pk_s[PR_W-1:KG_SHIFT];
            u5_dg_c <= pk_c[PR_W-1:KG_SHIFT];
            u5_rb_s <= pk_s[KG_SHIFT-1];
            u5_rb_c <= pk_c[KG_SHIFT-1];
            // 15: GINV - step
            u6_gs  <= {{(GS_W-GINV_W){1'b0}}, ginv_sin} + dgn_s + rbn_s;
            u6_gc  <= {{(GS_W-GINV_W){1'b0}}, ginv_cos} + dgn_c + rbn_c;
        end
    end

    // 16: resolved: the pending update (taken by the normaliser at its application sample) or a skip.
    // Its decisions are registered at stage 15 (the gear and g_left cannot change in between: they change
    // only at a stage 16, and blocks are B >= 16 samples apart), so that ce meets one gate in front of the
    // enables of the state registers, not the SWEEP tests and the gear compares.
    reg  u6_valid;   // stage 15: valid (stage 16 resolves)
    reg  u6_go;      // the block updates (pending)
    reg  u6_gup;     // and steps to the next gear
    reg  u6_gdec;    // or counts one update at this gear
    wire g_more = u5_full & (gear != MU_LOG2[3:0]);

    always @(posedge clk) begin
        if (rst) begin
            u6_valid <= 1'b0;
            u6_go    <= 1'b0;
            u6_gup   <= 1'b0;
            u6_gdec  <= 1'b0;
        end else if (ce) begin
            u6_valid <= u5_valid;
            u6_go    <= u5_valid & u5_ok;
            u6_gup   <= u5_valid & u5_ok & g_more & (g_left == 9'd1);
            u6_gdec  <= u5_valid & u5_ok & g_more & (g_left != 9'd1);
        end
    end

    always @(posedge clk) begin
        if (ce && u6_go) begin
            upd_off_sin  <= u6_os;
            upd_off_cos  <= u6_oc;
            // saturated with AND / OR, not a choice of constants (which synthesis maps to the LSR pin)
            upd_ginv_sin <= (u6_gs[GINV_W-1:0] | {GINV_W{gs_high}}) & ~{GINV_W{gs_neg}};
            upd_ginv_cos <= (u6_gc[GINV_W-1:0] | {GINV_W{gc_high}}) & ~{GINV_W{gc_neg}};
            upd_sat      <= u6_sat | gs_neg | gs_high | gc_neg | gc_high;
        end
    end

    // The gear, and the flags: set by a block's resolution (upd_valid if it updates: u6_go implies u6_valid),
    // cleared when the normaliser takes the update at its application sample (HOLD = 1: it waits for upd_resolved)
    always @(posedge clk) begin
        if (rst) begin
            gear         <= 4'd0;
            g_left       <= 9'd1;
            upd_valid    <= 1'b0;
            upd_resolved <= 1'b0;
        end else begin
            if (ce && u6_gup) begin
                gear   <= gear + 4'd1;
                g_left <= 9'd1 << gear;        // 2^(G_new - 1) updates at the new gear
            end else if (ce && u6_gdec) begin
                g_left <= g_left - 9'd1;
            end
            if (ce && u6_valid) begin
                upd_valid    <= u6_go | (upd_valid & ~upd_take);
                upd_resolved <= 1'b1;
            end else if (upd_take) begin
                upd_valid    <= 1'b0;
                upd_resolved <= 1'b0;
            end
        end
    end

    // Bits that carry nothing: the rounded-off bits of the gain product; the valid outputs of the delays
    // that carry data only.
    wire unused = &{1'b0, pk_s, pk_c, o8_carry_valid, u6_carry_valid};

endmodule

`default_nettype wire
