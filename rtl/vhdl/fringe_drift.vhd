-- fringe_drift: online offset / gain tracker for drifting sin/cos signals: the composition of
-- fringe_drift_normaliser (at the front of the core) and fringe_drift_observer (of each sample's fine
-- phase), which hand each other the state and the block's update.
--
-- VHDL-2008 twin of rtl/verilog/fringe_drift.v (same generics, ports and behaviour).
-- NORM_LATENCY = 4 clock enables (in_valid to norm_valid); OBS_LATENCY = 16 (a
-- block's last observer sample to its resolved update), one sample per clock; HOLD = 1: in_ready = '0'
-- holds the sample at a block boundary until the block's update is resolved; ce = 0 freezes
-- every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_drift.md.
-- Bit-exact model: model/fringe/fixed/drift.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_drift is
    generic (
        ADC_W        : integer := 14;   -- ADC code width, 4..24
        FINE_W       : integer := 16;   -- fine phase bits per period, 8..30
        BLOCK_LOG2   : integer := 8;    -- B = 2^BLOCK_LOG2 samples per update block, 4..12
        MU_LOG2      : integer := 3;    -- final step 2^-MU_LOG2 (gear shift from 1), 0..8
        OFS_FRAC     : integer := 4;    -- fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
        GINV_W       : integer := 18;   -- GINV width (GINV_W - 2 fraction bits), 8..24
        FWD_W        : integer := 6;    -- 2^FWD_W bins per period in the forward tables, 2..min(10, FINE_W-1)
        TABLE_W      : integer := 18;   -- forward table value and slope width, 8..24
        TABLE_FRAC   : integer := 2;    -- fraction bits of the table values and of W0 (ADC codes), 0..12
        KG_W         : integer := 18;   -- KG width (unsigned), 8..24
        KG_SHIFT     : integer := 40;   -- right shift of SEA * KG, 1..60
        PIPE_LATENCY : integer := 0;    -- clock enables from the norm outputs to the obs inputs in the core, >= 0
        HOLD         : integer := 1;    -- 1: updates apply at the block boundary (in_ready holds); 0: B/2 later
        FWD_SIN_INIT : string  := "";   -- hex image of the sine table, 2 banks x 2^FWD_W words; "" = zeros
        FWD_COS_INIT : string  := "";   -- hex image of the cosine table, 2 banks x 2^FWD_W words; "" = zeros
        USER_W       : integer := 1     -- normaliser sideband width, >= 1
    );
    port (
        clk        : in  std_logic;
        rst        : in  std_logic;                                        -- synchronous, active high
        ce         : in  std_logic;                                        -- clock enable
        -- normaliser in
        in_valid   : in  std_logic;
        raw_sin    : in  std_logic_vector(ADC_W - 1 downto 0);             -- s(ADC_W)
        raw_cos    : in  std_logic_vector(ADC_W - 1 downto 0);
        in_user    : in  std_logic_vector(USER_W - 1 downto 0);
        in_ready   : out std_logic;                                        -- HOLD = 1: '0' while a boundary waits
        -- normaliser out
        norm_valid : out std_logic;
        y_sin      : out std_logic_vector(ADC_W - 1 downto 0);             -- s(ADC_W)
        y_cos      : out std_logic_vector(ADC_W - 1 downto 0);
        norm_sat   : out std_logic;                                        -- y saturated (either channel)
        norm_user  : out std_logic_vector(USER_W - 1 downto 0);
        -- observer in
        obs_valid  : in  std_logic;
        obs_phase  : in  std_logic_vector(FINE_W - 1 downto 0);            -- u(FINE_W)
        obs_y_sin  : in  std_logic_vector(ADC_W - 1 downto 0);             -- the same sample's normalised codes
        obs_y_cos  : in  std_logic_vector(ADC_W - 1 downto 0);
        obs_bank   : in  std_logic;                                        -- table (and W0, KG) bank
        w0_sin     : in  std_logic_vector(ADC_W + TABLE_FRAC - 1 downto 0);  -- W0, s(ADC_W + TABLE_FRAC)
        w0_cos     : in  std_logic_vector(ADC_W + TABLE_FRAC - 1 downto 0);
        kg_sin     : in  std_logic_vector(KG_W - 1 downto 0);              -- KG (taken with a block's last sample)
        kg_cos     : in  std_logic_vector(KG_W - 1 downto 0);
        -- table write port (software side), independent of ce
        wr_en      : in  std_logic;
        wr_sel     : in  std_logic;                                        -- 0 sine table, 1 cosine table
        wr_addr    : in  std_logic_vector(FWD_W downto 0);                 -- {bank, bin}
        wr_data    : in  std_logic_vector(2 * TABLE_W - 1 downto 0);       -- {slope, value}
        -- tracker state
        off_sin    : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);  -- OFF, s(ADC_W + OFS_FRAC)
        off_cos    : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        ginv_sin   : out std_logic_vector(GINV_W - 1 downto 0);            -- GINV, u(GINV_W)
        ginv_cos   : out std_logic_vector(GINV_W - 1 downto 0);
        track_sat  : out std_logic                                         -- the last applied update saturated
    );
end entity fringe_drift;

architecture rtl of fringe_drift is

    constant NORM_LATENCY : integer := DRIFT_NORM_LATENCY;
    constant OBS_LATENCY  : integer := DRIFT_OBS_LATENCY;

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
        constant TOTAL   : integer := NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY;
        constant D1      : integer := 2 ** (BLOCK_LOG2 - 1) + 1;
    begin
        check_drift_state("fringe_drift", ADC_W, BLOCK_LOG2, OFS_FRAC, GINV_W, HOLD);
        check_drift_observer("fringe_drift", FINE_W, MU_LOG2, FWD_W, TABLE_W, TABLE_FRAC, KG_W, KG_SHIFT);
        check_min("fringe_drift", "PIPE_LATENCY", PIPE_LATENCY, 0);
        assert HOLD /= 0 or TOTAL <= D1
            report "fringe_drift: NORM_LATENCY + PIPE_LATENCY + OBS_LATENCY = " & integer'image(NORM_LATENCY)
                   & " + " & integer'image(PIPE_LATENCY) & " + " & integer'image(OBS_LATENCY) & " = "
                   & integer'image(TOTAL) & " exceeds D + 1 = 2^(BLOCK_LOG2-1) + 1 = " & integer'image(D1)
                   & ": the update would come too late"
            severity failure;
        check_min("fringe_drift", "USER_W", USER_W, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant OW : integer := ADC_W + OFS_FRAC;   -- OFF
    signal upd_valid, upd_sat, upd_resolved, upd_take : std_logic;
    signal upd_off_s, upd_off_c   : std_logic_vector(OW - 1 downto 0);
    signal upd_ginv_s, upd_ginv_c : std_logic_vector(GINV_W - 1 downto 0);
    signal off_s, off_c           : std_logic_vector(OW - 1 downto 0);
    signal ginv_s, ginv_c         : std_logic_vector(GINV_W - 1 downto 0);

begin

    u_norm : entity work.fringe_drift_normaliser
        generic map (ADC_W => ADC_W, BLOCK_LOG2 => BLOCK_LOG2, OFS_FRAC => OFS_FRAC, GINV_W => GINV_W, HOLD => HOLD,
                     USER_W => USER_W)
        port map (clk => clk, rst => rst, ce => ce,
                  in_valid => in_valid, raw_sin => raw_sin, raw_cos => raw_cos, in_user => in_user,
                  in_ready => in_ready,
                  norm_valid => norm_valid, y_sin => y_sin, y_cos => y_cos, norm_sat => norm_sat,
                  norm_user => norm_user,
                  upd_valid => upd_valid, upd_off_sin => upd_off_s, upd_off_cos => upd_off_c,
                  upd_ginv_sin => upd_ginv_s, upd_ginv_cos => upd_ginv_c, upd_sat => upd_sat,
                  upd_resolved => upd_resolved, upd_take => upd_take,
                  off_sin => off_s, off_cos => off_c, ginv_sin => ginv_s, ginv_cos => ginv_c,
                  track_sat => track_sat);

    u_obs : entity work.fringe_drift_observer
        generic map (ADC_W => ADC_W, FINE_W => FINE_W, BLOCK_LOG2 => BLOCK_LOG2, MU_LOG2 => MU_LOG2,
                     OFS_FRAC => OFS_FRAC, GINV_W => GINV_W, FWD_W => FWD_W, TABLE_W => TABLE_W,
                     TABLE_FRAC => TABLE_FRAC, KG_W => KG_W, KG_SHIFT => KG_SHIFT, HOLD => HOLD,
                     FWD_SIN_INIT => FWD_SIN_INIT, FWD_COS_INIT => FWD_COS_INIT)
        port map (clk => clk, rst => rst, ce => ce,
                  obs_valid => obs_valid, obs_phase => obs_phase, obs_y_sin => obs_y_sin, obs_y_cos => obs_y_cos,
                  obs_bank => obs_bank, w0_sin => w0_sin, w0_cos => w0_cos, kg_sin => kg_sin, kg_cos => kg_cos,
                  wr_en => wr_en, wr_sel => wr_sel, wr_addr => wr_addr, wr_data => wr_data,
                  off_sin => off_s, off_cos => off_c, ginv_sin => ginv_s, ginv_cos => ginv_c,
                  upd_valid => upd_valid, upd_off_sin => upd_off_s, upd_off_cos => upd_off_c,
                  upd_ginv_sin => upd_ginv_s, upd_ginv_cos => upd_ginv_c, upd_sat => upd_sat,
                  upd_resolved => upd_resolved, upd_take => upd_take);

    off_sin  <= off_s;
    off_cos  <= off_c;
    ginv_sin <= ginv_s;
    ginv_cos <= ginv_c;

end architecture rtl;
