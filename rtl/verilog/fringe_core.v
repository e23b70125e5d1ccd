// fringe_core: the whole signal-correction pipeline of a sin/cos encoder, one sample per clock
// (COMPACT = 1: one per CLOCKS_PER_SAMPLE = CORDIC_STAGES clock enables, in_ready = 0 in between;
// the CORDIC iterates, the quadrature's products share one multiplier; the same words and LATENCY):
//
//   sin, cos s(ADC_W) [-> fringe_drift_normaliser, DRIFT = 1] -> branch select (registered)
//   -> fringe_wave_lut x2 -> fringe_quadrature [-> fringe_canceller, CANCEL = 1] -> fringe_cordic
//   [-> fringe_drift_observer, DRIFT = 1: the block's update back to the normaliser]
//   -> magnitude flags -> fringe_period_count (+ coarse u(COARSE_W)) [-> fringe_trim, TRIM = 1]
//   -> fringe_long_period -> pos u(POS_W), status (8 bits)
//
// Every sample takes the active register and table bank when it is accepted and carries it along;
// the configuration write port (independent of ce) writes the inactive bank, CTRL swaps the banks.
// rst (synchronous, active high) clears the sample pipeline only; ce = 0 freezes it.
//
// LATENCY = CORDIC_STAGES + 25 (+ 13 with TRIM = 1, + 4 with DRIFT = 1, + 4 with CANCEL = 1) clock
// enables from in_valid to out_valid (fringe_core_latency, fringe_pkg).
// Parameters, ports, banks and pipeline: docs/blocks/fringe_core.md (formats, registers, status word:
// docs/architecture.md). Bit-exact model: model/fringe/fixed/core.py (run_core, run_core_banks).

`default_nettype none

module fringe_core #(
    `include "fringe_core_params.vh"  // generated: python sim/hdlgen.py
) (
    input  wire             clk,
    input  wire             rst,          // synchronous, active high: clears the sample pipeline
    input  wire             ce,           // clock enable: the pipeline advances when 1
    // sample in: taken at a clock enable with in_valid = 1 and in_ready = 1
    input  wire             in_valid,
    output wire             in_ready,     // 1 with COMPACT = 0; COMPACT = 1: 0 for CLOCKS_PER_SAMPLE-1 clock enables after a sample;
                                          // DRIFT = 1, DRIFT_HOLD = 1: also 0 while a tracker block boundary waits for its update
    input  wire [ADC_W-1:0] sin,          // s(ADC_W)
    input  wire [ADC_W-1:0] cos,          // s(ADC_W)
    input  wire [((COARSE_W > 0) ? COARSE_W : 1)-1:0] coarse,  // u(COARSE_W); 1 bit, ignored, when COARSE_W = 0
    // sample out
    output wire             out_valid,
    output wire [$clog2(LINES)+FINE_W-1:0] pos,  // u(POS_W) position, fine counts, [0, LINES*2^FINE_W)
    output wire [7:0]       status,       // status word (docs/architecture.md), bit 7 = BANK
    // configuration write port
    input  wire             cfg_wr_en,
    input  wire [19:0]      cfg_wr_addr,
    input  wire [63:0]      cfg_wr_data,
    output wire             active_bank
);

    `include "fringe_pkg.vh"

    // The documented latency (fringe.fixed.core.core_latency); read by the testbench, not by the logic.
    /* verilator lint_off UNUSEDPARAM */
    localparam integer LATENCY = fringe_core_latency(CORDIC_STAGES, TRIM, DRIFT, CANCEL);
    /* verilator lint_on UNUSEDPARAM */
    // Clock enables from one sample to the next at full speed (fringe.fixed.config clocks_per_sample).
    localparam integer CLOCKS_PER_SAMPLE = 1 + COMPACT * (CORDIC_STAGES + CORDIC_ITER_CLOCKS_BASE - 1);  // COMPACT: 0 or 1
    localparam integer POS_W   = $clog2(LINES) + FINE_W;        // clog2(LINES * 2^FINE_W)
    localparam integer CW      = (COARSE_W > 0) ? COARSE_W : 1;  // coarse port width
    localparam integer AMP_W   = WAVE_W + 1;   // CORDIC magnitude u(WAVE_W+1)
    localparam integer BR_W    = ADC_W + 1;    // branch thresholds s(ADC_W+1)

    generate
        if (POS_W > 31) begin : g_bad_pos_w
            $error("fringe_core: POS_W = clog2(LINES) + FINE_W = %0d > 31: registers are 32-bit (instance %m)",
                   POS_W);
        end
        if (LINES < 1) begin : g_bad_lines
            $error("fringe_core: LINES = %0d must be >= 1 (instance %m)", LINES);
        end
        if (WAVE_ADDR_W + 1 > 16) begin : g_bad_wave_addr_w
            $error("fringe_core: WAVE_ADDR_W = %0d: a table bank must fit the 16-bit word address (instance %m)",
                   WAVE_ADDR_W);
        end
        if (LP_ADDR_W > 16) begin : g_bad_lp_addr_w
            $error("fringe_core: LP_ADDR_W = %0d > 16: a table bank must fit the 16-bit word address (instance %m)",
                   LP_ADDR_W);
        end
        if (WAVE_W > 31 || ADC_W > 31) begin : g_bad_reg_fields
            $error("fringe_core: WAVE_W = %0d, ADC_W = %0d: register fields must fit 32 bits (instance %m)",
                   WAVE_W, ADC_W);
        end
        if (TRIM != 0 && TRIM != 1) begin : g_bad_trim
            $error("fringe_core: TRIM = %0d must be 0 or 1 (instance %m)", TRIM);
        end
        if (TRIM != 0 && TRIM_MAP_PSI_W + TRIM_MAP_PHI_W > 15) begin : g_bad_map_w
            $error("fringe_core: TRIM_MAP_PSI_W + TRIM_MAP_PHI_W = %0d > 15: a trim map bank must fit the 16-bit word address (instance %m)",
                   TRIM_MAP_PSI_W + TRIM_MAP_PHI_W);
        end
        if (COMPACT != 0 && COMPACT != 1) begin : g_bad_compact
            $error("fringe_core: COMPACT = %0d must be 0 or 1 (instance %m)", COMPACT);
        end
        if (DRIFT != 0 && DRIFT != 1) begin : g_bad_drift
            $error("fringe_core: DRIFT = %0d must be 0 or 1 (instance %m)", DRIFT);
        end
        if (CANCEL != 0 && CANCEL != 1) begin : g_bad_cancel
            $error("fringe_core: CANCEL = %0d must be 0 or 1 (instance %m)", CANCEL);
        end
        if (LP_W > 32) begin : g_bad_lp_w
            $error("fringe_core: LP_W = %0d > 32: a table word {slope, value} must fit cfg_wr_data (instance %m)",
                   LP_W);
        end
    endgenerate

    // ---- register file, CTRL and write decode (configuration, not reset): fringe_regs ------------
    wire [2*N_REGS*REG_W-1:0] regs_q;
    wire                      bank_r;
    wire                      wr_sin, wr_cos, wr_lp, wr_trim, wr_fwd, wr_fwd_sel;
    wire [1:0]                wr_trim_sel;
    wire [15:0]               wr_word;
    wire                      wr_bank_r;
    wire [63:0]               wr_data;

    fringe_regs #(
        .WAVE_ADDR_W(WAVE_ADDR_W), .LP_ADDR_W(LP_ADDR_W), .MAP_PSI_W(TRIM_MAP_PSI_W), .MAP_PHI_W(TRIM_MAP_PHI_W),
        .FWD_W(DRIFT_FWD_W), .REGS_INIT(REGS_INIT)
    ) u_regs (
        .clk(clk), .cfg_wr_en(cfg_wr_en), .cfg_wr_addr(cfg_wr_addr), .cfg_wr_data(cfg_wr_data),
        .regs_q(regs_q), .active_bank(bank_r),
        .wr_sin(wr_sin), .wr_cos(wr_cos), .wr_lp(wr_lp), .wr_trim(wr_trim), .wr_trim_sel(wr_trim_sel),
        .wr_fwd(wr_fwd), .wr_fwd_sel(wr_fwd_sel), .wr_word(wr_word), .wr_bank(wr_bank_r), .wr_data(wr_data)
    );

    // regs[{bank, index}]: the bank taps below read the words of their sample's bank
    wire [REG_W-1:0] regs [0:2*N_REGS-1];
    genvar ri;
    generate
        for (ri = 0; ri < 2 * N_REGS; ri = ri + 1) begin : g_regs
            assign regs[ri] = regs_q[REG_W*ri +: REG_W];
        end
    endgenerate

    assign active_bank = bank_r;

    wire [WAVE_ADDR_W+1:0] wave_wr_addr = {wr_bank_r, wr_word[WAVE_ADDR_W:0]};
    wire [LP_ADDR_W:0]     lp_wr_addr   = {wr_bank_r, wr_word[LP_ADDR_W-1:0]};
    wire [TRIM_MAP_PSI_W+TRIM_MAP_PHI_W+1:0] trim_wr_addr = {wr_bank_r, wr_word[TRIM_MAP_PSI_W+TRIM_MAP_PHI_W:0]};

    // ---- sample admission: COMPACT = 1 takes a sample every CLOCKS_PER_SAMPLE clock enables -------
    // The spacing holds through the pipeline (every stage advances on the same ce), so the iterated
    // CORDIC is free whenever a sample reaches it.
    wire take_in = in_valid && in_ready;
    wire admit_ready;                     // the COMPACT spacing
    wire drift_ready;                     // fringe_drift_normaliser's hold (DRIFT = 1, DRIFT_HOLD = 1)
    assign in_ready = admit_ready && drift_ready;

    generate
        if (COMPACT != 0) begin : g_admit
            localparam integer WAIT_W = $clog2(CLOCKS_PER_SAMPLE);
            localparam [31:0]  GAP_32 = CLOCKS_PER_SAMPLE - 1;
            reg [WAIT_W-1:0]   wait_r;   // clock enables until the next sample may be taken

            always @(posedge clk) begin
                if (rst) begin
                    wait_r <= {WAIT_W{1'b0}};
                end else if (ce) begin
                    if (take_in) begin
                        wait_r <= GAP_32[WAIT_W-1:0];
                    end else if (wait_r != {WAIT_W{1'b0}}) begin
                        wait_r <= wait_r - 1'b1;
                    end
                end
            end

            assign admit_ready = (wait_r == {WAIT_W{1'b0}});
        end else begin : g_admit_all
            assign admit_ready = 1'b1;
        end
    endgenerate

    // ---- the drift normaliser (DRIFT = 1) or the raw codes ----------------------------------------
    // The sample takes the active bank when it is accepted; the flags of the raw codes (CLIP_*) and of
    // the normalisation (a saturated normalised code) travel with it, with the normalised codes the
    // tracker's observer needs at the CORDIC output: dx = {y_sin, y_cos, norm_sat, clip_c, clip_s}.
    localparam integer DX_W   = 2 * ADC_W + 3;
    localparam integer LAT_X  = CANCEL * CANCEL_LATENCY;   // fringe_canceller (CANCEL = 1)
    localparam integer PIPE_D = CORE_INPUT_LATENCY + WAVE_LUT_LATENCY + QUADRATURE_LATENCY + LAT_X + CORDIC_STAGES
                                + CORDIC_LATENCY_BASE;   // normaliser outputs -> CORDIC outputs
    localparam [ADC_W-1:0] ADC_MIN = {1'b1, {(ADC_W-1){1'b0}}}, ADC_MAX = {1'b0, {(ADC_W-1){1'b1}}};
    wire             raw_clip_s = (sin == ADC_MIN) || (sin == ADC_MAX);
    wire             raw_clip_c = (cos == ADC_MIN) || (cos == ADC_MAX);
    wire             n_valid;
    wire [ADC_W-1:0] n_sin, n_cos;
    wire             n_sat, n_bank, n_clip_s, n_clip_c;
    wire [CW-1:0]    n_coarse;

    generate
        if (DRIFT != 0) begin : g_drift
            // fringe_drift_normaliser in front, fringe_drift_observer on each sample's phase PIPE_D clock
            // enables after its outputs; they hand each other the state and the block's update
            localparam integer OW      = ADC_W + DRIFT_OFS_FRAC;   // OFF
            localparam integer D_TOTAL = DRIFT_NORM_LATENCY + PIPE_D + DRIFT_OBS_LATENCY;
            // DRIFT_HOLD = 0: block j's update must be resolved when sample (j+1)B + B/2 arrives at full speed
            if (DRIFT_HOLD == 0 && DRIFT_BLOCK_LOG2 >= 1 && D_TOTAL > (1 << (DRIFT_BLOCK_LOG2 - 1)) + 1) begin : g_late
                $error("fringe_core: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = %0d + %0d + %0d = %0d exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = %0d: the update would come too late (instance %m)",
                       DRIFT_NORM_LATENCY, PIPE_D, DRIFT_OBS_LATENCY, D_TOTAL, (1 << (DRIFT_BLOCK_LOG2 - 1)) + 1);
            end
            wire signed [OW-1:0]    off_s, off_c, upd_off_s, upd_off_c;
            wire [DRIFT_GINV_W-1:0] ginv_s, ginv_c, upd_ginv_s, upd_ginv_c;
            wire                    track_sat, upd_valid, upd_sat, upd_resolved, upd_take;
            wire [CW+2:0]           nu;

            fringe_drift_normaliser #(
                .ADC_W(ADC_W), .BLOCK_LOG2(DRIFT_BLOCK_LOG2), .OFS_FRAC(DRIFT_OFS_FRAC), .GINV_W(DRIFT_GINV_W),
                .HOLD(DRIFT_HOLD), .USER_W(CW + 3)
            ) u_drift_norm (
                .clk(clk), .rst(rst), .ce(ce),
                .in_valid(take_in), .raw_sin(sin), .raw_cos(cos), .in_user({coarse, bank_r, raw_clip_c, raw_clip_s}),
                .in_ready(drift_ready),
                .norm_valid(n_valid), .y_sin(n_sin), .y_cos(n_cos), .norm_sat(n_sat), .norm_user(nu),
                .upd_valid(upd_valid), .upd_off_sin(upd_off_s), .upd_off_cos(upd_off_c), .upd_ginv_sin(upd_ginv_s),
                .upd_ginv_cos(upd_ginv_c), .upd_sat(upd_sat), .upd_resolved(upd_resolved), .upd_take(upd_take),
                .off_sin(off_s), .off_cos(off_c), .ginv_sin(ginv_s), .ginv_cos(ginv_c), .track_sat(track_sat)
            );

            fringe_drift_observer #(
                .ADC_W(ADC_W), .FINE_W(FINE_W), .BLOCK_LOG2(DRIFT_BLOCK_LOG2), .MU_LOG2(DRIFT_MU_LOG2),
                .OFS_FRAC(DRIFT_OFS_FRAC), .GINV_W(DRIFT_GINV_W), .FWD_W(DRIFT_FWD_W), .TABLE_W(DRIFT_TABLE_W),
                .TABLE_FRAC(DRIFT_TABLE_FRAC), .KG_W(DRIFT_KG_W), .KG_SHIFT(DRIFT_KG_SHIFT), .HOLD(DRIFT_HOLD),
                .FWD_SIN_INIT(DRIFT_FWD_SIN_INIT), .FWD_COS_INIT(DRIFT_FWD_COS_INIT)
            ) u_drift_obs (
                .clk(clk), .rst(rst), .ce(ce),
                .obs_valid(c_valid), .obs_phase(phase), .obs_y_sin(c_dx[DX_W-1 -: ADC_W]),
                .obs_y_cos(c_dx[ADC_W+2:3]), .obs_bank(c_bank),
                .w0_sin(regs[{c_bank, REG_W0_S}][ADC_W+DRIFT_TABLE_FRAC-1:0]),
                .w0_cos(regs[{c_bank, REG_W0_C}][ADC_W+DRIFT_TABLE_FRAC-1:0]),
                .kg_sin(regs[{c_bank, REG_KG_S}][DRIFT_KG_W-1:0]), .kg_cos(regs[{c_bank, REG_KG_C}][DRIFT_KG_W-1:0]),
                .wr_en(wr_fwd), .wr_sel(wr_fwd_sel), .wr_addr({wr_bank_r, wr_word[DRIFT_FWD_W-1:0]}),
                .wr_data(wr_data[2*DRIFT_TABLE_W-1:0]),
                .off_sin(off_s), .off_cos(off_c), .ginv_sin(ginv_s), .ginv_cos(ginv_c),
                .upd_valid(upd_valid), .upd_off_sin(upd_off_s), .upd_off_cos(upd_off_c), .upd_ginv_sin(upd_ginv_s),
                .upd_ginv_cos(upd_ginv_c), .upd_sat(upd_sat), .upd_resolved(upd_resolved), .upd_take(upd_take)
            );

            assign {n_coarse, n_bank, n_clip_c, n_clip_s} = nu;
            // the tracker's saturation is observable in simulation; the samples carry norm_sat
            wire unused_drift = &{1'b0, track_sat, c_dx[2:0]};
        end else begin : g_no_drift
            assign drift_ready = 1'b1;
            assign n_valid  = take_in;
            assign n_sin    = sin;
            assign n_cos    = cos;
            assign n_sat    = 1'b0;
            assign n_bank   = bank_r;
            assign n_clip_s = raw_clip_s;
            assign n_clip_c = raw_clip_c;
            assign n_coarse = coarse;
            wire unused_drift = &{1'b0, wr_fwd, wr_fwd_sel, c_dx};
        end
    endgenerate

    // ---- stage 1 (registered): the sample and its bank's branch thresholds -----------------------
    // (the register file read and the compares sit in separate stages: one long path otherwise)
    reg                    valid0;
    reg [ADC_W-1:0]        sin0, cos0;
    reg [CW-1:0]           coarse0;
    reg                    bank0;
    reg [2:0]              flags0;   // {norm_sat, clip_c, clip_s}
    reg signed [BR_W-1:0]  mid_s, hi_s, lo_s, mid_c, hi_c, lo_c;

    always @(posedge clk) begin
        if (rst) begin
            valid0 <= 1'b0;
        end else if (ce) begin
            valid0 <= n_valid;
        end
    end

    always @(posedge clk) begin
        if (ce) begin
            sin0    <= n_sin;
            cos0    <= n_cos;
            coarse0 <= n_coarse;
            bank0   <= n_bank;
            flags0  <= {n_sat, n_clip_c, n_clip_s};
            mid_s   <= regs[{n_bank, REG_MID_S}][BR_W-1:0];
            hi_s    <= regs[{n_bank, REG_THR_HI_S}][BR_W-1:0];
            lo_s    <= regs[{n_bank, REG_THR_LO_S}][BR_W-1:0];
            mid_c   <= regs[{n_bank, REG_MID_C}][BR_W-1:0];
            hi_c    <= regs[{n_bank, REG_THR_HI_C}][BR_W-1:0];
            lo_c    <= regs[{n_bank, REG_THR_LO_C}][BR_W-1:0];
        end
    end

    // ---- stage 2 (registered): branch selects ------------------------------------------------------
    // branch_s = cos >= (sin >= MID_S ? THR_HI_S : THR_LO_S), branch_c likewise with sin/cos swapped.
    wire signed [BR_W-1:0] sin_x   = {sin0[ADC_W-1], sin0};
    wire signed [BR_W-1:0] cos_x   = {cos0[ADC_W-1], cos0};
    wire                   br_s0   = (sin_x >= mid_s) ? (cos_x >= hi_s) : (cos_x >= lo_s);
    wire                   br_c0   = (cos_x >= mid_c) ? (sin_x >= hi_c) : (sin_x >= lo_c);

    reg             valid1;
    reg [ADC_W-1:0] sin1, cos1;
    reg [CW-1:0]    coarse1;
    reg             bank1, br_s1, br_c1;
    reg [2:0]       flags1;

    always @(posedge clk) begin
        if (rst) begin
            valid1 <= 1'b0;
        end else if (ce) begin
            valid1 <= valid0;
        end
    end

    always @(posedge clk) begin
        if (ce) begin
            sin1    <= sin0;
            cos1    <= cos0;
            coarse1 <= coarse0;
            bank1   <= bank0;
            flags1  <= flags0;
            br_s1   <= br_s0;
            br_c1   <= br_c0;
        end
    end

    // ---- the bank pipeline: registers read one clock enable ahead -------------------------------
    // bank_d[k] is bank1 after k+1 clock enables. A block taking its sample after N clock enables
    // (the sum of the latencies before it) sees the sample's bank in bank_d[N-1]; one clock enable
    // ahead it is in bank_d[N-2], which selects the registers it takes with the sample. The
    // latencies must equal the blocks' LATENCY constants.
    localparam integer LAT_WL = WAVE_LUT_LATENCY;
    localparam integer LAT_Q  = QUADRATURE_LATENCY;
    localparam integer LAT_C  = CORDIC_STAGES + CORDIC_LATENCY_BASE;
    localparam integer LAT_P  = PERIOD_COUNT_LATENCY;
    localparam integer LAT_T  = TRIM * TRIM_LATENCY;    // fringe_trim (TRIM = 1)
    localparam integer TAP_Q  = LAT_WL - 2;             // quadrature coefficients
    localparam integer TAP_X  = LAT_WL + LAT_Q - 2;                  // CANCEL_FREQ (CANCEL = 1)
    localparam integer TAP_C  = LAT_WL + LAT_Q + LAT_X + LAT_C - 2;  // magnitude thresholds, COARSE_OFS
    localparam integer TAP_P  = LAT_WL + LAT_Q + LAT_X + LAT_C + LAT_P + LAT_T - 2;  // ZERO, DIR
    reg [TAP_P:0] bank_d;

    always @(posedge clk) begin
        if (ce) begin
            bank_d <= {bank_d[TAP_P-1:0], bank1};
        end
    end

    wire bank_q = bank_d[TAP_Q];
    wire bank_c = bank_d[TAP_C];
    wire bank_p = bank_d[TAP_P];
    reg  [WAVE_W-1:0] ofs_s_r, ofs_c_r;
    reg  [COEF_W-1:0] k_ss_r, k_sc_r, k_cc_r;
    reg  [AMP_W-1:0]  amp_low, amp_high;
    reg  [POS_W:0]    coarse_ofs_r;
    reg  [POS_W-1:0]  zero_r;
    reg               dir_r;

    always @(posedge clk) begin
        if (ce) begin
            ofs_s_r      <= regs[{bank_q, REG_OFS_S}][WAVE_W-1:0];
            ofs_c_r      <= regs[{bank_q, REG_OFS_C}][WAVE_W-1:0];
            k_ss_r       <= regs[{bank_q, REG_K_SS}][COEF_W-1:0];
            k_sc_r       <= regs[{bank_q, REG_K_SC}][COEF_W-1:0];
            k_cc_r       <= regs[{bank_q, REG_K_CC}][COEF_W-1:0];
            amp_low      <= regs[{bank_c, REG_AMP_LOW}][AMP_W-1:0];
            amp_high     <= regs[{bank_c, REG_AMP_HIGH}][AMP_W-1:0];
            coarse_ofs_r <= regs[{bank_c, REG_COARSE_OFS}][POS_W:0];
            zero_r       <= regs[{bank_p, REG_ZERO}][POS_W-1:0];
            dir_r        <= regs[{bank_p, REG_DIR}][0];
        end
    end

    // ---- stages 3..6: waveform tables ------------------------------------------------------------
    localparam integer U_WL = DX_W + CW + 1;   // {dx, coarse, bank}
    wire              wl_valid;
    wire [WAVE_W-1:0] xs, xc;
    wire              clip_s, clip_c;
    wire [U_WL-1:0]   wl_user;
    wire              wl_valid_c;
    wire [0:0]        wl_user_c;

    fringe_wave_lut #(
        .ADC_W(ADC_W), .WAVE_ADDR_W(WAVE_ADDR_W), .WAVE_W(WAVE_W), .INIT_FILE(WAVE_SIN_INIT), .USER_W(U_WL)
    ) u_wave_sin (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(valid1), .adc(sin1), .branch(br_s1), .bank(bank1), .in_user({sin1, cos1, flags1, coarse1, bank1}),
        .wr_en(wr_sin), .wr_addr(wave_wr_addr), .wr_data(wr_data[2*WAVE_W-1:0]),
        .out_valid(wl_valid), .x(xs), .clip(clip_s), .out_user(wl_user)
    );

    // Same latency as the sine table: its valid and sideband duplicate the sine's.
    fringe_wave_lut #(
        .ADC_W(ADC_W), .WAVE_ADDR_W(WAVE_ADDR_W), .WAVE_W(WAVE_W), .INIT_FILE(WAVE_COS_INIT), .USER_W(1)
    ) u_wave_cos (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(valid1), .adc(cos1), .branch(br_c1), .bank(bank1), .in_user(1'b0),
        .wr_en(wr_cos), .wr_addr(wave_wr_addr), .wr_data(wr_data[2*WAVE_W-1:0]),
        .out_valid(wl_valid_c), .x(xc), .clip(clip_c), .out_user(wl_user_c)
    );

    wire            wl_bank   = wl_user[0];
    wire [CW-1:0]   wl_coarse = wl_user[CW:1];
    wire [DX_W-1:0] wl_dx     = wl_user[U_WL-1 -: DX_W];
    // CLIP_*: the raw ADC codes (with the normaliser in front, the table inputs are not the raw codes)
    wire            wl_clip_s = (DRIFT != 0) ? wl_dx[0] : clip_s;
    wire            wl_clip_c = (DRIFT != 0) ? wl_dx[1] : clip_c;

    // ---- stages 7..11: quadrature, coefficients of the sample's bank ----------------------------
    localparam integer U_Q = DX_W + CW + 3;    // {dx, coarse, clip_c, clip_s, bank}
    wire              q_valid;
    wire [WAVE_W-1:0] qs, qc;
    wire              q_sat;
    wire [U_Q-1:0]    q_user;

    fringe_quadrature #(.WAVE_W(WAVE_W), .COEF_W(COEF_W), .USER_W(U_Q), .SHARED_MUL(COMPACT)) u_quad (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(wl_valid), .xs(xs), .xc(xc), .in_user({wl_dx, wl_coarse, wl_clip_c, wl_clip_s, wl_bank}),
        .ofs_s(ofs_s_r), .ofs_c(ofs_c_r), .k_ss(k_ss_r), .k_sc(k_sc_r), .k_cc(k_cc_r),
        .out_valid(q_valid), .s(qs), .c(qc), .sat(q_sat), .out_user(q_user)
    );

    wire              q_any = q_sat | q_user[U_Q-DX_W+2];  // the quadrature or the normaliser (dx[2]) saturated

    // ---- [stages 12..15: fringe_canceller (CANCEL = 1), NCO word of the sample's bank] -----------
    wire              x_valid;
    wire [WAVE_W-1:0] x_c, x_s;
    wire              x_any;                    // q_any, or the canceller's subtraction or coefficients saturated
    wire [U_Q-1:0]    x_user;

    generate
        if (CANCEL != 0) begin : g_cancel
            reg  [REG_W-1:0] freq_r;             // CANCEL_FREQ, read one clock enable ahead like the others
            wire             x_sat, x_tsat;
            wire [U_Q:0]     xu;

            always @(posedge clk) begin
                if (ce) begin
                    freq_r <= regs[{bank_d[TAP_X], REG_CANCEL_FREQ}];
                end
            end

            fringe_canceller #(
                .WAVE_W(WAVE_W), .LUT_W(CANCEL_LUT_W), .C_W(CANCEL_C_W), .BLOCK_LOG2(CANCEL_BLOCK_LOG2),
                .MU_LOG2(CANCEL_MU_LOG2), .A_FRAC(CANCEL_A_FRAC), .A_W(CANCEL_A_W), .GEAR_OFFSET(CANCEL_GEAR_OFFSET),
                .LUT_INIT(CANCEL_LUT_INIT), .USER_W(U_Q + 1)
            ) u_cancel (
                .clk(clk), .rst(rst), .ce(ce),
                .in_valid(q_valid), .c(qc), .s(qs), .freq(freq_r), .in_user({q_any, q_user}),
                .out_valid(x_valid), .c_out(x_c), .s_out(x_s), .sat(x_sat), .track_sat(x_tsat), .out_user(xu)
            );

            assign x_user = xu[U_Q-1:0];
            assign x_any  = xu[U_Q] | x_sat | x_tsat;
        end else begin : g_no_cancel
            assign x_valid = q_valid;
            assign x_c     = qc;
            assign x_s     = qs;
            assign x_user  = q_user;
            assign x_any   = q_any;
        end
    endgenerate

    // ---- stages 12..CORDIC_STAGES+13 (+ 4 with CANCEL = 1): CORDIC (x = c, y = s) ------------------
    localparam integer U_C = DX_W + CW + 4;    // {dx, coarse, sat, clip_c, clip_s, bank}
    wire [DX_W-1:0]   x_dx  = x_user[U_Q-1 -: DX_W];
    wire              c_valid;
    wire [FINE_W-1:0] phase;
    wire [AMP_W-1:0]  mag;
    wire [U_C-1:0]    c_user;

    wire              c_ready;   // always 1 here: the admission above spaces the samples

    fringe_cordic #(
        .IN_W(WAVE_W), .FINE_W(FINE_W), .STAGES(CORDIC_STAGES), .GUARD(CORDIC_GUARD), .USER_W(U_C),
        .ITERATIVE(COMPACT)
    ) u_cordic (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(x_valid), .x(x_c), .y(x_s), .in_user({x_dx, x_user[CW+2:3], x_any, x_user[2:0]}), .ready(c_ready),
        .out_valid(c_valid), .phase(phase), .mag(mag), .out_user(c_user)
    );

    wire          c_bank   = c_user[0];
    wire [CW-1:0] c_coarse = c_user[CW+3:4];
    wire [DX_W-1:0] c_dx   = c_user[U_C-1 -: DX_W];
    // magnitude flags with the thresholds of the sample's bank (registered above)
    wire             f_low    = mag < amp_low;
    wire             f_high   = mag > amp_high;

    // ---- period count ----------------------------------------------------------------------------
    localparam integer U_P = AMP_W + 6; // {mag, amp_high, amp_low, sat, clip_c, clip_s, bank}
    wire             p_valid;
    wire [POS_W-1:0] p_pos;
    wire             p_overspeed, p_coarse_err;
    wire [U_P-1:0]   p_user;

    fringe_period_count #(
        .FINE_W(FINE_W), .LINES(LINES), .COARSE_W(COARSE_W), .USER_W(U_P)
    ) u_count (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(c_valid), .phase(phase), .coarse(c_coarse),
        .coarse_ofs(coarse_ofs_r),
        .in_user({mag, f_high, f_low, c_user[3:0]}),
        .out_valid(p_valid), .pos(p_pos), .overspeed(p_overspeed), .coarse_err(p_coarse_err),
        .out_user(p_user)
    );

    // status sideband from here on, its bits the generated STATUS_* (fringe.fixed.regmap)
    localparam integer U_L = STATUS_W;
    wire [U_L-1:0] p_status;
    assign p_status[STATUS_CLIP_SIN]   = p_user[1];
    assign p_status[STATUS_CLIP_COS]   = p_user[2];
    assign p_status[STATUS_AMP_LOW]    = p_user[4];
    assign p_status[STATUS_AMP_HIGH]   = p_user[5];
    assign p_status[STATUS_OVERSPEED]  = p_overspeed;
    assign p_status[STATUS_COARSE_ERR] = p_coarse_err;
    assign p_status[STATUS_SATURATED]  = p_user[3];
    assign p_status[STATUS_BANK]       = p_user[0];

    // ---- closed-loop trim (TRIM = 1), tables and bank as every other stage ------------------------
    wire             t_valid;
    wire [POS_W-1:0] t_pos;
    wire [U_L-1:0]   t_status;

    generate
        if (TRIM != 0) begin : g_trim
            wire           trim_sat, trim_dir;
            wire [U_L-1:0] trim_user;

            fringe_trim #(
                .LINES(LINES), .FINE_W(FINE_W), .AMP_W(AMP_W), .SPEED_LOG2(TRIM_SPEED_LOG2),
                .MAP_PSI_W(TRIM_MAP_PSI_W), .MAP_PHI_W(TRIM_MAP_PHI_W), .TRIM_W(TRIM_W), .TRIM_FRAC(TRIM_FRAC),
                .G_SHIFT(TRIM_G_SHIFT), .SECT_RECIP(TRIM_SECT_RECIP), .SECT_SHIFT(TRIM_SECT_SHIFT),
                .START_SPEED(TRIM_START_SPEED), .MAG_SMOOTH_LOG2(TRIM_MAG_SMOOTH_LOG2),
                .MAP_INIT(TRIM_MAP_INIT), .SPEED_INIT(TRIM_SPEED_INIT), .AMP_INIT(TRIM_AMP_INIT), .USER_W(U_L)
            ) u_trim (
                .clk(clk), .rst(rst), .ce(ce),
                .in_valid(p_valid), .pos(p_pos), .mag(p_user[U_P-1:6]), .bank(p_status[STATUS_BANK]), .in_user(p_status),
                .wr_en(wr_trim), .wr_sel(wr_trim_sel), .wr_addr(trim_wr_addr), .wr_data(wr_data[2*TRIM_W-1:0]),
                .out_valid(t_valid), .pos_out(t_pos), .dir(trim_dir), .sat(trim_sat), .out_user(trim_user)
            );

            // a clipped trim is a saturation like the quadrature's
            wire [U_L-1:0] trim_sat_bit = {{(U_L-1){1'b0}}, trim_sat} << STATUS_SATURATED;
            assign t_status = trim_user | trim_sat_bit;
            wire unused_trim = &{1'b0, trim_dir};
        end else begin : g_no_trim
            assign t_valid  = p_valid;
            assign t_pos    = p_pos;
            assign t_status = p_status;
            wire unused_trim = &{1'b0, wr_trim, wr_trim_sel, trim_wr_addr, p_user[U_P-1:6]};
        end
    endgenerate

    // ---- long-period table, zero and direction -------------------------------------------------
    wire [U_L-1:0] l_user;

    fringe_long_period #(
        .LINES(LINES), .FINE_W(FINE_W), .LP_ADDR_W(LP_ADDR_W), .LP_W(LP_W), .LP_FRAC(LP_FRAC),
        .LP_IF(LP_IF), .LP_RECIP(LP_RECIP), .LP_SHIFT(LP_SHIFT), .INIT_FILE(LP_INIT), .USER_W(U_L)
    ) u_long (
        .clk(clk), .rst(rst), .ce(ce),
        .in_valid(t_valid), .pos(t_pos), .bank(t_status[STATUS_BANK]),
        .zero(zero_r), .dir(dir_r),
        .in_user(t_status),
        .wr_en(wr_lp), .wr_addr(lp_wr_addr), .wr_data(wr_data[2*LP_W-1:0]),
        .out_valid(out_valid), .pos_out(pos), .out_user(l_user)
    );

    // The cosine table runs in step with the sine table (same latency): its valid and sideband
    // are duplicates. cfg_wr_data above the widest table word is not used.
    wire unused_ok = &{1'b0, wl_valid_c, wl_user_c, wr_data, wr_word, c_bank, c_ready};

    // status word: the STATUS_* bits (the blocks' sideband, registered)
    assign status = l_user;

endmodule

`default_nettype wire
