-- fringe_core: the whole signal-correction pipeline of a sin/cos encoder, one sample per clock
-- (COMPACT = 1: one per CLOCKS_PER_SAMPLE = CORDIC_STAGES clock enables, in_ready = '0' in between;
-- the CORDIC iterates, the quadrature's products share one multiplier; the same words and LATENCY):
--
--   sin, cos s(ADC_W) [-> fringe_drift_normaliser, DRIFT = 1] -> branch select (registered)
--   -> fringe_wave_lut x2 -> fringe_quadrature [-> fringe_canceller, CANCEL = 1] -> fringe_cordic
--   [-> fringe_drift_observer, DRIFT = 1: the block's update back to the normaliser]
--   -> magnitude flags -> fringe_period_count (+ coarse u(COARSE_W)) [-> fringe_trim, TRIM = 1]
--   -> fringe_long_period -> pos u(POS_W), status (8 bits)
--
-- Every sample takes the active register and table bank when it is accepted and carries it along;
-- the configuration write port (independent of ce) writes the inactive bank, CTRL swaps the banks.
-- rst (synchronous, active high) clears the sample pipeline only; ce = 0 freezes it.
--
-- LATENCY = CORDIC_STAGES + 25 (+ 13 with TRIM = 1, + 4 with DRIFT = 1, + 4 with CANCEL = 1) clock
-- enables from in_valid to out_valid (fringe_core_latency, fringe_pkg).
-- Parameters, ports, banks and pipeline: docs/blocks/fringe_core.md (formats, registers, status word:
-- docs/architecture.md). Bit-exact model: model/fringe/fixed/core.py (run_core, run_core_banks).
-- VHDL-2008 twin of rtl/verilog/fringe_core.v (same generics, ports, latency and bit-exact behaviour).

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_core is
    generic (
        -- BEGIN generated generics (written by python sim/hdlgen.py; do not edit)
        ADC_W                : integer := 12;  -- ADC code width (signed), 4..24
        LINES                : integer := 256; -- signal periods per revolution, 1..2^20 (POS_W = clog2(LINES) + FINE_W <= 31)
        COARSE_W             : integer := 9;   -- coarse code bits, 0 = none (periods are counted); else 2^COARSE_W >= LINES, <= FINE_W-2
        WAVE_ADDR_W          : integer := 8;   -- waveform table address bits per branch, 2..min(ADC_W-1, 15)
        WAVE_W               : integer := 18;  -- waveform table / quadrature data width, 8..31
        COEF_W               : integer := 18;  -- quadrature gain width (COEF_W-2 fraction bits), 8..27
        FINE_W               : integer := 16;  -- fine phase bits per signal period, 8..30
        CORDIC_STAGES        : integer := 18;  -- CORDIC micro-rotations, 4..32
        CORDIC_GUARD         : integer := 3;   -- extra fraction bits inside the CORDIC, 0..8
        COMPACT              : integer := 0;   -- 1 = time-multiplexed: one sample per CORDIC_STAGES clocks, iterated CORDIC (same words)
        LP_ADDR_W            : integer := 8;   -- long-period table entries per revolution = 2^LP_ADDR_W, <= 16
        LP_W                 : integer := 18;  -- long-period table value/slope width, <= 32
        LP_FRAC              : integer := 4;   -- fraction bits of the long-period correction (fine counts)
        LP_IF                : integer := 8;   -- interpolation fraction bits of the long-period table
        LP_RECIP             : natural := 1;   -- long-period index multiplier (long_period.index_mapping; < 2^31 in VHDL)
        LP_SHIFT             : integer := 16;  -- long-period index shift (long_period.index_mapping)
        -- fringe_trim (closed-loop corrections): built only with TRIM = 1
        TRIM                 : integer := 0;   -- 1 = fringe_trim between the period count and the long-period table (docs/blocks/fringe_trim.md)
        TRIM_SPEED_LOG2      : integer := 5;   -- speed window 2^TRIM_SPEED_LOG2 samples, 0..8
        TRIM_MAP_PSI_W       : integer := 6;   -- 2^TRIM_MAP_PSI_W error-map sectors per revolution, 0..8
        TRIM_MAP_PHI_W       : integer := 5;   -- 2^TRIM_MAP_PHI_W error-map bins per period, 2..min(10, FINE_W-1); TRIM_MAP_PSI_W + TRIM_MAP_PHI_W <= 15
        TRIM_W               : integer := 18;  -- trim table value/slope width, 8..24
        TRIM_FRAC            : integer := 4;   -- fraction bits of the trim (fine counts), 0..16
        TRIM_G_SHIFT         : integer := 24;  -- right shift of the speed and magnitude products, 1..48
        TRIM_SECT_RECIP      : natural := 1;   -- sector multiplier (trim.sector_mapping; < 2^31 in VHDL)
        TRIM_SECT_SHIFT      : integer := 18;  -- sector shift (trim.sector_mapping)
        TRIM_START_SPEED     : integer := 0;   -- speed of the first sample after reset (no window yet), fine counts per 2^TRIM_SPEED_LOG2 samples, -REV/2..REV/2-1
        TRIM_MAG_SMOOTH_LOG2 : integer := 0;   -- the magnitude terms take the magnitude's running average over ~2^TRIM_MAG_SMOOTH_LOG2 samples, 0 (the sample's own)..12
        -- the drift tracker (fringe_drift_normaliser, fringe_drift_observer): built only with DRIFT = 1
        DRIFT                : integer := 0;   -- 1 = the drift tracker normalises the ADC codes in front of everything (docs/drift.md)
        DRIFT_BLOCK_LOG2     : integer := 8;   -- samples per tracker block = 2^DRIFT_BLOCK_LOG2, 4..12 (>= 7 in the core with DRIFT_HOLD = 0)
        DRIFT_MU_LOG2        : integer := 1;   -- final tracker step 2^-DRIFT_MU_LOG2 per update (gear shift from 1), 0..8
        DRIFT_OFS_FRAC       : integer := 4;   -- fraction bits of the tracked offsets, 0..8
        DRIFT_GINV_W         : integer := 18;  -- tracked inverse gains u(DRIFT_GINV_W), 8..24
        DRIFT_FWD_W          : integer := 8;   -- 2^DRIFT_FWD_W bins of the forward waveform tables, 2..10
        DRIFT_TABLE_W        : integer := 18;  -- forward table value/slope width, 8..24
        DRIFT_TABLE_FRAC     : integer := 4;   -- fraction bits of the forward tables and W0_S/W0_C, 0..12
        DRIFT_KG_W           : integer := 18;  -- KG_S/KG_C width, 8..24
        DRIFT_KG_SHIFT       : integer := 40;  -- right shift of the gain-loop product, 1..60
        DRIFT_HOLD           : integer := 1;   -- 1 = tracker updates apply at the block boundary, in_ready holds the input until ready; 0 = half a block later, no hold
        -- fringe_canceller (the adaptive interference canceller): built only with CANCEL = 1
        CANCEL               : integer := 0;   -- 1 = fringe_canceller between the quadrature and the CORDIC (docs/blocks/fringe_canceller.md)
        CANCEL_LUT_W         : integer := 10;  -- 2^CANCEL_LUT_W entries of the canceller's sine table, 4..12
        CANCEL_C_W           : integer := 16;  -- canceller sine table value width, 8..18
        CANCEL_BLOCK_LOG2    : integer := 4;   -- samples per canceller update = 2^CANCEL_BLOCK_LOG2, 4..12
        CANCEL_MU_LOG2       : integer := 6;   -- final canceller step 2^-CANCEL_MU_LOG2 per block, 1..12
        CANCEL_A_FRAC        : integer := 4;   -- fraction bits of the canceller coefficients, 0..12
        CANCEL_A_W           : integer := 20;  -- canceller coefficient width, 8..min(32, WAVE_W + CANCEL_A_FRAC)
        CANCEL_GEAR_OFFSET   : integer := 0;   -- the canceller's gear shift starts this many gears lower, 0..CANCEL_MU_LOG2-1
        -- initial contents: $readmemh images, "" = zeros
        REGS_INIT            : string  := "";  -- $readmemh image of the registers, 2 x 32 words of 32 bits
        WAVE_SIN_INIT        : string  := "";  -- $readmemh image of the sine table, both banks
        WAVE_COS_INIT        : string  := "";  -- $readmemh image of the cosine table, both banks
        LP_INIT              : string  := "";  -- $readmemh image of the long-period table, both banks
        TRIM_MAP_INIT        : string  := "";  -- $readmemh image of the trim map, both banks (TRIM = 1)
        TRIM_SPEED_INIT      : string  := "";  -- $readmemh image of the trim speed table, both banks (TRIM = 1)
        TRIM_AMP_INIT        : string  := "";  -- $readmemh image of the trim magnitude table, both banks (TRIM = 1)
        DRIFT_FWD_SIN_INIT   : string  := "";  -- $readmemh image of the drift sine forward table, both banks (DRIFT = 1)
        DRIFT_FWD_COS_INIT   : string  := "";  -- $readmemh image of the drift cosine forward table, both banks (DRIFT = 1)
        CANCEL_LUT_INIT      : string  := ""   -- $readmemh image of the canceller's sine table (CANCEL = 1; canceller.sine_table)
        -- END generated generics
    );
    port (
        clk         : in  std_logic;
        rst         : in  std_logic;      -- synchronous, active high: clears the sample pipeline
        ce          : in  std_logic;      -- clock enable: the pipeline advances when 1
        -- sample in: taken at a clock enable with in_valid = '1' and in_ready = '1'
        in_valid    : in  std_logic;
        in_ready    : out std_logic;      -- '1' with COMPACT = 0; COMPACT = 1: '0' for CLOCKS_PER_SAMPLE-1 clock enables after a sample;
                                          -- DRIFT = 1, DRIFT_HOLD = 1: also '0' while a tracker block boundary waits for its update
        sin         : in  std_logic_vector(ADC_W - 1 downto 0);   -- s(ADC_W)
        cos         : in  std_logic_vector(ADC_W - 1 downto 0);   -- s(ADC_W)
        coarse      : in  std_logic_vector(maximum(COARSE_W, 1) - 1 downto 0);  -- u(COARSE_W); 1 bit, ignored, when 0
        -- sample out
        out_valid   : out std_logic;
        -- u(POS_W), POS_W = clog2(LINES * 2^FINE_W), fine counts, [0, LINES*2^FINE_W)
        pos         : out std_logic_vector(clog2(LINES) + FINE_W - 1 downto 0);
        status      : out std_logic_vector(7 downto 0);           -- status word, bit 7 = BANK
        -- configuration write port
        cfg_wr_en   : in  std_logic;
        cfg_wr_addr : in  std_logic_vector(19 downto 0);
        cfg_wr_data : in  std_logic_vector(63 downto 0);
        active_bank : out std_logic
    );
end entity fringe_core;

architecture rtl of fringe_core is

    constant POS_W : integer := clog2(LINES) + FINE_W;     -- clog2(LINES * 2^FINE_W)
    constant CW    : integer := maximum(COARSE_W, 1);      -- coarse port width

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_min("fringe_core", "LINES", LINES, 1);
        assert POS_W <= 31
            report "fringe_core: POS_W = clog2(LINES) + FINE_W = " & integer'image(POS_W)
                   & " > 31: registers are 32-bit" severity failure;
        assert WAVE_ADDR_W + 1 <= 16
            report "fringe_core: WAVE_ADDR_W = " & integer'image(WAVE_ADDR_W)
                   & ": a table bank must fit the 16-bit word address" severity failure;
        assert LP_ADDR_W <= 16
            report "fringe_core: LP_ADDR_W = " & integer'image(LP_ADDR_W)
                   & " > 16: a table bank must fit the 16-bit word address" severity failure;
        assert WAVE_W <= 31 and ADC_W <= 31
            report "fringe_core: WAVE_W = " & integer'image(WAVE_W) & ", ADC_W = " & integer'image(ADC_W)
                   & ": register fields must fit 32 bits" severity failure;
        assert TRIM = 0 or TRIM = 1
            report "fringe_core: TRIM = " & integer'image(TRIM) & " must be 0 or 1" severity failure;
        assert TRIM = 0 or TRIM_MAP_PSI_W + TRIM_MAP_PHI_W <= 15
            report "fringe_core: TRIM_MAP_PSI_W + TRIM_MAP_PHI_W = " & integer'image(TRIM_MAP_PSI_W + TRIM_MAP_PHI_W)
                   & " > 15: a trim map bank must fit the 16-bit word address" severity failure;
        assert COMPACT = 0 or COMPACT = 1
            report "fringe_core: COMPACT = " & integer'image(COMPACT) & " must be 0 or 1" severity failure;
        assert DRIFT = 0 or DRIFT = 1
            report "fringe_core: DRIFT = " & integer'image(DRIFT) & " must be 0 or 1" severity failure;
        assert CANCEL = 0 or CANCEL = 1
            report "fringe_core: CANCEL = " & integer'image(CANCEL) & " must be 0 or 1" severity failure;
        assert LP_W <= 32
            report "fringe_core: LP_W = " & integer'image(LP_W)
                   & " > 32: a table word {slope, value} must fit cfg_wr_data" severity failure;
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LAT_T   : integer := TRIM * TRIM_LATENCY;   -- fringe_trim (TRIM = 1)
    constant LATENCY : integer := core_latency(CORDIC_STAGES, TRIM, DRIFT, CANCEL);
    -- clock enables from one sample to the next at full speed (fringe.fixed.config clocks_per_sample)
    constant CLOCKS_PER_SAMPLE : integer := 1 + COMPACT * (CORDIC_STAGES + CORDIC_ITER_CLOCKS_BASE - 1);  -- COMPACT is 0 or 1
    constant AMP_W   : integer := WAVE_W + 1;   -- CORDIC magnitude u(WAVE_W+1)
    constant BR_W    : integer := ADC_W + 1;    -- branch thresholds s(ADC_W+1)

    -- register indices REG_*, CTRL_WORD: fringe_pkg (generated from model/fringe/fixed/regmap.py)

    subtype regs_t is word_array(0 to 2 * N_REGS - 1)(REG_W - 1 downto 0);   -- bank 0, then bank 1

    signal regs   : regs_t;                 -- from fringe_regs
    signal regs_q : std_logic_vector(2 * N_REGS * REG_W - 1 downto 0);
    signal bank_r : std_logic;

    -- field `lo`..`lo+w-1` of register `idx` of bank `b`
    function reg_field(r : regs_t; b : std_logic; idx : integer; w : integer) return std_logic_vector is
    begin
        if b = '1' then
            return r(32 + idx)(w - 1 downto 0);
        end if;
        return r(idx)(w - 1 downto 0);
    end function reg_field;

    -- the landing table write (fringe_regs)
    signal wr_sin, wr_cos, wr_lp, wr_trim, wr_fwd, wr_fwd_sel : std_logic;
    signal wr_trim_sel  : std_logic_vector(1 downto 0);
    signal wr_word      : std_logic_vector(15 downto 0);
    signal wr_bank_r    : std_logic;
    signal wr_data      : std_logic_vector(63 downto 0);
    signal wave_wr_addr : std_logic_vector(WAVE_ADDR_W + 1 downto 0);
    signal lp_wr_addr   : std_logic_vector(LP_ADDR_W downto 0);
    signal trim_wr_addr : std_logic_vector(TRIM_MAP_PSI_W + TRIM_MAP_PHI_W + 1 downto 0);

    -- the drift normaliser (DRIFT = 1) or the raw codes; dx = {y_sin, y_cos, norm_sat, clip_c, clip_s}
    -- travels with the sample to the CORDIC output (the tracker's observer), CLIP_* of the raw codes
    constant DX_W   : integer := 2 * ADC_W + 3;
    constant LAT_X  : integer := CANCEL * CANCEL_LATENCY;   -- fringe_canceller (CANCEL = 1)
    constant PIPE_D : integer := CORE_INPUT_LATENCY + WAVE_LUT_LATENCY + QUADRATURE_LATENCY + LAT_X + CORDIC_STAGES
                                 + CORDIC_LATENCY_BASE;   -- normaliser outputs -> CORDIC outputs
    signal raw_clip_s, raw_clip_c : std_logic;
    signal n_valid      : std_logic;
    signal take_in      : std_logic;    -- the sample is taken (in_valid and in_ready)
    signal in_ready_i   : std_logic;
    signal admit_ready  : std_logic;    -- the COMPACT spacing
    signal drift_ready  : std_logic;    -- fringe_drift_normaliser's hold (DRIFT = 1, DRIFT_HOLD = 1)
    signal c_ready      : std_logic;    -- always '1': the admission spaces the samples
    signal n_sin, n_cos : std_logic_vector(ADC_W - 1 downto 0);
    signal n_sat, n_bank, n_clip_s, n_clip_c : std_logic;
    signal n_coarse     : std_logic_vector(CW - 1 downto 0);

    -- stage 1: the sample and its bank's branch thresholds
    signal flags0, flags1 : std_logic_vector(2 downto 0);   -- {norm_sat, clip_c, clip_s}
    signal valid0       : std_logic;
    signal sin0, cos0   : std_logic_vector(ADC_W - 1 downto 0);
    signal coarse0      : std_logic_vector(CW - 1 downto 0);
    signal bank0        : std_logic;
    signal mid_s, hi_s, lo_s, mid_c, hi_c, lo_c : signed(BR_W - 1 downto 0);
    -- stage 2: branch selects
    signal valid1       : std_logic;
    signal sin1, cos1   : std_logic_vector(ADC_W - 1 downto 0);
    signal coarse1      : std_logic_vector(CW - 1 downto 0);
    signal bank1        : std_logic;
    signal br_s1, br_c1 : std_logic;

    -- the bank pipeline: bank_d(k) is bank1 after k+1 clock enables. A block taking its sample
    -- after N clock enables sees the sample's bank in bank_d(N-1); one clock enable ahead it is in
    -- bank_d(N-2), which selects the registers it takes with the sample. The latencies must equal
    -- the blocks' LATENCY constants.
    constant LAT_WL : integer := WAVE_LUT_LATENCY;
    constant LAT_Q  : integer := QUADRATURE_LATENCY;
    constant LAT_C  : integer := CORDIC_STAGES + CORDIC_LATENCY_BASE;
    constant LAT_P  : integer := PERIOD_COUNT_LATENCY;
    constant TAP_Q  : integer := LAT_WL - 2;             -- quadrature coefficients
    constant TAP_X  : integer := LAT_WL + LAT_Q - 2;                  -- CANCEL_FREQ (CANCEL = 1)
    constant TAP_C  : integer := LAT_WL + LAT_Q + LAT_X + LAT_C - 2;  -- magnitude thresholds, COARSE_OFS
    constant TAP_P  : integer := LAT_WL + LAT_Q + LAT_X + LAT_C + LAT_P + LAT_T - 2;  -- ZERO, DIR
    signal bank_d       : std_logic_vector(TAP_P downto 0);
    signal ofs_s_r, ofs_c_r : std_logic_vector(WAVE_W - 1 downto 0);
    signal k_ss_r, k_sc_r, k_cc_r : std_logic_vector(COEF_W - 1 downto 0);
    signal amp_low, amp_high : std_logic_vector(AMP_W - 1 downto 0);
    signal coarse_ofs_r : std_logic_vector(POS_W downto 0);

    -- waveform tables: user {dx, coarse, bank}
    constant U_WL : integer := DX_W + CW + 1;
    signal wl_in_user   : std_logic_vector(U_WL - 1 downto 0);
    signal wl_valid     : std_logic;
    signal xs, xc       : std_logic_vector(WAVE_W - 1 downto 0);
    signal clip_s       : std_logic;
    signal clip_c       : std_logic;
    signal wl_user      : std_logic_vector(U_WL - 1 downto 0);
    signal wl_valid_c   : std_logic;            -- duplicate of wl_valid
    signal wl_user_c    : std_logic_vector(0 downto 0);
    signal wl_bank      : std_logic;
    signal wl_dx        : std_logic_vector(DX_W - 1 downto 0);
    signal wl_clip_s, wl_clip_c : std_logic;

    -- quadrature: user {dx, coarse, clip_c, clip_s, bank}
    constant U_Q : integer := DX_W + CW + 3;
    signal q_in_user    : std_logic_vector(U_Q - 1 downto 0);
    signal q_valid      : std_logic;
    signal qs, qc       : std_logic_vector(WAVE_W - 1 downto 0);
    signal q_sat        : std_logic;
    signal q_user       : std_logic_vector(U_Q - 1 downto 0);

    -- CORDIC: user {dx, coarse, sat, clip_c, clip_s, bank}
    constant U_C : integer := DX_W + CW + 4;
    signal q_any        : std_logic;           -- the quadrature or the normaliser saturated
    -- the canceller (CANCEL = 1) or the quadrature's words
    signal x_valid      : std_logic;
    signal x_c, x_s     : std_logic_vector(WAVE_W - 1 downto 0);
    signal x_any        : std_logic;           -- q_any, or the canceller's subtraction or coefficients saturated
    signal x_user       : std_logic_vector(U_Q - 1 downto 0);
    signal c_dx         : std_logic_vector(DX_W - 1 downto 0);
    signal c_in_user    : std_logic_vector(U_C - 1 downto 0);
    signal c_valid      : std_logic;
    signal phase        : std_logic_vector(FINE_W - 1 downto 0);
    signal mag          : std_logic_vector(AMP_W - 1 downto 0);
    signal c_user       : std_logic_vector(U_C - 1 downto 0);
    signal f_low        : std_logic;
    signal f_high       : std_logic;

    -- period count: user {mag, amp_high, amp_low, sat, clip_c, clip_s, bank}
    constant U_P : integer := AMP_W + 6;
    signal p_in_user    : std_logic_vector(U_P - 1 downto 0);
    signal p_valid      : std_logic;
    signal p_pos        : std_logic_vector(POS_W - 1 downto 0);
    signal p_overspeed  : std_logic;
    signal p_coarse_err : std_logic;
    signal p_user       : std_logic_vector(U_P - 1 downto 0);
    signal p_zero       : std_logic_vector(POS_W - 1 downto 0);
    signal p_dir        : std_logic_vector(0 downto 0);

    -- long period: user {bank, sat, coarse_err, overspeed, amp_high, amp_low, clip_c, clip_s}
    constant U_L : integer := STATUS_W;
    signal p_status     : std_logic_vector(U_L - 1 downto 0);
    signal t_valid      : std_logic;
    signal t_pos        : std_logic_vector(POS_W - 1 downto 0);
    signal t_status     : std_logic_vector(U_L - 1 downto 0);
    signal l_user       : std_logic_vector(U_L - 1 downto 0);

begin

    -- ---- register file, CTRL and write decode (configuration, not reset): fringe_regs ------------
    u_regs : entity work.fringe_regs
        generic map (WAVE_ADDR_W => WAVE_ADDR_W, LP_ADDR_W => LP_ADDR_W, MAP_PSI_W => TRIM_MAP_PSI_W,
                     MAP_PHI_W => TRIM_MAP_PHI_W, FWD_W => DRIFT_FWD_W, REGS_INIT => REGS_INIT)
        port map (clk => clk, cfg_wr_en => cfg_wr_en, cfg_wr_addr => cfg_wr_addr, cfg_wr_data => cfg_wr_data,
                  regs_q => regs_q, active_bank => bank_r,
                  wr_sin => wr_sin, wr_cos => wr_cos, wr_lp => wr_lp, wr_trim => wr_trim, wr_trim_sel => wr_trim_sel,
                  wr_fwd => wr_fwd, wr_fwd_sel => wr_fwd_sel, wr_word => wr_word, wr_bank => wr_bank_r,
                  wr_data => wr_data);

    -- regs({bank, index}): the bank taps below read the words of their sample's bank
    g_regs : for i in 0 to 2 * N_REGS - 1 generate
        regs(i) <= regs_q(REG_W * i + REG_W - 1 downto REG_W * i);
    end generate g_regs;

    active_bank <= bank_r;

    wave_wr_addr <= wr_bank_r & std_logic_vector(wr_word(WAVE_ADDR_W downto 0));
    lp_wr_addr   <= wr_bank_r & std_logic_vector(wr_word(LP_ADDR_W - 1 downto 0));
    trim_wr_addr <= wr_bank_r & std_logic_vector(wr_word(TRIM_MAP_PSI_W + TRIM_MAP_PHI_W downto 0));

    -- ---- sample admission: COMPACT = 1 takes a sample every CLOCKS_PER_SAMPLE clock enables -------
    -- The spacing holds through the pipeline (every stage advances on the same ce), so the iterated
    -- CORDIC is free whenever a sample reaches it.
    take_in  <= in_valid and in_ready_i;
    in_ready_i <= admit_ready and drift_ready;
    in_ready <= in_ready_i;

    g_admit : if COMPACT /= 0 generate
        signal wait_r : integer range 0 to CLOCKS_PER_SAMPLE - 1;  -- clock enables until the next sample
    begin
        p_admit : process (clk)
        begin
            if rising_edge(clk) then
                if rst = '1' then
                    wait_r <= 0;
                elsif ce = '1' then
                    if take_in = '1' then
                        wait_r <= CLOCKS_PER_SAMPLE - 1;
                    elsif wait_r /= 0 then
                        wait_r <= wait_r - 1;
                    end if;
                end if;
            end if;
        end process p_admit;

        admit_ready <= '1' when wait_r = 0 else '0';
    else generate
        admit_ready <= '1';
    end generate g_admit;

    -- ---- the drift normaliser (DRIFT = 1) or the raw codes ----------------------------------------
    -- The sample takes the active bank when it is accepted; the flags of the raw codes (CLIP_*) and of
    -- the normalisation travel with it, with the normalised codes the observer needs at the CORDIC output.
    raw_clip_s <= '1' when sin = std_logic_vector(to_signed(-2 ** (ADC_W - 1), ADC_W))
                        or sin = std_logic_vector(to_signed(2 ** (ADC_W - 1) - 1, ADC_W)) else '0';
    raw_clip_c <= '1' when cos = std_logic_vector(to_signed(-2 ** (ADC_W - 1), ADC_W))
                        or cos = std_logic_vector(to_signed(2 ** (ADC_W - 1) - 1, ADC_W)) else '0';
    c_dx <= c_user(U_C - 1 downto U_C - DX_W);

    g_drift : if DRIFT /= 0 generate
        -- fringe_drift_normaliser in front, fringe_drift_observer on each sample's phase PIPE_D clock enables
        -- after its outputs; they hand each other the state and the block's update
        constant OW : integer := ADC_W + DRIFT_OFS_FRAC;   -- OFF
        -- DRIFT_HOLD = 0: block j's update must be resolved when sample (j+1)B + B/2 arrives at full speed
        function timing_ok return boolean is
            constant TOTAL : integer := DRIFT_NORM_LATENCY + PIPE_D + DRIFT_OBS_LATENCY;
        begin
            if DRIFT_HOLD = 0 and DRIFT_BLOCK_LOG2 >= 1 then
                assert TOTAL <= 2 ** (DRIFT_BLOCK_LOG2 - 1) + 1
                    report "fringe_core: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = "
                           & integer'image(DRIFT_NORM_LATENCY) & " + " & integer'image(PIPE_D) & " + "
                           & integer'image(DRIFT_OBS_LATENCY) & " = " & integer'image(TOTAL)
                           & " exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = " & integer'image(2 ** (DRIFT_BLOCK_LOG2 - 1) + 1)
                           & ": the update would come too late"
                    severity failure;
            end if;
            return true;
        end function timing_ok;
        constant TIMING_CHECKED : boolean := timing_ok;
        signal off_s, off_c, upd_off_s, upd_off_c : std_logic_vector(OW - 1 downto 0);
        signal ginv_s, ginv_c, upd_ginv_s, upd_ginv_c : std_logic_vector(DRIFT_GINV_W - 1 downto 0);
        signal track_sat, upd_valid, upd_sat, upd_resolved, upd_take : std_logic;
        signal d_in_user, nu  : std_logic_vector(CW + 2 downto 0);
        signal d_wr_addr      : std_logic_vector(DRIFT_FWD_W downto 0);
        signal c_bank_d       : std_logic;
    begin
        d_in_user <= coarse & bank_r & raw_clip_c & raw_clip_s;
        d_wr_addr <= wr_bank_r & std_logic_vector(wr_word(DRIFT_FWD_W - 1 downto 0));
        c_bank_d  <= c_user(0);

        u_drift_norm : entity work.fringe_drift_normaliser
            generic map (ADC_W => ADC_W, BLOCK_LOG2 => DRIFT_BLOCK_LOG2, OFS_FRAC => DRIFT_OFS_FRAC,
                         GINV_W => DRIFT_GINV_W, HOLD => DRIFT_HOLD, USER_W => CW + 3)
            port map (
                clk => clk, rst => rst, ce => ce,
                in_valid => take_in, raw_sin => sin, raw_cos => cos, in_user => d_in_user, in_ready => drift_ready,
                norm_valid => n_valid, y_sin => n_sin, y_cos => n_cos, norm_sat => n_sat, norm_user => nu,
                upd_valid => upd_valid, upd_off_sin => upd_off_s, upd_off_cos => upd_off_c,
                upd_ginv_sin => upd_ginv_s, upd_ginv_cos => upd_ginv_c, upd_sat => upd_sat,
                upd_resolved => upd_resolved, upd_take => upd_take,
                off_sin => off_s, off_cos => off_c, ginv_sin => ginv_s, ginv_cos => ginv_c, track_sat => track_sat
            );

        u_drift_obs : entity work.fringe_drift_observer
            generic map (ADC_W => ADC_W, FINE_W => FINE_W, BLOCK_LOG2 => DRIFT_BLOCK_LOG2,
                         MU_LOG2 => DRIFT_MU_LOG2, OFS_FRAC => DRIFT_OFS_FRAC, GINV_W => DRIFT_GINV_W,
                         FWD_W => DRIFT_FWD_W, TABLE_W => DRIFT_TABLE_W, TABLE_FRAC => DRIFT_TABLE_FRAC,
                         KG_W => DRIFT_KG_W, KG_SHIFT => DRIFT_KG_SHIFT, HOLD => DRIFT_HOLD,
                         FWD_SIN_INIT => DRIFT_FWD_SIN_INIT, FWD_COS_INIT => DRIFT_FWD_COS_INIT)
            port map (
                clk => clk, rst => rst, ce => ce,
                obs_valid => c_valid, obs_phase => phase,
                obs_y_sin => c_dx(DX_W - 1 downto ADC_W + 3), obs_y_cos => c_dx(ADC_W + 2 downto 3),
                obs_bank => c_bank_d,
                w0_sin => reg_field(regs, c_bank_d, REG_W0_S, ADC_W + DRIFT_TABLE_FRAC),
                w0_cos => reg_field(regs, c_bank_d, REG_W0_C, ADC_W + DRIFT_TABLE_FRAC),
                kg_sin => reg_field(regs, c_bank_d, REG_KG_S, DRIFT_KG_W),
                kg_cos => reg_field(regs, c_bank_d, REG_KG_C, DRIFT_KG_W),
                wr_en => wr_fwd, wr_sel => wr_fwd_sel, wr_addr => d_wr_addr,
                wr_data => wr_data(2 * DRIFT_TABLE_W - 1 downto 0),
                off_sin => off_s, off_cos => off_c, ginv_sin => ginv_s, ginv_cos => ginv_c,
                upd_valid => upd_valid, upd_off_sin => upd_off_s, upd_off_cos => upd_off_c,
                upd_ginv_sin => upd_ginv_s, upd_ginv_cos => upd_ginv_c, upd_sat => upd_sat,
                upd_resolved => upd_resolved, upd_take => upd_take
            );

        n_coarse <= nu(CW + 2 downto 3);
        n_bank   <= nu(2);
        n_clip_c <= nu(1);
        n_clip_s <= nu(0);
    else generate
        drift_ready <= '1';
        n_valid  <= take_in;
        n_sin    <= sin;
        n_cos    <= cos;
        n_sat    <= '0';
        n_bank   <= bank_r;
        n_clip_s <= raw_clip_s;
        n_clip_c <= raw_clip_c;
        n_coarse <= coarse;
    end generate g_drift;

    -- ---- stage 1 (registered): the sample takes the active bank and that bank's branch thresholds --
    -- (the register file read and the compares sit in separate stages: one long path otherwise)
    p_input_valid : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                valid0 <= '0';
                valid1 <= '0';
            elsif ce = '1' then
                valid0 <= n_valid;
                valid1 <= valid0;
            end if;
        end if;
    end process p_input_valid;

    p_stage1 : process (clk)
    begin
        if rising_edge(clk) then
            if ce = '1' then
                sin0    <= n_sin;
                cos0    <= n_cos;
                coarse0 <= n_coarse;
                bank0   <= n_bank;
                flags0  <= n_sat & n_clip_c & n_clip_s;
                mid_s   <= signed(reg_field(regs, n_bank, REG_MID_S, BR_W));
                hi_s    <= signed(reg_field(regs, n_bank, REG_THR_HI_S, BR_W));
                lo_s    <= signed(reg_field(regs, n_bank, REG_THR_LO_S, BR_W));
                mid_c   <= signed(reg_field(regs, n_bank, REG_MID_C, BR_W));
                hi_c    <= signed(reg_field(regs, n_bank, REG_THR_HI_C, BR_W));
                lo_c    <= signed(reg_field(regs, n_bank, REG_THR_LO_C, BR_W));
            end if;
        end if;
    end process p_stage1;

    -- ---- stage 2 (registered): branch selects ------------------------------------------------------
    -- branch_s = cos >= (sin >= MID_S ? THR_HI_S : THR_LO_S), branch_c likewise with sin/cos swapped.
    p_stage2 : process (clk)
        variable s_x, c_x : signed(BR_W - 1 downto 0);
        variable thr      : signed(BR_W - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                sin1    <= sin0;
                cos1    <= cos0;
                coarse1 <= coarse0;
                bank1   <= bank0;
                flags1  <= flags0;
                -- (only on defined inputs: no numeric_std warnings while the inputs are undriven)
                if not is_x(sin0) and not is_x(cos0) then
                    s_x := resize(signed(sin0), BR_W);
                    c_x := resize(signed(cos0), BR_W);
                    if s_x >= mid_s then
                        thr := hi_s;
                    else
                        thr := lo_s;
                    end if;
                    br_s1 <= '1' when c_x >= thr else '0';
                    if c_x >= mid_c then
                        thr := hi_c;
                    else
                        thr := lo_c;
                    end if;
                    br_c1 <= '1' when s_x >= thr else '0';
                else
                    br_s1 <= 'X';
                    br_c1 <= 'X';
                end if;
            end if;
        end if;
    end process p_stage2;

    -- ---- the bank pipeline: registers read one clock enable ahead -------------------------------
    p_bank_d : process (clk)
    begin
        if rising_edge(clk) then
            if ce = '1' then
                bank_d <= bank_d(TAP_P - 1 downto 0) & bank1;
                ofs_s_r      <= reg_field(regs, bank_d(TAP_Q), REG_OFS_S, WAVE_W);
                ofs_c_r      <= reg_field(regs, bank_d(TAP_Q), REG_OFS_C, WAVE_W);
                k_ss_r       <= reg_field(regs, bank_d(TAP_Q), REG_K_SS, COEF_W);
                k_sc_r       <= reg_field(regs, bank_d(TAP_Q), REG_K_SC, COEF_W);
                k_cc_r       <= reg_field(regs, bank_d(TAP_Q), REG_K_CC, COEF_W);
                amp_low      <= reg_field(regs, bank_d(TAP_C), REG_AMP_LOW, AMP_W);
                amp_high     <= reg_field(regs, bank_d(TAP_C), REG_AMP_HIGH, AMP_W);
                coarse_ofs_r <= reg_field(regs, bank_d(TAP_C), REG_COARSE_OFS, POS_W + 1);
                p_zero       <= reg_field(regs, bank_d(TAP_P), REG_ZERO, POS_W);
                p_dir        <= reg_field(regs, bank_d(TAP_P), REG_DIR, 1);
            end if;
        end if;
    end process p_bank_d;

    -- ---- stages 3..6: waveform tables ------------------------------------------------------------
    wl_in_user <= sin1 & cos1 & flags1 & coarse1 & bank1;

    u_wave_sin : entity work.fringe_wave_lut
        generic map (ADC_W => ADC_W, WAVE_ADDR_W => WAVE_ADDR_W, WAVE_W => WAVE_W,
                     INIT_FILE => WAVE_SIN_INIT, USER_W => U_WL)
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => valid1, adc => sin1, branch => br_s1, bank => bank1, in_user => wl_in_user,
            wr_en => wr_sin, wr_addr => wave_wr_addr, wr_data => wr_data(2 * WAVE_W - 1 downto 0),
            out_valid => wl_valid, x => xs, clip => clip_s, out_user => wl_user
        );

    -- Same latency as the sine table: its valid and sideband duplicate the sine's.
    u_wave_cos : entity work.fringe_wave_lut
        generic map (ADC_W => ADC_W, WAVE_ADDR_W => WAVE_ADDR_W, WAVE_W => WAVE_W,
                     INIT_FILE => WAVE_COS_INIT, USER_W => 1)
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => valid1, adc => cos1, branch => br_c1, bank => bank1, in_user => "0",
            wr_en => wr_cos, wr_addr => wave_wr_addr, wr_data => wr_data(2 * WAVE_W - 1 downto 0),
            out_valid => wl_valid_c, x => xc, clip => clip_c, out_user => wl_user_c
        );

    wl_bank <= wl_user(0);
    wl_dx   <= wl_user(U_WL - 1 downto U_WL - DX_W);
    -- CLIP_*: the raw ADC codes (with the normaliser in front, the table inputs are not the raw codes)
    wl_clip_s <= wl_dx(0) when DRIFT /= 0 else clip_s;
    wl_clip_c <= wl_dx(1) when DRIFT /= 0 else clip_c;

    -- ---- stages 7..11: quadrature, coefficients of the sample's bank ----------------------------
    q_in_user <= wl_user(U_WL - 1 downto 1) & wl_clip_c & wl_clip_s & wl_bank;

    u_quad : entity work.fringe_quadrature
        generic map (WAVE_W => WAVE_W, COEF_W => COEF_W, USER_W => U_Q, SHARED_MUL => COMPACT)
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => wl_valid, xs => xs, xc => xc, in_user => q_in_user,
            ofs_s => ofs_s_r, ofs_c => ofs_c_r, k_ss => k_ss_r, k_sc => k_sc_r, k_cc => k_cc_r,
            out_valid => q_valid, s => qs, c => qc, sat => q_sat, out_user => q_user
        );

    q_any <= q_sat or q_user(U_Q - 1 - DX_W + 3);

    -- ---- [stages 12..15: fringe_canceller (CANCEL = 1), NCO word of the sample's bank] -----------
    g_cancel : if CANCEL /= 0 generate
        signal freq_r       : std_logic_vector(REG_W - 1 downto 0);   -- CANCEL_FREQ, read one clock enable ahead
        signal x_sat, x_tsat : std_logic;
        signal xu_in, xu    : std_logic_vector(U_Q downto 0);
    begin
        p_freq : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    freq_r <= reg_field(regs, bank_d(TAP_X), REG_CANCEL_FREQ, REG_W);
                end if;
            end if;
        end process p_freq;

        xu_in <= q_any & q_user;

        u_cancel : entity work.fringe_canceller
            generic map (WAVE_W => WAVE_W, LUT_W => CANCEL_LUT_W, C_W => CANCEL_C_W, BLOCK_LOG2 => CANCEL_BLOCK_LOG2,
                         MU_LOG2 => CANCEL_MU_LOG2, A_FRAC => CANCEL_A_FRAC, A_W => CANCEL_A_W,
                         GEAR_OFFSET => CANCEL_GEAR_OFFSET, LUT_INIT => CANCEL_LUT_INIT, USER_W => U_Q + 1)
            port map (
                clk => clk, rst => rst, ce => ce,
                in_valid => q_valid, c => qc, s => qs, freq => freq_r, in_user => xu_in,
                out_valid => x_valid, c_out => x_c, s_out => x_s, sat => x_sat, track_sat => x_tsat, out_user => xu
            );

        x_user <= xu(U_Q - 1 downto 0);
        x_any  <= xu(U_Q) or x_sat or x_tsat;
    end generate g_cancel;

    g_no_cancel : if CANCEL = 0 generate
        x_valid <= q_valid;
        x_c     <= qc;
        x_s     <= qs;
        x_user  <= q_user;
        x_any   <= q_any;
    end generate g_no_cancel;

    -- ---- stages 12..CORDIC_STAGES+13 (+ 4 with CANCEL = 1): CORDIC (x = c, y = s) ------------------
    c_in_user <= x_user(U_Q - 1 downto 3) & x_any & x_user(2 downto 0);

    u_cordic : entity work.fringe_cordic
        generic map (IN_W => WAVE_W, FINE_W => FINE_W, STAGES => CORDIC_STAGES, GUARD => CORDIC_GUARD,
                     USER_W => U_C, ITERATIVE => COMPACT)
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => x_valid, x => x_c, y => x_s, in_user => c_in_user, ready => c_ready,
            out_valid => c_valid, phase => phase, mag => mag, out_user => c_user
        );

    -- magnitude flags with the thresholds of the sample's bank, registered above (only on a defined
    -- magnitude: no numeric_std warnings while the pipeline fills)
    f_low  <= '1' when not is_x(mag) and not is_x(amp_low) and unsigned(mag) < unsigned(amp_low) else '0';
    f_high <= '1' when not is_x(mag) and not is_x(amp_high) and unsigned(mag) > unsigned(amp_high) else '0';

    -- ---- period count ----------------------------------------------------------------------------
    p_in_user <= mag & f_high & f_low & c_user(3 downto 0);

    u_count : entity work.fringe_period_count
        generic map (FINE_W => FINE_W, LINES => LINES, COARSE_W => COARSE_W, USER_W => U_P)
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => c_valid, phase => phase, coarse => c_user(CW + 3 downto 4),
            coarse_ofs => coarse_ofs_r,
            in_user => p_in_user,
            out_valid => p_valid, pos => p_pos, overspeed => p_overspeed, coarse_err => p_coarse_err,
            out_user => p_user
        );

    -- status sideband from here on, its bits the generated STATUS_* (fringe.fixed.regmap)
    p_status(STATUS_CLIP_SIN)   <= p_user(1);
    p_status(STATUS_CLIP_COS)   <= p_user(2);
    p_status(STATUS_AMP_LOW)    <= p_user(4);
    p_status(STATUS_AMP_HIGH)   <= p_user(5);
    p_status(STATUS_OVERSPEED)  <= p_overspeed;
    p_status(STATUS_COARSE_ERR) <= p_coarse_err;
    p_status(STATUS_SATURATED)  <= p_user(3);
    p_status(STATUS_BANK)       <= p_user(0);

    -- ---- closed-loop trim (TRIM = 1), tables and bank as every other stage ------------------------
    g_trim : if TRIM /= 0 generate
        signal trim_sat, trim_dir : std_logic;
        signal trim_user          : std_logic_vector(U_L - 1 downto 0);
    begin
        u_trim : entity work.fringe_trim
            generic map (LINES => LINES, FINE_W => FINE_W, AMP_W => AMP_W, SPEED_LOG2 => TRIM_SPEED_LOG2,
                         MAP_PSI_W => TRIM_MAP_PSI_W, MAP_PHI_W => TRIM_MAP_PHI_W, TRIM_W => TRIM_W,
                         TRIM_FRAC => TRIM_FRAC, G_SHIFT => TRIM_G_SHIFT, SECT_RECIP => TRIM_SECT_RECIP,
                         SECT_SHIFT => TRIM_SECT_SHIFT, START_SPEED => TRIM_START_SPEED,
                         MAG_SMOOTH_LOG2 => TRIM_MAG_SMOOTH_LOG2, MAP_INIT => TRIM_MAP_INIT,
                         SPEED_INIT => TRIM_SPEED_INIT,
                         AMP_INIT => TRIM_AMP_INIT, USER_W => U_L)
            port map (
                clk => clk, rst => rst, ce => ce,
                in_valid => p_valid, pos => p_pos, mag => p_user(U_P - 1 downto 6), bank => p_status(STATUS_BANK),
                in_user => p_status,
                wr_en => wr_trim, wr_sel => wr_trim_sel, wr_addr => trim_wr_addr,
                wr_data => wr_data(2 * TRIM_W - 1 downto 0),
                out_valid => t_valid, pos_out => t_pos, dir => trim_dir, sat => trim_sat, out_user => trim_user
            );
        -- a clipped trim is a saturation like the quadrature's
        process (all) is
        begin
            t_status <= trim_user;
            t_status(STATUS_SATURATED) <= trim_user(STATUS_SATURATED) or trim_sat;
        end process;
    else generate
        t_valid  <= p_valid;
        t_pos    <= p_pos;
        t_status <= p_status;
    end generate g_trim;

    -- ---- long-period table, zero and direction -------------------------------------------------
    u_long : entity work.fringe_long_period
        generic map (LINES => LINES, FINE_W => FINE_W, LP_ADDR_W => LP_ADDR_W, LP_W => LP_W,
                     LP_FRAC => LP_FRAC, LP_IF => LP_IF, LP_RECIP => LP_RECIP, LP_SHIFT => LP_SHIFT,
                     INIT_FILE => LP_INIT, USER_W => U_L)
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => t_valid, pos => t_pos, bank => t_status(STATUS_BANK),
            zero => p_zero, dir => p_dir(0),
            in_user => t_status,
            wr_en => wr_lp, wr_addr => lp_wr_addr, wr_data => wr_data(2 * LP_W - 1 downto 0),
            out_valid => out_valid, pos_out => pos, out_user => l_user
        );

    -- status word: the STATUS_* bits (the blocks' sideband, registered)
    status <= l_user;

end architecture rtl;
