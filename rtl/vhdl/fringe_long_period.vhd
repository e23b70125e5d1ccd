-- fringe_long_period: the seed 000 harmonic (long-period) table, then direction and zero.
--
-- VHDL-2008 twin of rtl/verilog/fringe_long_period.v (same generics, ports, latency and bit-exact
-- behaviour; see there for the formats). One difference: VHDL integers are 32 bits, so LP_RECIP is
-- limited to 2^31 - 1 here (every power-of-two REV, and most others with LP_IF <= 6); the Verilog
-- takes 64 bits. Elaboration stops with a message when it does not fit.
-- Bit-exact model: model/fringe/fixed/long_period.py.
--
-- LATENCY = 6 clock enables: 1 index product, 2 table read, 3 slope x fraction,
-- 4 correction rounded to counts, 5 subtract and wrap, 6 direction and zero.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use ieee.math_real.all;

entity fringe_long_period is
    generic (
        LINES     : integer := 256;    -- signal periods per revolution, >= 1
        FINE_W    : integer := 16;     -- fine phase bits per period, 8..30
        LP_ADDR_W : integer := 8;      -- 2^LP_ADDR_W table entries per revolution, 2..16
        LP_W      : integer := 18;     -- value and slope width, 8..32
        LP_FRAC   : integer := 4;      -- fraction bits of the correction (fine counts), 0..16
        LP_IF     : integer := 8;      -- interpolation fraction bits, 1..16, <= LP_SHIFT
        LP_RECIP  : natural := 1;      -- index multiplier, from index_mapping() (< 2^31 in VHDL)
        LP_SHIFT  : integer := 16;     -- index shift, from index_mapping()
        INIT_FILE : string  := "";     -- hex image, 2 banks x 2^LP_ADDR_W words {slope, value}
        USER_W    : integer := 1;      -- sideband width, >= 1
        -- derived: do not override
        POS_W     : integer := integer(ceil(log2(real(LINES)))) + FINE_W
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;
        ce        : in  std_logic;
        in_valid  : in  std_logic;
        pos       : in  std_logic_vector(POS_W - 1 downto 0);
        bank      : in  std_logic;
        zero      : in  std_logic_vector(POS_W - 1 downto 0);
        dir       : in  std_logic;
        in_user   : in  std_logic_vector(USER_W - 1 downto 0);
        wr_en     : in  std_logic;
        wr_addr   : in  std_logic_vector(LP_ADDR_W downto 0);
        wr_data   : in  std_logic_vector(2 * LP_W - 1 downto 0);
        out_valid : out std_logic;
        pos_out   : out std_logic_vector(POS_W - 1 downto 0);
        out_user  : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_long_period;

architecture rtl of fringe_long_period is

    function bits(n : natural) return integer is
        variable b : integer := 1;
    begin
        while b < 31 and 2**b <= n loop
            b := b + 1;
        end loop;
        return b;
    end function bits;

    function generics_ok return boolean is
    begin
        assert FINE_W >= 8 and FINE_W <= 30
            report "fringe_long_period: FINE_W = " & integer'image(FINE_W) & " out of range 8..30" severity failure;
        assert LP_ADDR_W >= 2 and LP_ADDR_W <= 16 and LP_ADDR_W <= POS_W
            report "fringe_long_period: LP_ADDR_W = " & integer'image(LP_ADDR_W)
                   & " out of range 2..16 or above clog2(REV)" severity failure;
        assert LP_W >= 8 and LP_W <= 32
            report "fringe_long_period: LP_W = " & integer'image(LP_W) & " out of range 8..32" severity failure;
        assert LP_FRAC >= 0 and LP_FRAC <= 16
            report "fringe_long_period: LP_FRAC = " & integer'image(LP_FRAC) & " out of range 0..16"
            severity failure;
        assert LP_IF >= 1 and LP_IF <= 16 and LP_IF <= LP_SHIFT
            report "fringe_long_period: LP_IF = " & integer'image(LP_IF) & " out of range 1..16 or above LP_SHIFT"
            severity failure;
        assert LP_W - 1 - LP_FRAC < POS_W - 1
            report "fringe_long_period: LP_W - LP_FRAC allows corrections of half a revolution" severity failure;
        assert USER_W >= 1
            report "fringe_long_period: USER_W = " & integer'image(USER_W) & " must be >= 1" severity failure;
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := 6;
    constant RECIP_W : integer := bits(LP_RECIP);
    constant T_W     : integer := POS_W + RECIP_W;
    constant PR_W    : integer := LP_W + LP_IF + 1;
    constant C_W     : integer := LP_W + 2;
    constant WW      : integer := maximum(POS_W, C_W) + 2;
    constant REV_S   : signed(WW - 1 downto 0) := shift_left(to_signed(LINES, WW), FINE_W);

    signal s1_entry : unsigned(LP_ADDR_W - 1 downto 0);
    signal s1_frac, s2_frac : unsigned(LP_IF - 1 downto 0);
    signal s1_pos, s1_zero, s2_pos, s2_zero, s3_pos, s3_zero, s4_zero, s5_pos_c, s5_zero
        : unsigned(POS_W - 1 downto 0);
    signal s1_bank, s1_dir, s2_dir, s3_dir, s4_dir, s5_dir : std_logic;
    signal word     : std_logic_vector(2 * LP_W - 1 downto 0);
    signal s3_prod  : signed(PR_W - 1 downto 0);
    signal s3_value : signed(LP_W - 1 downto 0);
    signal s4_pos_c : signed(WW - 1 downto 0);
    signal rd_addr  : std_logic_vector(LP_ADDR_W downto 0);

    type user_sr_t is array (1 to LATENCY) of std_logic_vector(USER_W - 1 downto 0);
    signal valid_sr : std_logic_vector(1 to LATENCY);
    signal user_sr  : user_sr_t;

    function wrap(v : signed) return signed is
    begin
        if v < 0 then
            return v + REV_S;
        elsif v >= REV_S then
            return v - REV_S;
        end if;
        return v;
    end function wrap;

begin

    rd_addr <= s1_bank & std_logic_vector(s1_entry);

    u_table : entity work.fringe_table_ram
        generic map (ADDR_W => LP_ADDR_W, DATA_W => 2 * LP_W, INIT_FILE => INIT_FILE)
        port map (clk => clk, wr_en => wr_en, wr_addr => wr_addr, wr_data => wr_data,
                  rd_en => ce, rd_addr => rd_addr, rd_data => word);

    datapath : process (clk)
        variable t        : unsigned(T_W - 1 downto 0);
        variable prod_rnd : signed(PR_W - 1 downto 0);
        variable corr     : signed(C_W - 1 downto 0);
        variable step     : signed(C_W - 1 downto 0);
        variable out_raw  : signed(WW - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- 1: index product
                t := resize(unsigned(pos) * to_unsigned(LP_RECIP, RECIP_W), T_W);
                s1_entry <= t(LP_SHIFT + LP_ADDR_W - 1 downto LP_SHIFT);
                s1_frac  <= t(LP_SHIFT - 1 downto LP_SHIFT - LP_IF);
                s1_pos   <= unsigned(pos);
                s1_zero  <= unsigned(zero);
                s1_bank  <= bank;
                s1_dir   <= dir;
                -- 2: table read (in fringe_table_ram)
                s2_frac <= s1_frac;
                s2_pos  <= s1_pos;
                s2_zero <= s1_zero;
                s2_dir  <= s1_dir;
                -- 3: slope x fraction
                s3_prod  <= resize(signed(word(2 * LP_W - 1 downto LP_W)) * signed('0' & s2_frac), PR_W);
                s3_value <= signed(word(LP_W - 1 downto 0));
                s3_pos   <= s2_pos;
                s3_zero  <= s2_zero;
                s3_dir   <= s2_dir;
                -- 4: correction rounded to whole counts, subtracted
                prod_rnd := s3_prod + shift_left(to_signed(1, PR_W), LP_IF - 1);
                corr := resize(s3_value, C_W) + resize(shift_right(prod_rnd, LP_IF), C_W);
                if LP_FRAC > 0 then
                    step := shift_right(corr + shift_left(to_signed(1, C_W), LP_FRAC - 1), LP_FRAC);
                else
                    step := corr;
                end if;
                s4_pos_c <= signed(resize(s3_pos, WW)) - resize(step, WW);
                s4_zero  <= s3_zero;
                s4_dir   <= s3_dir;
                -- 5: wrap into [0, REV)
                s5_pos_c <= resize(unsigned(wrap(s4_pos_c)), POS_W);   -- unsigned resize: keep the low bits
                s5_zero  <= s4_zero;
                s5_dir   <= s4_dir;
                -- 6: direction and zero
                if s5_dir = '1' then
                    out_raw := signed(resize(s5_zero, WW)) - signed(resize(s5_pos_c, WW));
                else
                    out_raw := signed(resize(s5_pos_c, WW)) + signed(resize(s5_zero, WW));
                end if;
                pos_out <= std_logic_vector(resize(unsigned(wrap(out_raw)), POS_W));
            end if;
        end if;
    end process datapath;

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
