-- fringe_long_period: the seed 000 harmonic (long-period) correction table with linear
-- interpolation, then the output direction and zero.
--
-- VHDL-2008 twin of rtl/verilog/fringe_long_period.v (same generics, ports and behaviour).
-- LATENCY = 8 clock enables, one sample per clock; ce = 0 freezes
-- every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_long_period.md.
-- Bit-exact model: model/fringe/fixed/long_period.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_long_period is
    generic (
        LINES     : integer := 256;  -- signal periods per revolution, 1..2^20; FINE_W + clog2(LINES) <= 48
        FINE_W    : integer := 16;   -- fine phase bits per period, 8..30
        LP_ADDR_W : integer := 8;    -- 2^LP_ADDR_W table entries per revolution, 2..16, 2^LP_ADDR_W <= REV
        LP_W      : integer := 18;   -- width of value and slope, 8..32; 2^(LP_W - LP_FRAC) <= REV
        LP_FRAC   : integer := 4;    -- fraction bits of the correction (fine counts), 0..16
        LP_IF     : integer := 8;    -- interpolation fraction bits, 1..16
        LP_RECIP  : natural := 1;    -- index multiplier, from index_mapping() (checked; < 2^31 in VHDL)
        LP_SHIFT  : integer := 16;   -- index shift, LP_IF..127, from index_mapping() (checked)
        INIT_FILE : string  := "";   -- hex image of the table, 2 banks x 2^LP_ADDR_W words; "" = zeros
        USER_W    : integer := 1     -- sideband width, >= 1
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;                              -- synchronous: clears valid only
        ce        : in  std_logic;                              -- clock enable
        -- sample in
        in_valid  : in  std_logic;
        pos       : in  std_logic_vector(FINE_W + clog2(LINES) - 1 downto 0);
                                                                -- u(POS_W), in [0, REV)
        bank      : in  std_logic;                              -- table bank of this sample
        zero      : in  std_logic_vector(FINE_W + clog2(LINES) - 1 downto 0);
                                                                -- u(POS_W), in [0, REV)
        dir       : in  std_logic;                              -- 1: the output runs the other way
        in_user   : in  std_logic_vector(USER_W - 1 downto 0);
        -- table write port (software side), independent of ce
        wr_en     : in  std_logic;
        wr_addr   : in  std_logic_vector(LP_ADDR_W downto 0);   -- {bank, entry}
        wr_data   : in  std_logic_vector(2 * LP_W - 1 downto 0);  -- {slope, value}
        -- position out
        out_valid : out std_logic;
        pos_out   : out std_logic_vector(FINE_W + clog2(LINES) - 1 downto 0);
                                                                -- u(POS_W), in [0, REV)
        out_user  : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_long_period;

architecture rtl of fringe_long_period is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_position("fringe_long_period", FINE_W, LINES, 48);
        check_range("fringe_long_period", "LP_ADDR_W", LP_ADDR_W, 2, 16);
        -- 2^LP_ADDR_W <= REV = LINES * 2^FINE_W
        assert LP_ADDR_W <= FINE_W or LINES >= 2**(LP_ADDR_W - FINE_W)
            report "fringe_long_period: 2^LP_ADDR_W = " & integer'image(2**LP_ADDR_W)
                   & " entries exceed REV = LINES * 2^FINE_W"
            severity failure;
        check_range("fringe_long_period", "LP_W", LP_W, 8, 32);
        check_range("fringe_long_period", "LP_FRAC", LP_FRAC, 0, 16);
        check_range("fringe_long_period", "LP_IF", LP_IF, 1, 16);
        -- 2^(LP_W - LP_FRAC) <= REV
        assert LP_W - LP_FRAC <= FINE_W or LINES >= 2**(LP_W - LP_FRAC - FINE_W)
            report "fringe_long_period: LP_W - LP_FRAC = " & integer'image(LP_W - LP_FRAC)
                   & ": corrections up to 2^" & integer'image(LP_W - LP_FRAC)
                   & " fine counts exceed REV = LINES * 2^FINE_W"
            severity failure;
        assert LP_SHIFT >= LP_IF and LP_SHIFT <= 127
            report "fringe_long_period: LP_SHIFT = " & integer'image(LP_SHIFT) & " out of range LP_IF = "
                   & integer'image(LP_IF) & " .. 127"
            severity failure;
        check_mapping("fringe_long_period", "LP", "LP_ADDR_W", "index_mapping", LP_RECIP, LP_SHIFT, LP_ADDR_W,
                      LINES, FINE_W);
        check_min("fringe_long_period", "USER_W", USER_W, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := LONG_PERIOD_LATENCY;
    constant POS_W   : integer := FINE_W + clog2(LINES);            -- clog2(REV)
    constant RECIP_W : integer := bit_width(LP_RECIP);
    constant T_W     : integer := maximum(POS_W + RECIP_W, LP_SHIFT + LP_ADDR_W);  -- index product
    constant PR_W    : integer := LP_W + LP_IF + 1;                 -- slope x frac
    constant C_W     : integer := maximum(LP_W, LP_FRAC) + 2;       -- value + 2^(LP_FRAC-1) + ip
    constant SX_W    : integer := C_W + LP_IF;                      -- {value, 2^(LP_IF-1)} + product
    -- 2^(LP_IF-1) in LP_IF + 1 bits; its low LP_IF bits are concatenated below value
    constant RND_X   : signed(LP_IF downto 0) := shift_left(to_signed(1, LP_IF + 1), LP_IF - 1);
    constant WW      : integer := POS_W + 2;                        -- signed positions
    constant REV_W   : unsigned(WW - 1 downto 0) := shift_left(to_unsigned(LINES, WW), FINE_W);


    signal s1_entry          : unsigned(LP_ADDR_W - 1 downto 0);
    signal s1_frac, s2_frac  : unsigned(LP_IF - 1 downto 0);
    signal s1_pos, s1_zero, s2_pos, s2_zero, s3_pos, s3_zero, s4_zero, s5_pos_c
                             : unsigned(POS_W - 1 downto 0);
    signal s1_bank           : std_logic;
    signal s1_dir, s2_dir, s3_dir, s4_dir, s5_dir : std_logic;
    signal rd_addr           : std_logic_vector(LP_ADDR_W downto 0);
    signal word_ram, word    : std_logic_vector(2 * LP_W - 1 downto 0);   -- word: the RAM's output register
    signal s1b_frac          : unsigned(LP_IF - 1 downto 0);
    signal s1b_pos, s1b_zero : unsigned(POS_W - 1 downto 0);
    signal s1b_dir           : std_logic;
    signal prod              : std_logic_vector(LP_W + LP_IF - 1 downto 0);
    signal s3_prod           : signed(PR_W - 1 downto 0);    -- after stage 3b: slope * frac
    signal s3a_value, s3_value : signed(C_W - 1 downto 0);
    signal s3a_pos, s3a_zero : unsigned(POS_W - 1 downto 0);
    signal s3a_dir           : std_logic;
    signal s4_step           : signed(C_W - LP_FRAC - 1 downto 0);
    signal s4_pos, s4_pos_up, s4_pos_dn : signed(WW - 1 downto 0);
    signal s5_zero, s5_zero_alt : unsigned(WW - 1 downto 0);

begin

    -- ---- valid (the only reset registers) and sideband, LATENCY stages -----------------------
    u_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => LATENCY)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
                  out_valid => out_valid, out_data => out_user);

    -- ---- 2: table read ---------------------------------------------------------------------------
    rd_addr <= s1_bank & std_logic_vector(s1_entry);

    u_table : entity work.fringe_table_ram
        generic map (ADDR_W => LP_ADDR_W, DATA_W => 2 * LP_W, INIT_FILE => INIT_FILE)
        port map (clk => clk, wr_en => wr_en, wr_addr => wr_addr, wr_data => wr_data,
                  rd_en => ce, rd_addr => rd_addr, rd_data => word_ram);

    -- ---- 3, 3b: slope x fraction in 16x16 partial products (slope split above 15 bits) -----------
    u_prod : entity work.fringe_split_mul
        generic map (A_W => LP_W, A_SIGNED => 1, B_W => LP_IF, B_SIGNED => 0, LATENCY => 2, LO_W => 15)
        port map (clk => clk, ce => ce, a => word(2 * LP_W - 1 downto LP_W), b => std_logic_vector(s2_frac),
                  p => prod);
    s3_prod <= resize(signed(prod), PR_W);

    p_data : process (clk)
        variable t        : unsigned(T_W - 1 downto 0);
        variable sum4     : signed(SX_W - 1 downto 0);
        variable pos_x    : signed(WW - 1 downto 0);
        variable step_x, c_mid, c_up, c_down, c_wrap : signed(WW - 1 downto 0);
        variable zero_x   : unsigned(WW - 1 downto 0);
        variable pc_x, a, b : unsigned(WW - 1 downto 0);
        variable use_b    : boolean;
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

                -- 2: the table read is in fringe_table_ram (rd_en = ce); 2b: its output register
                s1b_frac <= s1_frac;
                s1b_pos  <= s1_pos;
                s1b_zero <= s1_zero;
                s1b_dir  <= s1_dir;
                word     <= word_ram;
                s2_frac  <= s1b_frac;
                s2_pos   <= s1b_pos;
                s2_zero  <= s1b_zero;
                s2_dir   <= s1b_dir;

                -- 3: slope x fraction (u_prod); value + 2^(LP_FRAC-1)
                s3a_value <= resize(signed(word(LP_W - 1 downto 0)), C_W) + round_half(C_W, LP_FRAC);
                s3a_pos   <= s2_pos;
                s3a_zero  <= s2_zero;
                s3a_dir   <= s2_dir;
                -- 3b: the partial products summed (u_prod)
                s3_value  <= s3a_value;
                s3_pos    <= s3a_pos;
                s3_zero   <= s3a_zero;
                s3_dir    <= s3a_dir;

                -- 4: step = corr + 2^(LP_FRAC-1) >>> LP_FRAC, one add: ({value + 2^(LP_FRAC-1),
                -- 2^(LP_IF-1)} + product) >>> (LP_IF + LP_FRAC); pos -+ REV in parallel for stage 5
                sum4 := (s3_value & RND_X(LP_IF - 1 downto 0)) + resize(s3_prod, SX_W);
                s4_step   <= sum4(SX_W - 1 downto LP_IF + LP_FRAC);
                pos_x     := signed(resize(s3_pos, WW));
                s4_pos    <= pos_x;
                s4_pos_up <= pos_x + signed(REV_W);
                s4_pos_dn <= pos_x - signed(REV_W);
                s4_zero   <= s3_zero;
                s4_dir    <= s3_dir;

                -- 5: pos_c = (pos - step) mod REV, the three differences in parallel, chosen by sign
                -- bits (|step| <= 2^(LP_W-LP_FRAC) <= REV); zero -+ REV for stage 6
                step_x := resize(s4_step, WW);
                c_mid  := s4_pos - step_x;
                c_up   := s4_pos_up - step_x;
                c_down := s4_pos_dn - step_x;
                c_wrap := wrapped(c_mid, c_up, c_down);
                s5_pos_c <= unsigned(c_wrap(POS_W - 1 downto 0));
                zero_x := resize(s4_zero, WW);
                s5_zero <= zero_x;
                if s4_dir = '1' then
                    s5_zero_alt <= zero_x + REV_W;
                else
                    s5_zero_alt <= zero_x - REV_W;
                end if;
                s5_dir <= s4_dir;

                -- 6: zero and direction, wrap
                -- dir = 0: a = pos_c + zero in [0, 2 REV - 2], b = a - REV; take b when b >= 0.
                -- dir = 1: a = zero - pos_c in (-REV, REV),    b = a + REV; take b when a < 0.
                pc_x := resize(s5_pos_c, WW);
                if s5_dir = '1' then
                    a := s5_zero - pc_x;
                    b := s5_zero_alt - pc_x;
                    use_b := a(WW - 1) = '1';
                else
                    a := s5_zero + pc_x;
                    b := s5_zero_alt + pc_x;
                    use_b := b(WW - 1) = '0';
                end if;
                if use_b then
                    pos_out <= std_logic_vector(b(POS_W - 1 downto 0));
                else
                    pos_out <= std_logic_vector(a(POS_W - 1 downto 0));
                end if;
            end if;
        end if;
    end process p_data;

end architecture rtl;
