-- fringe_period_count: coarse/fine combination (absolute position from a coarse code), or period
-- counting without one; overspeed and coarse-code checks.
--
-- VHDL-2008 twin of rtl/verilog/fringe_period_count.v (same generics, ports and behaviour).
--
-- With a coarse code, r (the sample's distance from its code's centre) says whether edge jitter can
-- have flipped the code: a sample in the TRUST band, -2^(FINE_W-2) <= r < 2^(FINE_W-2) (the top two
-- bits of r agree), sets pos from the code; any other sample is tracked, (pos_prev + delta) mod REV as
-- the counter (a code of half a period or more flipped at its edge is a whole period off), except
-- before the first trusted sample since reset: there the first sample, an overspeed and a sample
-- nearer its code's centre than the start-up anchor (m < anchor_m, m = r XOR sign) set pos from the
-- code, so a start at a jittered edge follows the best code so far instead of every flip (not
-- flagged: edge jitter is not a wrong code). coarse_err: |r| > COARSE_TOL, or a trusted sample whose period number
-- differs from a track not lost by an overspeed since the last absolute output (a really wrong code:
-- pos resynchronises to the code), and every sample tracked from such a resync (track_bad).
-- LATENCY = 4 clock enables, one sample per clock: the track (pos_prev + delta, a one-clock loop) is
-- stage 3, the compare of its period number with the code's (resync, track_bad, coarse_err) stage 4,
-- out of the loop, from registered values; pos and overspeed wait one stage with it. ce = 0 freezes
-- every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_period_count.md.
-- Bit-exact model: model/fringe/fixed/period_count.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_period_count is
    generic (
        FINE_W   : integer := 16;   -- fine phase bits per signal period, 8..30
        LINES    : integer := 256;  -- signal periods per revolution, 1..2^20, any integer; FINE_W + clog2(LINES) <= 48
        COARSE_W : integer := 9;    -- coarse code bits: 0 = none (periods counted), else 1..24, <= FINE_W-2, 2^COARSE_W >= LINES
        USER_W   : integer := 1     -- sideband width, >= 1
    );
    port (
        clk        : in  std_logic;
        rst        : in  std_logic;                               -- synchronous, active high
        ce         : in  std_logic;                               -- clock enable
        -- sample in
        in_valid   : in  std_logic;
        phase      : in  std_logic_vector(FINE_W - 1 downto 0);   -- u(FINE_W)
        coarse     : in  std_logic_vector(maximum(COARSE_W, 1) - 1 downto 0);  -- u(COARSE_W); unused if 0
        coarse_ofs : in  std_logic_vector(FINE_W + clog2(LINES) downto 0);
                                                                  -- s(POS_W+1), fine counts, |value| <= 2^FINE_W
        in_user    : in  std_logic_vector(USER_W - 1 downto 0);
        -- position out
        out_valid  : out std_logic;
        pos        : out std_logic_vector(FINE_W + clog2(LINES) - 1 downto 0);
                                                                  -- u(POS_W), in [0, REV)
        overspeed  : out std_logic;
        coarse_err : out std_logic;
        out_user   : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_period_count;

architecture rtl of fringe_period_count is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_position("fringe_period_count", FINE_W, LINES, 48);
        assert COARSE_W = 0 or (COARSE_W >= 1 and COARSE_W <= 24 and COARSE_W <= FINE_W - 2)
            report "fringe_period_count: COARSE_W = " & integer'image(COARSE_W)
                   & " out of range: 0 (no coarse code) or 1..24 with COARSE_W <= FINE_W - 2"
            severity failure;
        assert COARSE_W = 0 or 2**COARSE_W >= LINES
            report "fringe_period_count: 2^COARSE_W = " & integer'image(2**COARSE_W) & " is less than LINES = "
                   & integer'image(LINES)
            severity failure;
        check_min("fringe_period_count", "USER_W", USER_W, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := PERIOD_COUNT_LATENCY;
    constant POS_W   : integer := FINE_W + clog2(LINES);   -- clog2(REV)
    constant N_W     : integer := POS_W - FINE_W;          -- period number bits (0 when LINES = 1)
    constant W       : integer := POS_W + 3;               -- signed: centre and d for any s(POS_W+1) offset
    constant NR      : integer := W - FINE_W;              -- signed period number before the wrap
    constant SW      : integer := POS_W + 2;               -- signed sum of the counter
    constant SH      : integer := maximum(FINE_W - COARSE_W, 0);

    -- |delta| >= 2^(FINE_W-2) for delta as s(FINE_W) is delta in [2^(FINE_W-2), 3 * 2^(FINE_W-2)]
    -- read as unsigned (the most negative delta, -2^(FINE_W-1), is inside).
    constant Q1 : unsigned(FINE_W - 1 downto 0) := shift_left(to_unsigned(1, FINE_W), FINE_W - 2);
    constant Q3 : unsigned(FINE_W - 1 downto 0) := shift_left(to_unsigned(3, FINE_W), FINE_W - 2);

    constant LINES_W : unsigned(W - 1 downto 0) := to_unsigned(LINES, W);
    constant REV_S   : unsigned(SW - 1 downto 0) := shift_left(to_unsigned(LINES, SW), FINE_W);
    -- the period-number bits of a position: the low FINE_W bits of the track's sum are the sample's
    -- phase (pos_prev's are the previous valid sample's, delta is their difference, REV a multiple of
    -- 2^FINE_W), so s3_pos takes them from s2_phase and the choice drives N_W bits
    constant HI      : unsigned(POS_W - 1 downto 0) := shift_left(not to_unsigned(0, POS_W), FINE_W);

    -- COARSE_TOL (< 2^(FINE_W-1) + 1) as s(FINE_W+1); 0 without a coarse code
    function tolerance return signed is
    begin
        if COARSE_W > 0 and COARSE_W <= FINE_W - 2 then
            return signed(shift_left(to_unsigned(LINES, FINE_W + 1), FINE_W - COARSE_W - 2)
                          + shift_left(to_unsigned(1, FINE_W + 1), FINE_W - 2));
        end if;
        return to_signed(0, FINE_W + 1);
    end function tolerance;
    constant TOL : signed(FINE_W downto 0) := tolerance;

    signal s2_valid   : std_logic;                              -- the sample in stage 2
    signal s3_valid   : std_logic;                              -- the sample in stage 3
    signal s2_user, s3_user : std_logic_vector(USER_W - 1 downto 0);
    signal take, step, done : std_logic;

    signal phase_prev : unsigned(FINE_W - 1 downto 0);  -- data: the previous valid sample's phase
    signal have_prev  : std_logic;                      -- state: a valid sample was taken since reset
    signal s1_phase   : unsigned(FINE_W - 1 downto 0);
    signal s1_delta   : unsigned(FINE_W - 1 downto 0);  -- phase - phase_prev mod 2^FINE_W
    signal s1_first   : std_logic;                      -- no previous sample
    signal s1_centre  : unsigned(W - 1 downto 0);
    signal s2_phase   : unsigned(FINE_W - 1 downto 0);
    signal s2_first   : std_logic;
    signal s2_over    : std_logic;
    signal s2_n       : unsigned(NR - 1 downto 0);      -- floor((d + half) / 2^FINE_W), in [-2, LINES+1]
    signal s2_r       : signed(FINE_W - 1 downto 0);    -- residual, in [-2^(FINE_W-1), 2^(FINE_W-1))
    signal s2_m       : unsigned(FINE_W - 2 downto 0);  -- r xor sign: r for r >= 0, -r-1 below (no carry)
    -- registered in stage 2 so that stage 3's choice is one LUT after m < anchor_m (4 inputs)
    signal s2_trusted : std_logic;                      -- -TRUST <= r < TRUST: the top two bits of r agree
    signal s2_restart : std_logic;                      -- the first sample or an overspeed: a start-up anchor
    signal s2_d, s2_d_up, s2_d_down : unsigned(SW - 1 downto 0);  -- counter: delta, delta + REV, delta - REV
    signal s3_pos     : unsigned(POS_W - 1 downto 0);   -- data: the track's pos_prev, pos one stage early
    signal s3_over    : std_logic;
    signal trusted_seen : std_logic;                    -- state: a trusted sample since reset
    signal track_lost   : std_logic;                    -- state: an overspeed since the last absolute output
    signal track_bad    : std_logic;                    -- state: the last absolute output was a resync
    -- m of the last start-up anchor (start_up: the first sample, an overspeed, m < anchor_m), read only
    -- before the first trusted sample (where those are the absolute samples besides the trusted one that
    -- ends it) and after the first sample since reset, which writes it: data, not reset (as s3_pos). Its
    -- write enable leaves trusted out (the m loop is a compare and one LUT).
    signal anchor_m     : unsigned(FINE_W - 2 downto 0);
    signal closer       : std_logic;                    -- m < anchor_m, in parallel with the track's sums
    signal start_up     : std_logic;                    -- the start-up anchor moves here
    signal resync       : std_logic;                    -- a trusted code disagrees with a valid track
    signal differs      : std_logic;                    -- the code's period number is not the track's
    signal trk          : unsigned(SW - 1 downto 0);    -- the tracked position, < REV
    signal n_wrap       : unsigned(NR - 1 downto 0);    -- the code's period number mod LINES
    signal trusted      : std_logic;                    -- -TRUST <= r < TRUST: the code cannot be flipped
    signal absolute     : std_logic;                    -- this sample's pos is the code's
    signal lost         : std_logic;                    -- the track is lost
    -- stage 4, out of the loop: the period numbers of the code and the track, and what else the
    -- resync and coarse_err take, registered in stage 3
    signal s3_n, s3_trk_n : unsigned(maximum(POS_W - FINE_W, 1) - 1 downto 0);
    signal s3_err, s3_absolute, s3_checked : std_logic;

begin

    -- ---- valid (reset) and sideband, LATENCY stages: stages 1-2, stage 3, then stage 4 --------
    u_valid_12 : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => LATENCY - 2)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
                  out_valid => s2_valid, out_data => s2_user);
    u_valid_3 : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => 1)
        port map (clk => clk, rst => rst, ce => ce, in_valid => s2_valid, in_data => s2_user,
                  out_valid => s3_valid, out_data => s3_user);
    u_valid_4 : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => 1)
        port map (clk => clk, rst => rst, ce => ce, in_valid => s3_valid, in_data => s3_user,
                  out_valid => out_valid, out_data => out_user);

    take <= ce and in_valid;       -- stage 1 takes a sample
    step <= ce and s2_valid;       -- stage 3 takes a sample: the track's loop and the state it reads
    done <= ce and s3_valid;       -- stage 4 produces an output

    -- ---- stage 1: delta to the previous valid sample, coarse centre --------------------------
    p_stage1 : process (clk)
        variable cpos : unsigned(W - 1 downto 0);
    begin
        if rising_edge(clk) then
            if take = '1' then
                phase_prev <= unsigned(phase);
                have_prev  <= '1';
            end if;
            if ce = '1' then
                s1_phase <= unsigned(phase);
                s1_delta <= unsigned(phase) - phase_prev;
                s1_first <= not have_prev;
                -- centre = (coarse * LINES << (FINE_W - COARSE_W)) + coarse_ofs (< REV + 2^POS_W)
                cpos := shift_left(resize(resize(unsigned(coarse), W) * LINES_W, W), SH);
                s1_centre <= cpos + unsigned(resize(signed(coarse_ofs), W));
            end if;
            if rst = '1' then           -- the state only, after the stage: rst wins
                have_prev <= '0';
            end if;
        end if;
    end process p_stage1;

    -- ---- stage 2: overspeed; d + half, or the counter's delta and its wrapped alternatives ----
    p_stage2 : process (clk)
        variable ph_h, dh : unsigned(W - 1 downto 0);
        variable dx       : unsigned(SW - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                s2_phase <= s1_phase;
                s2_first <= s1_first;
                if s1_first = '0' and s1_delta >= Q1 and s1_delta <= Q3 then
                    s2_over <= '1';
                else
                    s2_over <= '0';
                end if;
                if s1_first = '1' or (s1_delta >= Q1 and s1_delta <= Q3) then
                    s2_restart <= '1';
                else
                    s2_restart <= '0';
                end if;
                -- dh = d + 2^(FINE_W-1) = centre - (phase - 2^(FINE_W-1)), one subtract: phase -
                -- 2^(FINE_W-1) is phase with its top bit inverted, read as s(FINE_W); r is dh's low
                -- bits with the top one inverted, as s(FINE_W)
                ph_h := unsigned(resize(signed(not s1_phase(FINE_W - 1) & s1_phase(FINE_W - 2 downto 0)), W));
                dh   := s1_centre - ph_h;
                s2_n <= dh(W - 1 downto FINE_W);
                s2_r <= signed(not dh(FINE_W - 1) & dh(FINE_W - 2 downto 0));
                s2_m <= dh(FINE_W - 2 downto 0) xor (FINE_W - 2 downto 0 => not dh(FINE_W - 1));
                s2_trusted <= dh(FINE_W - 1) xor dh(FINE_W - 2);
                -- counter: delta + REV and delta - REV, so stage 3 adds once
                dx := unsigned(resize(signed(s1_delta), SW));
                s2_d      <= dx;
                s2_d_up   <= dx + REV_S;
                s2_d_down <= dx - REV_S;
            end if;
        end if;
    end process p_stage2;

    -- ---- stage 3: the track and the choice absolute/tracked (the loop) -------------------------
    trusted  <= s2_trusted;
    -- counting mode never writes anchor_m: no compare against its power-up 'U' (short-circuit and)
    closer   <= '1' when COARSE_W > 0 and s2_m < anchor_m else '0';
    start_up <= s2_restart or closer;
    absolute <= trusted or (not trusted_seen and start_up);
    lost     <= track_lost or s2_over;

    -- the track: (pos_prev + delta) mod REV, the three sums in parallel, chosen by sign bits; n mod
    -- LINES (n in [-2, LINES+1]), both candidates in parallel, chosen by sign bits
    p_comb : process (all)
        variable sum, sum_up, sum_down : unsigned(SW - 1 downto 0);
        variable n_up, n_down : unsigned(NR - 1 downto 0);
    begin
        sum      := resize(s3_pos, SW) + s2_d;
        sum_up   := resize(s3_pos, SW) + s2_d_up;
        sum_down := resize(s3_pos, SW) + s2_d_down;
        trk      <= wrapped(sum, sum_up, sum_down);
        n_up     := s2_n + LINES_W(NR - 1 downto 0);
        n_down   := s2_n - LINES_W(NR - 1 downto 0);
        if LINES = 1 then
            n_wrap <= (others => '0');      -- n mod 1 = 0
        else
            n_wrap <= wrapped(s2_n, n_up, n_down);
        end if;
    end process p_comb;

    p_stage3 : process (clk)
        variable r : signed(FINE_W downto 0);
    begin
        if rising_edge(clk) then
            if step = '1' then
                trusted_seen <= trusted_seen or trusted;
                track_lost   <= not absolute and lost;
                if COARSE_W > 0 then
                    if start_up = '1' then
                        anchor_m <= s2_m;
                    end if;
                    -- trk's low FINE_W bits are s2_phase (HI): only the period number is chosen
                    if absolute = '1' then
                        s3_pos <= shift_left(resize(n_wrap, POS_W), FINE_W) or resize(s2_phase, POS_W);
                    else
                        s3_pos <= (trk(POS_W - 1 downto 0) and HI) or resize(s2_phase, POS_W);
                    end if;
                else
                    if s2_first = '1' then
                        s3_pos <= resize(s2_phase, POS_W);
                    else
                        s3_pos <= (trk(POS_W - 1 downto 0) and HI) or resize(s2_phase, POS_W);
                    end if;
                end if;
            end if;
            -- what stage 4 takes: trk and the code's position share their low FINE_W bits (the
            -- phase), their period numbers are compared there, out of the loop
            if ce = '1' then
                s3_over <= s2_over;
                -- |r| > tol (two compares in parallel)
                r := resize(s2_r, FINE_W + 1);
                if COARSE_W > 0 and (r > TOL or r < -TOL) then
                    s3_err <= '1';
                else
                    s3_err <= '0';
                end if;
                s3_absolute <= absolute;
                s3_checked  <= trusted and trusted_seen and not lost;
                s3_n        <= resize(n_wrap, s3_n'length);
                s3_trk_n    <= resize(trk(SW - 1 downto FINE_W), s3_trk_n'length);
            end if;
            if rst = '1' then           -- the state only, after the stage: rst wins
                trusted_seen <= '0';
                track_lost   <= '0';
            end if;
        end if;
    end process p_stage3;

    -- ---- stage 4: the resync, track_bad, coarse_err; the outputs -----------------------------
    differs <= '1' when POS_W > FINE_W and s3_n /= s3_trk_n else '0';
    resync  <= s3_checked and differs;

    p_stage4 : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                track_bad <= '0';
            elsif done = '1' and s3_absolute = '1' then
                track_bad <= resync;
            end if;
            if done = '1' then
                pos       <= std_logic_vector(s3_pos);
                overspeed <= s3_over;
                if COARSE_W = 0 then
                    coarse_err <= '0';
                elsif s3_absolute = '1' then
                    coarse_err <= s3_err or resync;
                else
                    coarse_err <= s3_err or track_bad;
                end if;
            end if;
        end if;
    end process p_stage4;

end architecture rtl;
