-- fringe_top: fringe_core with AXI4-Stream sample input and position output.
--
-- VHDL-2008 twin of rtl/verilog/fringe_top.v (same generics, ports, latency and behaviour).
--
-- s_axis_tdata = {coarse lane, cos lane, sin lane}, m_axis_tdata = {status, position lane}, lanes of
-- whole bytes; the whole pipeline advances on the registered clock enable ce (a flip-flop: the previous
-- clock's !m_axis_tvalid || m_axis_tready, 1 after reset) and s_axis_tready = ce && the core's in_ready.
-- A word the sink refuses while the pipeline advances over it waits in a one-word skid register, which
-- m_axis_tdata shows while it is full (ce is 0 then): nothing lost or duplicated. rst (synchronous,
-- active high) empties the pipeline and the skid register.
--
-- LATENCY = fringe_core's: CORDIC_STAGES + 25 (+ 13 with TRIM = 1, + 4 with DRIFT = 1, + 4 with
-- CANCEL = 1) clocks from the s_axis handshake to m_axis_tvalid when the sink does not stall.
-- Parameters, ports and pipeline: docs/blocks/fringe_top.md. Bit-exact model: model/fringe/fixed/core.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_top is
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
        clk           : in  std_logic;
        rst           : in  std_logic;    -- synchronous, active high
        -- AXI4-Stream samples in
        -- S_DATA_W = 2*ADC_LANE + COARSE_LANE bits
        s_axis_tdata  : in  std_logic_vector(2 * (8 * ((ADC_W + 7) / 8)) + 8 * ((COARSE_W + 7) / 8) - 1 downto 0);
        s_axis_tvalid : in  std_logic;
        s_axis_tready : out std_logic;
        -- AXI4-Stream positions out
        -- M_DATA_W = POS_LANE + 8 bits
        m_axis_tdata  : out std_logic_vector(8 * ((clog2(LINES) + FINE_W + 7) / 8) + 8 - 1
                                             downto 0);
        m_axis_tvalid : out std_logic;
        m_axis_tready : in  std_logic;
        -- configuration write port (fringe_core)
        cfg_wr_en     : in  std_logic;
        cfg_wr_addr   : in  std_logic_vector(19 downto 0);
        cfg_wr_data   : in  std_logic_vector(63 downto 0);
        active_bank   : out std_logic
    );
end entity fringe_top;

architecture rtl of fringe_top is

    constant LATENCY  : integer := core_latency(CORDIC_STAGES, TRIM, DRIFT, CANCEL);
    -- clock enables from one sample to the next at full speed (fringe.fixed.config clocks_per_sample)
    constant CLOCKS_PER_SAMPLE : integer := 1 + COMPACT * (CORDIC_STAGES + CORDIC_ITER_CLOCKS_BASE - 1);  -- COMPACT is 0 or 1
    constant CW       : integer := maximum(COARSE_W, 1);      -- coarse port width of the core
    constant POS_W    : integer := clog2(LINES) + FINE_W;     -- position bits
    constant ADC_LANE : integer := 8 * ((ADC_W + 7) / 8);     -- bits of the sin and cos lanes
    constant POS_LANE : integer := 8 * ((POS_W + 7) / 8);     -- bits of the position lane
    constant M_W      : integer := POS_LANE + 8;              -- bits of m_axis_tdata

    -- The stream's clock enable is a register, so its fan-out to the whole pipeline starts at a
    -- flip-flop and not at the sink's m_axis_tready: ce = the previous clock's
    -- !m_axis_tvalid || m_axis_tready. The clock the sink refuses a word, the pipeline may still advance
    -- over it (ce was decided a clock earlier): the word goes to the skid register, m_axis_tdata shows
    -- it, and ce is 0 until the sink takes it. skid_valid = !ce except in the clock after a reset.
    signal ce_r       : std_logic;                            -- the clock enable of the whole pipeline
    signal skid_valid : std_logic;                            -- the skid register holds the oldest word
    signal skid_data  : std_logic_vector(M_W - 1 downto 0);
    signal ce         : std_logic;
    signal core_valid : std_logic;                            -- the core's registered out_valid
    signal core_data  : std_logic_vector(M_W - 1 downto 0);   -- {status, position lane} of the core's output
    signal out_valid  : std_logic;                            -- m_axis_tvalid
    signal in_ready   : std_logic;
    signal coarse    : std_logic_vector(CW - 1 downto 0);
    signal pos       : std_logic_vector(POS_W - 1 downto 0);
    signal status    : std_logic_vector(7 downto 0);

begin

    ce            <= ce_r;
    s_axis_tready <= ce and in_ready;
    out_valid     <= skid_valid or core_valid;
    m_axis_tvalid <= out_valid;
    m_axis_tdata  <= skid_data when skid_valid = '1' else core_data;

    p_skid : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                ce_r       <= '1';
                skid_valid <= '0';
            else
                ce_r       <= (not out_valid) or m_axis_tready;
                skid_valid <= out_valid and not m_axis_tready;
            end if;
            if skid_valid = '0' then
                skid_data <= core_data;   -- the core's word, kept when the sink refuses it
            end if;
        end if;
    end process p_skid;

    g_coarse : if COARSE_W > 0 generate
        coarse <= s_axis_tdata(2 * ADC_LANE + COARSE_W - 1 downto 2 * ADC_LANE);
    else generate
        coarse <= (others => '0');
    end generate g_coarse;

    u_core : entity work.fringe_core
        generic map (
            -- BEGIN generated core map (written by python sim/hdlgen.py; do not edit)
            ADC_W => ADC_W, LINES => LINES, COARSE_W => COARSE_W, WAVE_ADDR_W => WAVE_ADDR_W, WAVE_W => WAVE_W,
            COEF_W => COEF_W, FINE_W => FINE_W, CORDIC_STAGES => CORDIC_STAGES, CORDIC_GUARD => CORDIC_GUARD,
            COMPACT => COMPACT, LP_ADDR_W => LP_ADDR_W, LP_W => LP_W, LP_FRAC => LP_FRAC, LP_IF => LP_IF,
            LP_RECIP => LP_RECIP, LP_SHIFT => LP_SHIFT, TRIM => TRIM, TRIM_SPEED_LOG2 => TRIM_SPEED_LOG2,
            TRIM_MAP_PSI_W => TRIM_MAP_PSI_W, TRIM_MAP_PHI_W => TRIM_MAP_PHI_W, TRIM_W => TRIM_W,
            TRIM_FRAC => TRIM_FRAC, TRIM_G_SHIFT => TRIM_G_SHIFT, TRIM_SECT_RECIP => TRIM_SECT_RECIP,
            TRIM_SECT_SHIFT => TRIM_SECT_SHIFT, TRIM_START_SPEED => TRIM_START_SPEED,
            TRIM_MAG_SMOOTH_LOG2 => TRIM_MAG_SMOOTH_LOG2, DRIFT => DRIFT, DRIFT_BLOCK_LOG2 => DRIFT_BLOCK_LOG2,
            DRIFT_MU_LOG2 => DRIFT_MU_LOG2, DRIFT_OFS_FRAC => DRIFT_OFS_FRAC, DRIFT_GINV_W => DRIFT_GINV_W,
            DRIFT_FWD_W => DRIFT_FWD_W, DRIFT_TABLE_W => DRIFT_TABLE_W, DRIFT_TABLE_FRAC => DRIFT_TABLE_FRAC,
            DRIFT_KG_W => DRIFT_KG_W, DRIFT_KG_SHIFT => DRIFT_KG_SHIFT, DRIFT_HOLD => DRIFT_HOLD, CANCEL => CANCEL,
            CANCEL_LUT_W => CANCEL_LUT_W, CANCEL_C_W => CANCEL_C_W, CANCEL_BLOCK_LOG2 => CANCEL_BLOCK_LOG2,
            CANCEL_MU_LOG2 => CANCEL_MU_LOG2, CANCEL_A_FRAC => CANCEL_A_FRAC, CANCEL_A_W => CANCEL_A_W,
            CANCEL_GEAR_OFFSET => CANCEL_GEAR_OFFSET, REGS_INIT => REGS_INIT, WAVE_SIN_INIT => WAVE_SIN_INIT,
            WAVE_COS_INIT => WAVE_COS_INIT, LP_INIT => LP_INIT, TRIM_MAP_INIT => TRIM_MAP_INIT,
            TRIM_SPEED_INIT => TRIM_SPEED_INIT, TRIM_AMP_INIT => TRIM_AMP_INIT,
            DRIFT_FWD_SIN_INIT => DRIFT_FWD_SIN_INIT, DRIFT_FWD_COS_INIT => DRIFT_FWD_COS_INIT,
            CANCEL_LUT_INIT => CANCEL_LUT_INIT
            -- END generated core map
        )
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => s_axis_tvalid, in_ready => in_ready,
            sin => s_axis_tdata(ADC_W - 1 downto 0),
            cos => s_axis_tdata(ADC_LANE + ADC_W - 1 downto ADC_LANE),
            coarse => coarse,
            out_valid => core_valid, pos => pos, status => status,
            cfg_wr_en => cfg_wr_en, cfg_wr_addr => cfg_wr_addr, cfg_wr_data => cfg_wr_data,
            active_bank => active_bank
        );

    core_data <= status & std_logic_vector(resize(unsigned(pos), POS_LANE));

end architecture rtl;
