-- fringe_drift_normaliser: the front half of the drift tracker (docs/drift.md): offsets and gains of the
-- raw sin/cos codes removed with the tracker's state, which it holds and replaces at block boundaries
-- with the update fringe_drift_observer resolves.
--
-- VHDL-2008 twin of rtl/verilog/fringe_drift_normaliser.v (same generics, ports and behaviour).
-- LATENCY = 5 clock enables (in_valid to norm_valid), one sample per clock; HOLD = 1: in_ready = '0'
-- holds the sample at a block boundary until the observer has resolved the block's update; ce = 0 freezes
-- every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_drift_normaliser.md.
-- Bit-exact model: model/fringe/fixed/drift_normaliser.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_drift_normaliser is
    generic (
        ADC_W      : integer := 14;   -- ADC code width, 4..24
        BLOCK_LOG2 : integer := 8;    -- B = 2^BLOCK_LOG2 samples per update block, 4..12
        OFS_FRAC   : integer := 4;    -- fraction bits of OFF, 0..8; ADC_W + OFS_FRAC <= 32
        GINV_W     : integer := 18;   -- GINV width (GINV_W - 2 fraction bits), 8..24
        HOLD       : integer := 1;    -- 1: updates apply at the block boundary (in_ready holds); 0: B/2 later
        USER_W     : integer := 1     -- sideband width, >= 1
    );
    port (
        clk          : in  std_logic;
        rst          : in  std_logic;                                        -- synchronous, active high
        ce           : in  std_logic;                                        -- clock enable
        -- in
        in_valid     : in  std_logic;
        raw_sin      : in  std_logic_vector(ADC_W - 1 downto 0);             -- s(ADC_W)
        raw_cos      : in  std_logic_vector(ADC_W - 1 downto 0);
        in_user      : in  std_logic_vector(USER_W - 1 downto 0);
        in_ready     : out std_logic;                                        -- HOLD = 1: '0' while a boundary waits
        -- out
        norm_valid   : out std_logic;
        y_sin        : out std_logic_vector(ADC_W - 1 downto 0);             -- s(ADC_W)
        y_cos        : out std_logic_vector(ADC_W - 1 downto 0);
        norm_sat     : out std_logic;                                        -- y saturated (either channel)
        norm_user    : out std_logic_vector(USER_W - 1 downto 0);
        -- the update (from fringe_drift_observer)
        upd_valid    : in  std_logic;                                        -- an update is pending
        upd_off_sin  : in  std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);  -- its state
        upd_off_cos  : in  std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        upd_ginv_sin : in  std_logic_vector(GINV_W - 1 downto 0);
        upd_ginv_cos : in  std_logic_vector(GINV_W - 1 downto 0);
        upd_sat      : in  std_logic;
        upd_resolved : in  std_logic;                                        -- the last complete block's update is known
        upd_take     : out std_logic;                                        -- the application sample is accepted
        -- tracker state
        off_sin      : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);  -- OFF, s(ADC_W + OFS_FRAC)
        off_cos      : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        ginv_sin     : out std_logic_vector(GINV_W - 1 downto 0);            -- GINV, u(GINV_W)
        ginv_cos     : out std_logic_vector(GINV_W - 1 downto 0);
        track_sat    : out std_logic                                         -- the last applied update saturated
    );
end entity fringe_drift_normaliser;

architecture rtl of fringe_drift_normaliser is

    constant LATENCY : integer := DRIFT_NORM_LATENCY;

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_drift_state("fringe_drift_normaliser", ADC_W, BLOCK_LOG2, OFS_FRAC, GINV_W, HOLD);
        check_min("fringe_drift_normaliser", "USER_W", USER_W, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant D      : integer := (1 - minimum(HOLD, 1)) * 2 ** (BLOCK_LOG2 - 1);   -- application delay
    constant OW     : integer := ADC_W + OFS_FRAC;                  -- OFF
    constant SHN    : integer := OFS_FRAC + GINV_W - 2;             -- normaliser shift
    constant PW     : integer := OW + GINV_W + 2;                   -- (raw * 2^OFS_FRAC - OFF) * GINV
    constant QW     : integer := PW - SHN;                          -- that >>> SHN
    constant UNITY  : unsigned(GINV_W - 1 downto 0) := shift_left(to_unsigned(1, GINV_W), GINV_W - 2);
    constant CNT_D  : unsigned(BLOCK_LOG2 - 1 downto 0) := to_unsigned(D, BLOCK_LOG2);
    constant CNT_DM1 : unsigned(BLOCK_LOG2 - 1 downto 0) := CNT_D - 1;   -- (mod B)
    constant CNT_LAST : unsigned(BLOCK_LOG2 - 1 downto 0) := (others => '1');

    signal in_take    : std_logic;
    signal in_ready_i : std_logic;
    signal acc_n      : std_logic;
    -- the next sample is an application sample: npast and ncnt = CNT_D, registered with them (no compare
    -- between ncnt and the enables of the state registers)
    signal at_apply   : std_logic;
    signal take       : std_logic;                      -- (with acc_n) the state becomes the pending update
    signal ncnt       : unsigned(BLOCK_LOG2 - 1 downto 0);
    signal npast      : std_logic;
    signal off_s, off_c   : signed(OW - 1 downto 0);
    signal ginv_s, ginv_c : unsigned(GINV_W - 1 downto 0);
    signal tsat       : std_logic;

    signal n1_s, n1_c   : signed(ADC_W - 1 downto 0);
    signal n2_s, n2_c   : signed(OW downto 0);
    signal n2_gs, n2_gc : unsigned(GINV_W - 1 downto 0);
    signal n3_s, n3_c   : signed(PW - 1 downto 0);
    -- the product's bits from the rounding bit up, registered once more: the multiplier's output register
    -- feeds only this register, the rounding adder and the saturation are a stage of their own (5)
    signal n4_s, n4_c   : signed(QW downto 0);

begin

    -- ---- application of the pending update ------------------------------------------------------------
    in_take  <= in_valid and in_ready_i;
    acc_n    <= ce and in_take and not rst;
    take     <= at_apply and upd_valid;
    upd_take <= acc_n and at_apply;

    -- HOLD = 1: the boundary sample waits until its block's update is resolved (at most one block is
    -- outstanding: the next one needs samples past this boundary). HOLD = 0: never waits (the latency check).
    in_ready_i <= '1' when HOLD = 0 or at_apply = '0' or upd_resolved = '1' else '0';
    in_ready   <= in_ready_i;

    p_apply : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                ncnt   <= (others => '0');
                npast  <= '0';
                at_apply <= '0';
                off_s  <= (others => '0');
                off_c  <= (others => '0');
                ginv_s <= UNITY;
                ginv_c <= UNITY;
                tsat   <= '0';
            elsif acc_n = '1' then
                ncnt <= ncnt + 1;
                if ncnt = CNT_LAST then
                    npast <= '1';
                end if;
                if (npast = '1' or ncnt = CNT_LAST) and ncnt = CNT_DM1 then
                    at_apply <= '1';
                else
                    at_apply <= '0';
                end if;
                if take = '1' then
                    off_s  <= signed(upd_off_sin);
                    off_c  <= signed(upd_off_cos);
                    ginv_s <= unsigned(upd_ginv_sin);
                    ginv_c <= unsigned(upd_ginv_cos);
                    tsat   <= upd_sat;
                end if;
            end if;
        end if;
    end process p_apply;

    off_sin   <= std_logic_vector(off_s);
    off_cos   <= std_logic_vector(off_c);
    ginv_sin  <= std_logic_vector(ginv_s);
    ginv_cos  <= std_logic_vector(ginv_c);
    track_sat <= tsat;

    -- ---- normaliser ------------------------------------------------------------------------------------
    u_norm_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => LATENCY)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_take, in_data => in_user,
                  out_valid => norm_valid, out_data => norm_user);

    p_norm : process (clk)
        variable q_s, q_c : signed(QW - 1 downto 0);
        variable rb_s, rb_c : signed(QW - 1 downto 0);
        variable os, oc   : boolean;
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- 1: input registers
                n1_s <= signed(raw_sin);
                n1_c <= signed(raw_cos);
                -- 2: d = raw * 2^OFS_FRAC - OFF (the state after this sample's acceptance)
                n2_s  <= shift_left(resize(n1_s, OW + 1), OFS_FRAC) - resize(off_s, OW + 1);
                n2_c  <= shift_left(resize(n1_c, OW + 1), OFS_FRAC) - resize(off_c, OW + 1);
                n2_gs <= ginv_s;
                n2_gc <= ginv_c;
                -- 3: d * GINV
                n3_s <= n2_s * signed('0' & n2_gs);
                n3_c <= n2_c * signed('0' & n2_gc);
                -- 4: P(PW-1 downto SHN-1) registered (P >>> SHN and the rounding bit)
                n4_s <= n3_s(PW - 1 downto SHN - 1);
                n4_c <= n3_c(PW - 1 downto SHN - 1);
                -- 5: rounded, >>> SHN, saturate: (P + 2^(SHN-1)) >>> SHN = (P >>> SHN) + P[SHN-1]
                rb_s := (others => '0');
                rb_c := (others => '0');
                rb_s(0) := n4_s(0);
                rb_c(0) := n4_c(0);
                q_s := n4_s(QW downto 1) + rb_s;
                q_c := n4_c(QW downto 1) + rb_c;
                os := outside(q_s, ADC_W);
                oc := outside(q_c, ADC_W);
                y_sin <= std_logic_vector(saturate(q_s, ADC_W));
                y_cos <= std_logic_vector(saturate(q_c, ADC_W));
                norm_sat <= '1' when os or oc else '0';
            end if;
        end if;
    end process p_norm;

end architecture rtl;
