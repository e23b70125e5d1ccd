-- fringe_top: fringe_core with AXI4-Stream sample input and position output.
--
-- VHDL-2008 twin of rtl/verilog/fringe_top.v (same generics, ports, latency and behaviour).
--
-- docs/architecture.md, "Top level":
--   s_axis_tdata = {coarse lane, cos lane, sin lane}: sin in [ADC_W-1:0], cos from bit ADC_LANE,
--                  coarse from bit 2*ADC_LANE (no coarse lane when COARSE_W = 0), each field
--                  right-aligned in a lane of whole bytes, ADC_LANE = 8*ceil(ADC_W/8); the padding
--                  bits of a lane are ignored.
--   m_axis_tdata = {status (8 bits), position lane (8*ceil(POS_W/8) bits)}, the position
--                  right-aligned and zero-padded.
--   Backpressure: the whole pipeline advances on ce = !m_axis_tvalid || m_axis_tready and
--   s_axis_tready = ce: one sample per clock, nothing lost or duplicated. m_axis_tvalid is the
--   core's registered out_valid, so m_axis_tdata is stable while the sink stalls.
--   Configuration write port and active_bank: see rtl/vhdl/fringe_core.vhd.
-- rst (synchronous, active high) empties the pipeline: m_axis_tvalid is 0 after it, samples in
-- flight and a sample taken in the same clock are dropped.
--
-- LATENCY = fringe_core LATENCY = CORDIC_STAGES + 24 (+ 12 with TRIM = 1, + 4 with DRIFT = 1) clocks from the s_axis handshake to
-- m_axis_tvalid when the sink does not stall (every stall adds its cycles).

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_top is
    generic (
        ADC_W         : integer := 12;    -- ADC code width (signed), 4..24
        LINES         : integer := 256;   -- signal periods per revolution, 1..2^20 (POS_W = clog2(LINES) + FINE_W <= 31)
        COARSE_W      : integer := 9;     -- coarse code bits, 0 = none (periods are counted); else 2^COARSE_W >= LINES, <= FINE_W-2
        WAVE_ADDR_W   : integer := 8;     -- waveform table address bits per branch, 2..min(ADC_W-1, 15)
        WAVE_W        : integer := 18;    -- waveform table / quadrature data width, 8..31
        COEF_W        : integer := 18;    -- quadrature gain width (COEF_W-2 fraction bits), 8..27
        FINE_W        : integer := 16;    -- fine phase bits per signal period, 8..30
        CORDIC_STAGES : integer := 18;    -- CORDIC micro-rotations, 4..32
        CORDIC_GUARD  : integer := 3;     -- extra fraction bits inside the CORDIC, 0..8
        LP_ADDR_W     : integer := 8;     -- long-period table entries per revolution = 2^LP_ADDR_W, <= 16
        LP_W          : integer := 18;    -- long-period table value/slope width, <= 32
        LP_FRAC       : integer := 4;     -- fraction bits of the long-period correction (fine counts)
        LP_IF         : integer := 8;     -- interpolation fraction bits of the long-period table
        LP_RECIP      : natural := 1;     -- long-period index multiplier (index_mapping; < 2^31 in VHDL)
        LP_SHIFT      : integer := 16;    -- long-period index shift (fringe.fixed.long_period.index_mapping)
        TRIM          : integer := 0;     -- 1 = fringe_trim (closed-loop corrections); the trim generics: fringe_core
        SPEED_LOG2    : integer := 5;
        MAP_PSI_W     : integer := 6;
        MAP_PHI_W     : integer := 5;
        TRIM_W        : integer := 18;
        TRIM_FRAC     : integer := 4;
        G_SHIFT       : integer := 24;
        SECT_RECIP    : natural := 1;
        SECT_SHIFT    : integer := 18;
        DRIFT            : integer := 0;  -- 1 = fringe_drift (online offset/gain tracker); its generics: fringe_core
        DRIFT_BLOCK_LOG2 : integer := 8;
        DRIFT_MU_LOG2    : integer := 1;
        DRIFT_OFS_FRAC   : integer := 4;
        DRIFT_GINV_W     : integer := 18;
        DRIFT_FWD_W      : integer := 8;
        DRIFT_TABLE_W    : integer := 18;
        DRIFT_TABLE_FRAC : integer := 4;
        DRIFT_KG_W       : integer := 18;
        DRIFT_KG_SHIFT   : integer := 40;
        REGS_INIT     : string  := "";    -- $readmemh image of the registers, 2 x 32 words of 32 bits
        WAVE_SIN_INIT : string  := "";    -- $readmemh image of the sine table, both banks
        WAVE_COS_INIT : string  := "";    -- $readmemh image of the cosine table, both banks
        LP_INIT       : string  := "";    -- $readmemh image of the long-period table, both banks
        MAP_INIT      : string  := "";    -- $readmemh images of the trim tables, both banks (TRIM = 1)
        SPEED_INIT    : string  := "";
        AMP_INIT      : string  := "";
        FWD_SIN_INIT  : string  := "";    -- $readmemh images of the drift forward tables, both banks (DRIFT = 1)
        FWD_COS_INIT  : string  := ""
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

    constant LATENCY  : integer := core_latency(CORDIC_STAGES, TRIM, DRIFT);
    constant CW       : integer := maximum(COARSE_W, 1);      -- coarse port width of the core
    constant POS_W    : integer := clog2(LINES) + FINE_W;     -- position bits
    constant ADC_LANE : integer := 8 * ((ADC_W + 7) / 8);     -- bits of the sin and cos lanes
    constant POS_LANE : integer := 8 * ((POS_W + 7) / 8);     -- bits of the position lane

    signal ce        : std_logic;
    signal out_valid : std_logic;
    signal coarse    : std_logic_vector(CW - 1 downto 0);
    signal pos       : std_logic_vector(POS_W - 1 downto 0);
    signal status    : std_logic_vector(7 downto 0);

begin

    ce            <= (not out_valid) or m_axis_tready;
    s_axis_tready <= ce;
    m_axis_tvalid <= out_valid;

    g_coarse : if COARSE_W > 0 generate
        coarse <= s_axis_tdata(2 * ADC_LANE + COARSE_W - 1 downto 2 * ADC_LANE);
    else generate
        coarse <= (others => '0');
    end generate g_coarse;

    u_core : entity work.fringe_core
        generic map (
            ADC_W => ADC_W, LINES => LINES, COARSE_W => COARSE_W, WAVE_ADDR_W => WAVE_ADDR_W,
            WAVE_W => WAVE_W, COEF_W => COEF_W, FINE_W => FINE_W, CORDIC_STAGES => CORDIC_STAGES,
            CORDIC_GUARD => CORDIC_GUARD, LP_ADDR_W => LP_ADDR_W, LP_W => LP_W, LP_FRAC => LP_FRAC,
            LP_IF => LP_IF, LP_RECIP => LP_RECIP, LP_SHIFT => LP_SHIFT, REGS_INIT => REGS_INIT,
            WAVE_SIN_INIT => WAVE_SIN_INIT, WAVE_COS_INIT => WAVE_COS_INIT, LP_INIT => LP_INIT,
            TRIM => TRIM, SPEED_LOG2 => SPEED_LOG2, MAP_PSI_W => MAP_PSI_W, MAP_PHI_W => MAP_PHI_W,
            TRIM_W => TRIM_W, TRIM_FRAC => TRIM_FRAC, G_SHIFT => G_SHIFT, SECT_RECIP => SECT_RECIP,
            SECT_SHIFT => SECT_SHIFT, MAP_INIT => MAP_INIT, SPEED_INIT => SPEED_INIT, AMP_INIT => AMP_INIT,
            DRIFT => DRIFT, DRIFT_BLOCK_LOG2 => DRIFT_BLOCK_LOG2, DRIFT_MU_LOG2 => DRIFT_MU_LOG2,
            DRIFT_OFS_FRAC => DRIFT_OFS_FRAC, DRIFT_GINV_W => DRIFT_GINV_W, DRIFT_FWD_W => DRIFT_FWD_W,
            DRIFT_TABLE_W => DRIFT_TABLE_W, DRIFT_TABLE_FRAC => DRIFT_TABLE_FRAC, DRIFT_KG_W => DRIFT_KG_W,
            DRIFT_KG_SHIFT => DRIFT_KG_SHIFT, FWD_SIN_INIT => FWD_SIN_INIT, FWD_COS_INIT => FWD_COS_INIT
        )
        port map (
            clk => clk, rst => rst, ce => ce,
            in_valid => s_axis_tvalid,
            sin => s_axis_tdata(ADC_W - 1 downto 0),
            cos => s_axis_tdata(ADC_LANE + ADC_W - 1 downto ADC_LANE),
            coarse => coarse,
            out_valid => out_valid, pos => pos, status => status,
            cfg_wr_en => cfg_wr_en, cfg_wr_addr => cfg_wr_addr, cfg_wr_data => cfg_wr_data,
            active_bank => active_bank
        );

    m_axis_tdata <= status & std_logic_vector(resize(unsigned(pos), POS_LANE));

end architecture rtl;
