-- fringe_period_count: coarse/fine combination, or period counting without a coarse code.
--
-- VHDL-2008 twin of rtl/verilog/fringe_period_count.v (same generics, ports, latency and
-- bit-exact behaviour). REV = LINES * 2^FINE_W, POS_W = FINE_W + clog2(LINES):
--   delta      s(FINE_W) = phase - phase of the previous valid sample (modulo 2^FINE_W)
--   overspeed  |delta| >= 2^(FINE_W-2); never on the first sample after reset
--   COARSE_W > 0: centre = (coarse * LINES << (FINE_W - COARSE_W)) + coarse_ofs; d = centre - phase;
--     n = (d + 2^(FINE_W-1)) >>> FINE_W; r = d - n * 2^FINE_W; coarse_err = |r| > COARSE_TOL;
--     pos = (n mod LINES) * 2^FINE_W + phase   (|coarse_ofs| <= 2^FINE_W)
--   COARSE_W = 0: pos = (pos_prev + delta) mod REV; the first valid sample after reset: pos = phase
-- Bit-exact model: model/fringe/fixed/period_count.py.
--
-- LATENCY = 2 clock enables: 1 delta, overspeed, coarse centre; 2 period number and position.
-- rst (synchronous, active high, wins over ce) clears the valid pipeline and the
-- "have a previous sample" state.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use ieee.math_real.all;

entity fringe_period_count is
    generic (
        FINE_W   : integer := 16;    -- fine phase bits per signal period, 8..30
        LINES    : integer := 256;   -- signal periods per revolution, 1..2^20, any integer
        COARSE_W : integer := 9;     -- coarse code bits, 0 = none; else FINE_W >= COARSE_W + 2, 2^COARSE_W >= LINES
        USER_W   : integer := 1;     -- sideband width, >= 1
        -- derived: do not override
        POS_W    : integer := integer(ceil(log2(real(LINES)))) + FINE_W;
        CW       : integer := maximum(COARSE_W, 1)
    );
    port (
        clk        : in  std_logic;
        rst        : in  std_logic;                              -- synchronous, active high
        ce         : in  std_logic;                              -- clock enable
        in_valid   : in  std_logic;
        phase      : in  std_logic_vector(FINE_W - 1 downto 0);  -- u(FINE_W)
        coarse     : in  std_logic_vector(CW - 1 downto 0);      -- u(COARSE_W), ignored when COARSE_W = 0
        coarse_ofs : in  std_logic_vector(POS_W downto 0);       -- s(POS_W+1), |value| <= 2^FINE_W
        in_user    : in  std_logic_vector(USER_W - 1 downto 0);
        out_valid  : out std_logic;
        pos        : out std_logic_vector(POS_W - 1 downto 0);   -- u(POS_W), in [0, REV)
        overspeed  : out std_logic;
        coarse_err : out std_logic;
        out_user   : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_period_count;

architecture rtl of fringe_period_count is

    function generics_ok return boolean is
    begin
        assert FINE_W >= 8 and FINE_W <= 30
            report "fringe_period_count: FINE_W = " & integer'image(FINE_W) & " out of range 8..30"
            severity failure;
        assert LINES >= 1 and LINES <= 2**20
            report "fringe_period_count: LINES = " & integer'image(LINES) & " out of range 1..2^20"
            severity failure;
        assert COARSE_W = 0 or (COARSE_W >= 1 and COARSE_W <= 24 and FINE_W >= COARSE_W + 2)
            report "fringe_period_count: COARSE_W = " & integer'image(COARSE_W)
                   & " must be 0 or 1..24 with FINE_W >= COARSE_W + 2"
            severity failure;
        assert COARSE_W = 0 or 2**COARSE_W >= LINES
            report "fringe_period_count: 2^COARSE_W < LINES" severity failure;
        assert USER_W >= 1
            report "fringe_period_count: USER_W = " & integer'image(USER_W) & " must be >= 1" severity failure;
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := 2;
    constant W       : integer := POS_W + 3;
    constant SH      : integer := maximum(FINE_W - COARSE_W, 0);
    constant LINES_W : signed(W - 1 downto 0) := to_signed(LINES, W);
    constant REV_W   : signed(W - 1 downto 0) := shift_left(LINES_W, FINE_W);
    constant HALF    : signed(W - 1 downto 0) := shift_left(to_signed(1, W), FINE_W - 1);
    function tolerance return signed is
    begin
        if COARSE_W > 0 then
            return shift_left(LINES_W, FINE_W - COARSE_W - 2) + shift_left(to_signed(1, W), FINE_W - 2);
        end if;
        return to_signed(0, W);
    end function tolerance;
    constant TOL : signed(W - 1 downto 0) := tolerance;

    signal prev_phase : unsigned(FINE_W - 1 downto 0);
    signal have_prev  : std_logic;
    signal s1_centre  : signed(W - 1 downto 0);
    signal s1_phase   : unsigned(FINE_W - 1 downto 0);
    signal s1_delta   : signed(FINE_W - 1 downto 0);
    signal s1_fast    : std_logic;
    signal s1_first   : std_logic;
    signal pos_count  : unsigned(POS_W - 1 downto 0);

    type user_sr_t is array (1 to LATENCY) of std_logic_vector(USER_W - 1 downto 0);
    signal valid_sr : std_logic_vector(1 to LATENCY);
    signal user_sr  : user_sr_t;

begin

    -- stage 1: delta to the previous sample, overspeed, coarse centre
    stage1 : process (clk)
        variable delta : signed(FINE_W - 1 downto 0);
        variable cw_v  : signed(W - 1 downto 0);
    begin
        if rising_edge(clk) then
            if rst = '1' then
                have_prev <= '0';
            elsif ce = '1' and in_valid = '1' then
                have_prev <= '1';
            end if;
            if ce = '1' then
                delta := signed(unsigned(phase) - prev_phase);
                if in_valid = '1' then
                    prev_phase <= unsigned(phase);
                end if;
                cw_v := signed(resize(unsigned(coarse), W));
                s1_centre <= resize(shift_left(resize(cw_v * LINES_W, W), SH), W) + resize(signed(coarse_ofs), W);
                s1_phase <= unsigned(phase);
                s1_delta <= delta;
                if have_prev = '1' and abs(resize(delta, FINE_W + 1)) >= 2**(FINE_W - 2) then
                    s1_fast <= '1';
                else
                    s1_fast <= '0';
                end if;
                s1_first <= not have_prev;
            end if;
        end if;
    end process stage1;

    -- stage 2: period number and position
    stage2 : process (clk)
        variable phase_w : signed(W - 1 downto 0);
        variable d, d_half, n, r, n_wrap, sum, nxt : signed(W - 1 downto 0);
    begin
        if rising_edge(clk) then
            phase_w := signed(resize(s1_phase, W));
            d := s1_centre - phase_w;
            d_half := d + HALF;
            n := shift_right(d_half, FINE_W);
            r := signed(resize(unsigned(d_half(FINE_W - 1 downto 0)), W)) - HALF;
            if n < 0 then
                n_wrap := n + LINES_W;
            elsif n >= LINES_W then
                n_wrap := n - LINES_W;
            else
                n_wrap := n;
            end if;
            sum := signed(resize(pos_count, W)) + resize(s1_delta, W);
            if sum < 0 then
                nxt := sum + REV_W;
            elsif sum >= REV_W then
                nxt := sum - REV_W;
            else
                nxt := sum;
            end if;
            if s1_first = '1' then
                nxt := phase_w;
            end if;
            if ce = '1' and valid_sr(1) = '1' then
                pos_count <= unsigned(nxt(POS_W - 1 downto 0));
            end if;
            if ce = '1' then
                overspeed <= s1_fast;
                if COARSE_W > 0 then
                    pos <= std_logic_vector(unsigned(shift_left(n_wrap, FINE_W)(POS_W - 1 downto 0))
                                            or resize(s1_phase, POS_W));
                    if abs(r) > TOL then
                        coarse_err <= '1';
                    else
                        coarse_err <= '0';
                    end if;
                else
                    pos <= std_logic_vector(nxt(POS_W - 1 downto 0));
                    coarse_err <= '0';
                end if;
            end if;
        end if;
    end process stage2;

    -- valid (reset) and sideband
    pipe : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                valid_sr <= (others => '0');
            elsif ce = '1' then
                valid_sr <= in_valid & valid_sr(1 to LATENCY - 1);
            end if;
            if ce = '1' then
                user_sr <= in_user & user_sr(1 to LATENCY - 1);
            end if;
        end if;
    end process pipe;

    out_valid <= valid_sr(LATENCY);
    out_user  <= user_sr(LATENCY);

end architecture rtl;
