-- fringe_drift_observer: the back half of the drift tracker (docs/drift.md): from each sample's fine
-- phase and normalised codes, block sums of the error against the calibrated waveform, and per block the
-- tracker's next state (offset and inverse gain steps at the gear), held as the pending update until
-- fringe_drift_normaliser takes it.
--
-- VHDL-2008 twin of rtl/verilog/fringe_drift_observer.v (same generics, ports and behaviour).
-- LATENCY = 16 clock enables (obs_valid of a block's last sample to its resolved update), one sample per
-- clock; ce = 0 freezes every register, rst (synchronous, active high) clears only the valid pipeline and
-- the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_drift_observer.md.
-- Bit-exact model: model/fringe/fixed/drift_observer.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_drift_observer is
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
        HOLD         : integer := 1;    -- 1: the window is the whole block; 0: its second half
        FWD_SIN_INIT : string  := "";   -- hex image of the sine table, 2 banks x 2^FWD_W words; "" = zeros
        FWD_COS_INIT : string  := ""    -- hex image of the cosine table, 2 banks x 2^FWD_W words; "" = zeros
    );
    port (
        clk          : in  std_logic;
        rst          : in  std_logic;                                        -- synchronous, active high
        ce           : in  std_logic;                                        -- clock enable
        -- in
        obs_valid    : in  std_logic;
        obs_phase    : in  std_logic_vector(FINE_W - 1 downto 0);            -- u(FINE_W)
        obs_y_sin    : in  std_logic_vector(ADC_W - 1 downto 0);             -- the same sample's normalised codes
        obs_y_cos    : in  std_logic_vector(ADC_W - 1 downto 0);
        obs_bank     : in  std_logic;                                        -- table (and W0, KG) bank
        w0_sin       : in  std_logic_vector(ADC_W + TABLE_FRAC - 1 downto 0);  -- W0, s(ADC_W + TABLE_FRAC)
        w0_cos       : in  std_logic_vector(ADC_W + TABLE_FRAC - 1 downto 0);
        kg_sin       : in  std_logic_vector(KG_W - 1 downto 0);              -- KG (taken with a block's last sample)
        kg_cos       : in  std_logic_vector(KG_W - 1 downto 0);
        -- table write port (software side), independent of ce
        wr_en        : in  std_logic;
        wr_sel       : in  std_logic;                                        -- 0 sine table, 1 cosine table
        wr_addr      : in  std_logic_vector(FWD_W downto 0);                 -- {bank, bin}
        wr_data      : in  std_logic_vector(2 * TABLE_W - 1 downto 0);       -- {slope, value}
        -- the state the normaliser uses now (the update steps from it)
        off_sin      : in  std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);  -- OFF, s(ADC_W + OFS_FRAC)
        off_cos      : in  std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        ginv_sin     : in  std_logic_vector(GINV_W - 1 downto 0);            -- GINV, u(GINV_W)
        ginv_cos     : in  std_logic_vector(GINV_W - 1 downto 0);
        -- the update (to fringe_drift_normaliser)
        upd_valid    : out std_logic;                                        -- an update is pending
        upd_off_sin  : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);  -- its state
        upd_off_cos  : out std_logic_vector(ADC_W + OFS_FRAC - 1 downto 0);
        upd_ginv_sin : out std_logic_vector(GINV_W - 1 downto 0);
        upd_ginv_cos : out std_logic_vector(GINV_W - 1 downto 0);
        upd_sat      : out std_logic;                                        -- it saturated (OFF or GINV)
        upd_resolved : out std_logic;                                        -- the last complete block's update is known
        upd_take     : in  std_logic                                         -- the normaliser takes it
    );
end entity fringe_drift_observer;

architecture rtl of fringe_drift_observer is

    constant LATENCY  : integer := DRIFT_OBS_LATENCY;
    constant SWEEP_LO : integer := FINE_W - DRIFT_SWEEP_MIN_LOG2;  -- log2 of the least SWEEP that updates
    constant PARTIAL  : boolean := MU_LOG2 >= DRIFT_PARTIAL_MU_MIN;  -- blocks of less than a period update

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_drift_state("fringe_drift_observer", ADC_W, BLOCK_LOG2, OFS_FRAC, GINV_W, HOLD);
        check_drift_observer("fringe_drift_observer", FINE_W, MU_LOG2, FWD_W, TABLE_W, TABLE_FRAC, KG_W, KG_SHIFT);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant WL     : integer := BLOCK_LOG2 - 1 + minimum(HOLD, 1);   -- log2(W), W samples accumulated
    constant OW     : integer := ADC_W + OFS_FRAC;                  -- OFF
    constant TW     : integer := TABLE_W;
    constant FB     : integer := FINE_W - FWD_W;                    -- >= 1
    constant AW     : integer := TW + 1;                            -- a
    constant YW     : integer := ADC_W + TABLE_FRAC + 1;            -- y * 2^TABLE_FRAC - W0
    constant E_W    : integer := maximum(YW, AW) + 1;               -- e
    constant EA_W   : integer := E_W + AW;                          -- e * a
    constant SE_W   : integer := E_W + WL;
    constant SEA_W  : integer := EA_W + WL;
    -- offset step shift at gear 0 (+ G), 1 less than log2(W) + TABLE_FRAC: the phase comes from the same
    -- codes, so the observer sees half of an offset error; the doubled step removes it (>= 2: WL >= 3)
    constant SH_B   : integer := WL + TABLE_FRAC - 1;
    constant XW     : integer := SE_W + OFS_FRAC + 1;               -- SE * 2^OFS_FRAC
    constant OS_W   : integer := XW + 1;                            -- OFF + step
    constant KP_W   : integer := SEA_W + KG_W + MU_LOG2 + 1;        -- SEA * KG * 2^(MU_LOG2 - G)
    constant PR_W   : integer := maximum(KP_W, KG_SHIFT) + 1;       -- + 2^(KG_SHIFT-1)
    constant DG_W   : integer := PR_W - KG_SHIFT;                   -- the GINV step
    constant GS_W   : integer := maximum(GINV_W + 1, DG_W) + 1;     -- GINV - step
    constant CNT_LAST : unsigned(BLOCK_LOG2 - 1 downto 0) := (others => '1');

    -- the state (inputs) and the pending update (outputs)
    signal off_s, off_c   : signed(OW - 1 downto 0);
    signal ginv_s, ginv_c : unsigned(GINV_W - 1 downto 0);
    signal resolved   : std_logic;                      -- the last complete block's update is known
    signal pend_valid : std_logic;
    signal pend_off_s, pend_off_c   : signed(OW - 1 downto 0);
    signal pend_ginv_s, pend_ginv_c : unsigned(GINV_W - 1 downto 0);
    signal pend_sat   : std_logic;

    signal acc_o      : std_logic;
    signal ocnt       : unsigned(BLOCK_LOG2 - 1 downto 0);
    signal o_at_last  : std_logic;   -- ocnt = CNT_LAST, registered with ocnt (no compare behind ce)
    signal ohave      : std_logic;
    signal last_phase : unsigned(FINE_W - 1 downto 0);
    signal kg_hold_s, kg_hold_c : unsigned(KG_W - 1 downto 0);
    -- KG taken one clock enable after the block's last sample, from a register of every sample's KG: the
    -- hold's enable is ce and one register (not ce, obs_valid, reset and the count; read at stage 10)
    signal kg_in_s, kg_in_c     : unsigned(KG_W - 1 downto 0);
    signal kg_take              : std_logic;
    signal rd_addr    : std_logic_vector(FWD_W downto 0);
    signal wr_en_s, wr_en_c : std_logic;
    signal obs_frac   : std_logic_vector(FB - 1 downto 0);
    signal a_s, a_c   : std_logic_vector(AW - 1 downto 0);   -- from the forward tables
    signal o_last     : std_logic;                      -- the block's last sample (observer input)
    signal o_win      : std_logic;                      -- in the window (the block's last W samples)
    signal o8_valid, o8_last, o8_win : std_logic;       -- stage 8: valid, the block's last sample, window
    signal o_flags, o8_flags : std_logic_vector(1 downto 0);
    signal o1_phase, o1_prev : unsigned(FINE_W - 1 downto 0);
    signal o1_ys, o1_yc   : signed(ADC_W - 1 downto 0);
    signal o1_w0s, o1_w0c : signed(YW - 2 downto 0);
    signal o2_dl      : unsigned(FINE_W - 1 downto 0);
    signal o2_yws, o2_ywc : signed(YW - 1 downto 0);
    signal o3_yws, o3_ywc : signed(YW - 1 downto 0);
    signal o3_abs     : unsigned(FINE_W - 1 downto 0);
    signal o4_yws, o4_ywc : signed(YW - 1 downto 0);
    signal o4_abs     : unsigned(FINE_W - 1 downto 0);
    signal o5_es, o5_ec   : signed(E_W - 1 downto 0);
    signal o5_as, o5_ac   : signed(AW - 1 downto 0);
    signal o5_abs     : unsigned(FINE_W - 1 downto 0);
    signal o8_es, o8_ec   : signed(E_W - 1 downto 0);
    signal o8_abs         : unsigned(FINE_W - 1 downto 0);
    signal o8_carry       : std_logic_vector(2 * E_W + FINE_W - 1 downto 0);
    signal o8_carry_valid : std_logic;
    signal o8_eas, o8_eac : signed(EA_W - 1 downto 0);
    signal se_s, se_c   : signed(SE_W - 1 downto 0);
    signal sea_s, sea_c : signed(SEA_W - 1 downto 0);
    -- SWEEP as its low FINE_W bits and a flag for the bits above (|delta| >= 0: once set, they stay
    -- nonzero): the period test is the flag or the low sum's carry, not an OR over an adder's top bits
    signal sweep      : unsigned(FINE_W - 1 downto 0);
    signal sweep_hi   : std_logic;
    signal fresh      : std_logic_vector(4 downto 0);   -- the accumulators hold a finished block: start from 0
    signal o9_go      : std_logic;

    -- e * a and P = SEA * KG (fringe_split_mul), P sign-extended to PR_W bits
    constant P_W          : integer := SEA_W + KG_W;                -- SEA * KG, exact
    signal ea_e           : std_logic_vector(2 * E_W - 1 downto 0);   -- per channel: {cosine, sine}
    signal ea_a           : std_logic_vector(2 * AW - 1 downto 0);
    signal ea_p           : std_logic_vector(2 * EA_W - 1 downto 0);
    signal kg_e           : std_logic_vector(2 * SEA_W - 1 downto 0);
    signal kg_k           : std_logic_vector(2 * KG_W - 1 downto 0);
    signal kg_p           : std_logic_vector(2 * P_W - 1 downto 0);
    signal px_s, px_c     : signed(PR_W - 1 downto 0);
    signal gear         : integer range 0 to 8;         -- G_u = min(MU_LOG2, bit_length(u))
    signal g_left       : integer range 0 to 256;       -- updates left at this gear
    signal u1_ss, u1_sc : signed(XW - 1 downto 0);
    signal u2_os, u2_oc : signed(OS_W - 1 downto 0);
    signal snap_full    : std_logic;                    -- the block swept a whole period
    signal snap_ok      : std_logic;                    -- enough to update
    signal g_up         : integer range 0 to 8;         -- MU_LOG2 - G: the gain step's left shift (stage 14)
    signal u5_valid     : std_logic;                    -- stage 14: valid
    signal u5_tests     : std_logic_vector(1 downto 0); -- stage 14: the SWEEP tests (full, ok)
    signal u6_valid     : std_logic;                    -- stage 15: valid (stage 16 resolves)
    signal u6_go        : std_logic;                    -- the block updates (pending)
    signal u6_gup       : std_logic;                    -- and steps to the next gear
    signal u6_gdec      : std_logic;                    -- or counts one update at this gear
    signal u3_os, u3_oc, u6_os, u6_oc : signed(OW - 1 downto 0);
    signal u3_sat, u6_sat : std_logic;
    signal u6_carry     : std_logic_vector(2 * OW downto 0);
    signal u6_carry_valid : std_logic;
    signal u5_dg_s, u5_dg_c : signed(DG_W - 1 downto 0);
    signal u5_rb_s, u5_rb_c : std_logic;
    signal u6_gs, u6_gc : signed(GS_W - 1 downto 0);

begin

    off_s  <= signed(off_sin);
    off_c  <= signed(off_cos);
    ginv_s <= unsigned(ginv_sin);
    ginv_c <= unsigned(ginv_cos);
    upd_valid    <= pend_valid;
    upd_off_sin  <= std_logic_vector(pend_off_s);
    upd_off_cos  <= std_logic_vector(pend_off_c);
    upd_ginv_sin <= std_logic_vector(pend_ginv_s);
    upd_ginv_cos <= std_logic_vector(pend_ginv_c);
    upd_sat      <= pend_sat;
    upd_resolved <= resolved;

    -- ---- observer: counters ------------------------------------------------------------------------------
    acc_o <= ce and obs_valid and not rst;

    p_ocnt : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                ocnt      <= (others => '0');
                o_at_last <= '0';
                ohave     <= '0';
            elsif acc_o = '1' then
                ocnt      <= ocnt + 1;
                o_at_last <= '1' when ocnt = CNT_LAST - 1 else '0';
                ohave     <= '1';
            end if;
            if rst = '1' then
                kg_take <= '0';
            elsif ce = '1' then
                kg_take <= obs_valid and o_at_last;
            end if;
            if acc_o = '1' then
                last_phase <= unsigned(obs_phase);
            end if;
            if ce = '1' then
                kg_in_s <= unsigned(kg_sin);
                kg_in_c <= unsigned(kg_cos);
                if kg_take = '1' then
                    kg_hold_s <= kg_in_s;
                    kg_hold_c <= kg_in_c;
                end if;
            end if;
        end if;
    end process p_ocnt;

    -- ---- observer: tables, stages 1..4: a = value + ((slope * frac + 2^(FB-1)) >>> FB) ----------------
    rd_addr  <= obs_bank & obs_phase(FINE_W - 1 downto FB);
    obs_frac <= obs_phase(FB - 1 downto 0);
    wr_en_s <= wr_en and not wr_sel;
    wr_en_c <= wr_en and wr_sel;

    u_fwd_sin : entity work.fringe_interp_table
        generic map (ADDR_W => FWD_W, W => TW, FB => FB, OUT_W => AW, ROUND_SHIFT => 0,
                     INIT_FILE => FWD_SIN_INIT)
        port map (clk => clk, ce => ce, wr_en => wr_en_s, wr_addr => wr_addr, wr_data => wr_data,
                  rd_addr => rd_addr, frac => obs_frac, result => a_s);

    u_fwd_cos : entity work.fringe_interp_table
        generic map (ADDR_W => FWD_W, W => TW, FB => FB, OUT_W => AW, ROUND_SHIFT => 0,
                     INIT_FILE => FWD_COS_INIT)
        port map (clk => clk, ce => ce, wr_en => wr_en_c, wr_addr => wr_addr, wr_data => wr_data,
                  rd_addr => rd_addr, frac => obs_frac, result => a_c);

    -- ---- observer: pipeline ------------------------------------------------------------------------------
    o_last <= o_at_last;
    -- the window: the block's last W samples (HOLD = 0: the second half, normalised with the latest state)
    o_win  <= '1' when HOLD /= 0 or ocnt(BLOCK_LOG2 - 1) = '1' else '0';
    o_flags <= o_win & o_last;

    u_obs_valid : entity work.fringe_delay
        generic map (WIDTH => 2, DEPTH => 8)
        port map (clk => clk, rst => rst, ce => ce, in_valid => obs_valid, in_data => o_flags,
                  out_valid => o8_valid, out_data => o8_flags);
    o8_last <= o8_flags(0);
    o8_win  <= o8_flags(1);

    p_obs : process (clk)
        variable dl     : unsigned(FINE_W - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- 1: input registers (the table read is in the RAMs)
                o1_phase <= unsigned(obs_phase);
                -- the first sample after reset is its own previous phase (delta 0): a choice of two inputs
                -- here, not a clear of o2_dl (the LSR pin, with ce in front of it)
                if ohave = '1' then
                    o1_prev <= last_phase;
                else
                    o1_prev <= unsigned(obs_phase);
                end if;
                o1_ys    <= signed(obs_y_sin);
                o1_yc    <= signed(obs_y_cos);
                o1_w0s   <= signed(w0_sin);
                o1_w0c   <= signed(w0_cos);
                -- 2: phase delta (wraps); y * 2^TABLE_FRAC - W0
                o2_dl <= o1_phase - o1_prev;
                o2_yws <= shift_left(resize(o1_ys, YW), TABLE_FRAC) - resize(o1_w0s, YW);
                o2_ywc <= shift_left(resize(o1_yc, YW), TABLE_FRAC) - resize(o1_w0c, YW);
                -- 3: |delta|
                o3_yws <= o2_yws;
                o3_ywc <= o2_ywc;
                dl := o2_dl;
                if dl(FINE_W - 1) = '1' then
                    o3_abs <= 0 - dl;
                else
                    o3_abs <= dl;
                end if;
                -- 4: a from the tables
                o4_yws <= o3_yws;
                o4_ywc <= o3_ywc;
                o4_abs <= o3_abs;
                -- 5: e = yw - a
                o5_es  <= resize(o4_yws, E_W) - resize(signed(a_s), E_W);
                o5_ec  <= resize(o4_ywc, E_W) - resize(signed(a_c), E_W);
                o5_as  <= signed(a_s);
                o5_ac  <= signed(a_c);
                o5_abs <= o4_abs;
                -- 6..8: e * a (g_ch); e and |delta| carried along (u_obs_carry)
            end if;
        end if;
    end process p_obs;

    -- ---- e * a (stages 6..8): 18x18 partial products ---------------------------------------------------
    ea_e <= std_logic_vector(o5_ec) & std_logic_vector(o5_es);     -- {cosine, sine}
    ea_a <= std_logic_vector(o5_ac) & std_logic_vector(o5_as);

    -- (the two channels' multipliers: g_ch below)
    o8_eas <= signed(ea_p(EA_W - 1 downto 0));
    o8_eac <= signed(ea_p(2 * EA_W - 1 downto EA_W));

    u_obs_carry : entity work.fringe_delay
        generic map (WIDTH => 2 * E_W + FINE_W, DEPTH => 3)
        port map (clk => clk, rst => rst, ce => ce, in_valid => '0',
                  in_data => std_logic_vector(o5_es) & std_logic_vector(o5_ec) & std_logic_vector(o5_abs),
                  out_valid => o8_carry_valid, out_data => o8_carry);
    o8_es  <= signed(o8_carry(2 * E_W + FINE_W - 1 downto E_W + FINE_W));
    o8_ec  <= signed(o8_carry(E_W + FINE_W - 1 downto FINE_W));
    o8_abs <= unsigned(o8_carry(FINE_W - 1 downto 0));

    -- 9: accumulators. The block's last sample is added like the others, so after it the accumulators
    -- hold the block's sums (read by stage 10 at the next clock enable, before a new sample can change
    -- them: no snapshot copies). fresh (set by that sample and by a reset) makes the next window sample
    -- start from 0 instead of a clear: a synchronous clear of the wide registers is the LSR pin, which
    -- took the block-end enable (and ce) across the chip to ~170 flip-flops (issue 11). One copy of it per
    -- accumulator (se_s, se_c, sea_s, sea_c, sweep), each written with its own feedback so that synthesis
    -- does not merge them: one register in front of ~170 LUTs was the next critical path.
    p_acc : process (clk)
        variable se_s_n, se_c_n   : signed(SE_W - 1 downto 0);
        variable sea_s_n, sea_c_n : signed(SEA_W - 1 downto 0);
        variable sweep_n          : unsigned(FINE_W downto 0);   -- with its carry
        variable blk_end, acc_w   : boolean;
        variable full_n           : boolean;
    begin
        if rising_edge(clk) then
            se_s_n  := resize(o8_es, SE_W);
            se_c_n  := resize(o8_ec, SE_W);
            sea_s_n := resize(o8_eas, SEA_W);
            sea_c_n := resize(o8_eac, SEA_W);
            sweep_n := resize(o8_abs, FINE_W + 1);
            if fresh(0) = '0' then se_s_n  := se_s + se_s_n; end if;
            if fresh(1) = '0' then se_c_n  := se_c + se_c_n; end if;
            if fresh(2) = '0' then sea_s_n := sea_s + sea_s_n; end if;
            if fresh(3) = '0' then sea_c_n := sea_c + sea_c_n; end if;
            if fresh(4) = '0' then sweep_n := resize(sweep, FINE_W + 1) + sweep_n; end if;
            full_n := (sweep_hi = '1' and fresh(4) = '0') or sweep_n(FINE_W) = '1';   -- SWEEP >= a period
            blk_end := o8_valid = '1' and o8_last = '1';   -- (in the window: the block's last sample)
            acc_w   := o8_valid = '1' and o8_win = '1';
            if rst = '1' then
                o9_go <= '0';
                fresh <= (others => '1');
            elsif ce = '1' then
                o9_go <= '1' when blk_end else '0';
                if blk_end then
                    fresh <= (others => '1');
                elsif acc_w then
                    fresh <= (others => '0');
                end if;
            end if;
            -- data only: no reset, no clear
            if ce = '1' and acc_w then
                se_s  <= se_s_n;
                se_c  <= se_c_n;
                sea_s <= sea_s_n;
                sea_c <= sea_c_n;
                sweep    <= sweep_n(FINE_W - 1 downto 0);
                sweep_hi <= '1' when full_n else '0';
            end if;
            -- The block's SWEEP test, registered at its last sample. A block that swept less than a period (but
            -- at least 2^SWEEP_LO) updates at the final gear, if that is 2^-2 or smaller, and does not count. The
            -- gear changes only at stage 16, long before the next block's end (B >= 16 samples later), so stages
            -- 10 and 14 see the block's gear G.
            if ce = '1' and blk_end then
                snap_full  <= '1' when full_n else '0';
                snap_ok    <= '1' when full_n or (PARTIAL and sweep_n(FINE_W - 1 downto SWEEP_LO) /= 0) else '0';
            end if;
            -- g_up: a function of snap_full and the gear, both constant from stage 10 to 16 (and frozen by
            -- ce = 0), registered every clock: no enable, and no block-end term in front of its flip-flops.
            if snap_full = '1' then
                g_up <= MU_LOG2 - gear;
            else
                g_up <= 0;
            end if;
        end if;
    end process p_acc;

    -- ---- the update (stages 10..16) -------------------------------------------------------------------
    -- 10..13 P = SEA * KG: 18x18 partial products (g_ch); 10 the offset step at the gear, 11 OFF + step,
    -- 12 OFF saturated, SWEEP test carried along; 14 P * 2^(MU_LOG2 - G) >>> KG_SHIFT and its rounding bit;
    -- 15 GINV - that - the bit (the rounding as a borrow); 16 GINV saturated: resolved.
    kg_e <= std_logic_vector(sea_c) & std_logic_vector(sea_s);   -- {cosine, sine}: the block's sums at stage 10
    kg_k <= std_logic_vector(kg_hold_c) & std_logic_vector(kg_hold_s);

    -- the multipliers of one channel (0 sine, 1 cosine): e * a (stages 6..8), SEA * KG (10..13)
    g_ch : for ch in 0 to 1 generate
        u_ea : entity work.fringe_split_mul
            generic map (A_W => E_W, A_SIGNED => 1, B_W => AW, B_SIGNED => 1, LATENCY => 3)
            port map (clk => clk, ce => ce, a => ea_e((ch + 1) * E_W - 1 downto ch * E_W),
                      b => ea_a((ch + 1) * AW - 1 downto ch * AW), p => ea_p((ch + 1) * EA_W - 1 downto ch * EA_W));
        u_kg : entity work.fringe_split_mul
            generic map (A_W => SEA_W, A_SIGNED => 1, B_W => KG_W, B_SIGNED => 0, LATENCY => 4)
            port map (clk => clk, ce => ce, a => kg_e((ch + 1) * SEA_W - 1 downto ch * SEA_W),
                      b => kg_k((ch + 1) * KG_W - 1 downto ch * KG_W), p => kg_p((ch + 1) * P_W - 1 downto ch * P_W));
    end generate g_ch;

    -- P sign-extended to PR_W bits (fits P * 2^(MU_LOG2 - G): PR_W > P_W + MU_LOG2 + 1)
    px_s <= resize(signed(kg_p(P_W - 1 downto 0)), PR_W);
    px_c <= resize(signed(kg_p(2 * P_W - 1 downto P_W)), PR_W);

    -- stages 10..14: LATENCY - 11 (1..8 before the accumulators, 9 the block's end, 15 and 16 after)
    u_upd_valid : entity work.fringe_delay
        generic map (WIDTH => 2, DEPTH => LATENCY - 11)
        port map (clk => clk, rst => rst, ce => ce, in_valid => o9_go, in_data => snap_full & snap_ok,
                  out_valid => u5_valid, out_data => u5_tests);

    -- 13..15: OFF carried along
    u_upd_carry : entity work.fringe_delay
        generic map (WIDTH => 2 * OW + 1, DEPTH => 3)
        port map (clk => clk, rst => rst, ce => ce, in_valid => '0',
                  in_data => std_logic_vector(u3_os) & std_logic_vector(u3_oc) & u3_sat,
                  out_valid => u6_carry_valid, out_data => u6_carry);
    u6_os  <= signed(u6_carry(2 * OW downto OW + 1));
    u6_oc  <= signed(u6_carry(OW downto 1));
    u6_sat <= u6_carry(0);

    -- Gear shift: update number u (updates resolved with a whole period swept since reset, i.e. applied or
    -- about to be) runs at G_u = min(MU_LOG2, bit_length(u)); g_left counts the updates left at this gear. The
    -- gear changes only at stage 16, after the stages 10 and 14 of the same block read it (stage 10 directly,
    -- stage 14 through g_up).
    p_upd : process (clk)
        variable sxo_s, sxo_c : signed(XW - 1 downto 0);
        variable pk_s, pk_c   : signed(PR_W - 1 downto 0);
        variable dgn_s, dgn_c : signed(GS_W - 1 downto 0);
        variable rbn_s, rbn_c : signed(GS_W - 1 downto 0);
        variable gs_neg, gc_neg, gs_high, gc_high, os_over, oc_over : boolean;
        variable hi_s, hi_c, lo_s, lo_c : unsigned(GINV_W - 1 downto 0);   -- the saturation's OR / AND masks
        variable g_more, u5_go : boolean;
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- 10: (SE * 2^OFS_FRAC) >>> (log2(W) + TABLE_FRAC - 1 + G)
                -- (log2(W) + TABLE_FRAC - 1 + G at a whole period, else at the final gear MU_LOG2: a shift by
                -- the gear register and a fixed one, chosen by the SWEEP test's register after them)
                sxo_s := shift_left(resize(se_s, XW), OFS_FRAC);
                sxo_c := shift_left(resize(se_c, XW), OFS_FRAC);
                if snap_full = '1' then
                    u1_ss <= shift_right(shift_right(sxo_s, SH_B), gear);
                    u1_sc <= shift_right(shift_right(sxo_c, SH_B), gear);
                else
                    u1_ss <= shift_right(sxo_s, SH_B + MU_LOG2);
                    u1_sc <= shift_right(sxo_c, SH_B + MU_LOG2);
                end if;
                -- 11: OFF + step
                u2_os <= resize(off_s, OS_W) + resize(u1_ss, OS_W);
                u2_oc <= resize(off_c, OS_W) + resize(u1_sc, OS_W);
                -- 12: OFF saturated
                os_over := outside(u2_os, OW);
                oc_over := outside(u2_oc, OW);
                u3_os  <= saturate(u2_os, OW);
                u3_oc  <= saturate(u2_oc, OW);
                u3_sat <= '1' when os_over or oc_over else '0';
                -- 14: the gain step at the gear, (P * 2^(MU_LOG2 - G) + 2^(KG_SHIFT-1)) >>> KG_SHIFT in two parts
                pk_s := shift_left(px_s, g_up);
                pk_c := shift_left(px_c, g_up);
                u5_dg_s <= pk_s(PR_W - 1 downto KG_SHIFT);
                u5_dg_c <= pk_c(PR_W - 1 downto KG_SHIFT);
                u5_rb_s <= pk_s(KG_SHIFT - 1);
                u5_rb_c <= pk_c(KG_SHIFT - 1);
                -- 15: GINV - dg - rb = GINV + not dg + not rb
                dgn_s := not resize(u5_dg_s, GS_W);
                dgn_c := not resize(u5_dg_c, GS_W);
                rbn_s := (others => '0');
                rbn_c := (others => '0');
                rbn_s(0) := not u5_rb_s;
                rbn_c(0) := not u5_rb_c;
                u6_gs <= signed(resize(ginv_s, GS_W)) + dgn_s + rbn_s;
                u6_gc <= signed(resize(ginv_c, GS_W)) + dgn_c + rbn_c;
            end if;
            -- 16: resolved: the pending update (taken by the normaliser at its application sample) or a skip
            gs_neg  := u6_gs(GS_W - 1) = '1';
            gc_neg  := u6_gc(GS_W - 1) = '1';
            gs_high := not gs_neg and u6_gs(GS_W - 2 downto GINV_W) /= 0;
            gc_high := not gc_neg and u6_gc(GS_W - 2 downto GINV_W) /= 0;
            -- Its decisions are registered at stage 15 (the gear and g_left cannot change in between: they
            -- change only at a stage 16, and blocks are B >= 16 samples apart), so that ce meets one gate in
            -- front of the enables of the state registers, not the SWEEP tests and the gear compares.
            g_more := u5_tests(1) = '1' and gear /= MU_LOG2;
            u5_go  := u5_valid = '1' and u5_tests(0) = '1';
            if rst = '1' then
                u6_valid <= '0';
                u6_go    <= '0';
                u6_gup   <= '0';
                u6_gdec  <= '0';
            elsif ce = '1' then
                u6_valid <= u5_valid;
                u6_go    <= '1' when u5_go else '0';
                u6_gup   <= '1' when u5_go and g_more and g_left = 1 else '0';
                u6_gdec  <= '1' when u5_go and g_more and g_left /= 1 else '0';
            end if;
            -- the flags: set by a block's resolution (pend_valid if it updates: u6_go implies u6_valid), cleared
            -- when the normaliser takes the update at its application sample (HOLD = 1: it waits for resolved)
            if rst = '1' then
                pend_valid <= '0';
                resolved   <= '0';
            elsif ce = '1' and u6_valid = '1' then
                pend_valid <= u6_go or (pend_valid and not upd_take);
                resolved   <= '1';
            elsif upd_take = '1' then
                pend_valid <= '0';
                resolved   <= '0';
            end if;
            if rst = '1' then
                gear   <= 0;
                g_left <= 1;
            elsif ce = '1' and u6_gup = '1' then
                gear   <= gear + 1;
                g_left <= 2 ** gear;         -- 2^(G_new - 1) updates at the new gear
            elsif ce = '1' and u6_gdec = '1' then
                g_left <= g_left - 1;
            end if;
            if ce = '1' and u6_go = '1' then
                pend_off_s <= u6_os;
                pend_off_c <= u6_oc;
                -- saturated with AND / OR, not a choice of constants (which synthesis maps to the LSR pin)
                hi_s := (others => '0');
                hi_c := (others => '0');
                lo_s := (others => '1');
                lo_c := (others => '1');
                if gs_high then hi_s := (others => '1'); end if;
                if gc_high then hi_c := (others => '1'); end if;
                if gs_neg then lo_s := (others => '0'); end if;
                if gc_neg then lo_c := (others => '0'); end if;
                pend_ginv_s <= (unsigned(u6_gs(GINV_W - 1 downto 0)) or hi_s) and lo_s;
                pend_ginv_c <= (unsigned(u6_gc(GINV_W - 1 downto 0)) or hi_c) and lo_c;
                pend_sat <= '1' when u6_sat = '1' or gs_neg or gs_high or gc_neg or gc_high else '0';
            end if;
        end if;
    end process p_upd;

end architecture rtl;
