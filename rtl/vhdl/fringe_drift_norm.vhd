-- fringe_drift_norm: fringe_drift's normaliser, y = sat(((raw * 2^OFS_FRAC - OFF) * GINV) >>> SHN), and
-- the application of the observer's pending update to OFF and GINV at the block's application sample.
--
-- VHDL-2008 twin of rtl/verilog/fringe_drift_norm.v. Part of the fringe_drift block (its contract:
-- docs/blocks/fringe_drift.md; its generics are checked by fringe_drift); NORM_LATENCY = 4 clock enables,
-- one sample per clock; ce = 0 freezes every register, rst clears the valid pipeline and the state
-- (counters, OFF, GINV), never the data registers. Bit-exact model: model/fringe/fixed/drift.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_drift_norm is
    generic (
        ADC_W      : integer := 14;   -- ADC code width
        BLOCK_LOG2 : integer := 8;    -- B = 2^BLOCK_LOG2 samples per update block
        OFS_FRAC   : integer := 4;    -- fraction bits of OFF
        GINV_W     : integer := 18;   -- GINV width (GINV_W - 2 fraction bits)
        USER_W     : integer := 1     -- sideband width
    );
    port (
        clk         : in  std_logic;
        rst         : in  std_logic;                                        -- synchronous, active high
        ce          : in  std_logic;                                        -- clock enable
        -- sample in
        in_valid    : in  std_logic;
        raw_sin     : in  std_logic_vector(ADC_W - 1 downto 0);             -- s(ADC_W)
        raw_cos     : in  std_logic_vector(ADC_W - 1 downto 0);
        in_user     : in  std_logic_vector(USER_W - 1 downto 0);
        -- sample out
        norm_valid  : out std_logic;
        y_sin       : out std_logic_vector(ADC_W - 1 downto 0);             -- s(ADC_W)
        y_cos       : out std_logic_vector(ADC_W - 1 downto 0);
        norm_sat    : out std_logic;                                        -- y saturated (either channel)
        norm_user   : out std_logic_vector(USER_W - 1 downto 0);
        -- the observer's pending update; take: applied at this clock enable
        pend_valid  : in  std_logic;
        pend_off_s  : in  std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        pend_off_c  : in  std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        pend_ginv_s : in  std_logic_vector(GINV_W - 1 downto 0);
        pend_ginv_c : in  std_logic_vector(GINV_W - 1 downto 0);
        pend_sat    : in  std_logic;
        take        : out std_logic;
        -- tracker state
        off_sin     : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);  -- OFF, s(ADC_W + OFS_FRAC)
        off_cos     : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        ginv_sin    : out std_logic_vector(GINV_W - 1 downto 0);            -- GINV, u(GINV_W)
        ginv_cos    : out std_logic_vector(GINV_W - 1 downto 0);
        track_sat   : out std_logic                                         -- the last applied update saturated
    );
end entity fringe_drift_norm;

architecture rtl of fringe_drift_norm is

    constant NORM_LATENCY : integer := DRIFT_NORM_LATENCY;
    constant D      : integer := 2 ** (BLOCK_LOG2 - 1);
    constant OW     : integer := ADC_W + OFS_FRAC;                  -- OFF
    constant SHN    : integer := OFS_FRAC + GINV_W - 2;             -- normaliser shift
    constant PW     : integer := OW + GINV_W + 2;                   -- (raw * 2^OFS_FRAC - OFF) * GINV
    constant QW     : integer := PW - SHN;                          -- that >>> SHN
    constant UNITY  : unsigned(GINV_W - 1 downto 0) := shift_left(to_unsigned(1, GINV_W), GINV_W - 2);
    constant CNT_D  : unsigned(BLOCK_LOG2 - 1 downto 0) := to_unsigned(D, BLOCK_LOG2);
    constant CNT_LAST : unsigned(BLOCK_LOG2 - 1 downto 0) := (others => '1');

    -- application
    signal acc_n      : std_logic;
    signal take_i     : std_logic;
    signal ncnt       : unsigned(BLOCK_LOG2 - 1 downto 0);
    signal npast      : std_logic;
    signal off_s, off_c   : signed(OW - 1 downto 0);
    signal ginv_s, ginv_c : unsigned(GINV_W - 1 downto 0);
    signal tsat       : std_logic;

    -- normaliser
    signal n1_s, n1_c   : signed(ADC_W - 1 downto 0);
    signal n2_s, n2_c   : signed(OW downto 0);
    signal n2_gs, n2_gc : unsigned(GINV_W - 1 downto 0);
    signal n3_s, n3_c   : signed(PW - 1 downto 0);


begin

    -- ---- application of the pending update ------------------------------------------------------------
    acc_n <= ce and in_valid and not rst;
    take_i <= '1' when acc_n = '1' and npast = '1' and ncnt = CNT_D and pend_valid = '1' else '0';

    p_apply : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                ncnt   <= (others => '0');
                npast  <= '0';
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
                if take_i = '1' then
                    off_s  <= signed(pend_off_s);
                    off_c  <= signed(pend_off_c);
                    ginv_s <= unsigned(pend_ginv_s);
                    ginv_c <= unsigned(pend_ginv_c);
                    tsat   <= pend_sat;
                end if;
            end if;
        end if;
    end process p_apply;

    off_sin   <= std_logic_vector(off_s);
    off_cos   <= std_logic_vector(off_c);
    ginv_sin  <= std_logic_vector(ginv_s);
    ginv_cos  <= std_logic_vector(ginv_c);
    track_sat <= tsat;
    take      <= take_i;

    -- ---- normaliser ------------------------------------------------------------------------------------
    u_norm_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => NORM_LATENCY)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
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
                -- 4: rounded, >>> SHN, saturate: (P + 2^(SHN-1)) >>> SHN = (P >>> SHN) + P[SHN-1]
                rb_s := (others => '0');
                rb_c := (others => '0');
                rb_s(0) := n3_s(SHN - 1);
                rb_c(0) := n3_c(SHN - 1);
                q_s := n3_s(PW - 1 downto SHN) + rb_s;
                q_c := n3_c(PW - 1 downto SHN) + rb_c;
                os := outside(q_s, ADC_W);
                oc := outside(q_c, ADC_W);
                y_sin <= std_logic_vector(saturate(q_s, ADC_W));
                y_cos <= std_logic_vector(saturate(q_c, ADC_W));
                norm_sat <= '1' when os or oc else '0';
            end if;
        end if;
    end process p_norm;

end architecture rtl;
