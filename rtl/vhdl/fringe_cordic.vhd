-- fringe_cordic: phase (arctan) and magnitude of the corrected vector, vectoring CORDIC.
--
-- VHDL-2008 twin of rtl/verilog/fringe_cordic.v (same generics, ports and behaviour).
-- LATENCY = STAGES + 2 clock enables. ITERATIVE = 0: fully pipelined, one sample per clock, ready = 1.
-- ITERATIVE = 1: one x/y/z register and one micro-rotation stage iterated STAGES times (the same
-- micro-rotations in the same order, so the same words and the same LATENCY), one sample per
-- STAGES + CORDIC_ITER_CLOCKS_BASE (= 0) clock enables; ready = 0 while a sample is in the register, and an
-- in_valid while ready = 0 is ignored. ce = 0 freezes every register, rst (synchronous, active high)
-- clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_cordic.md.
-- Bit-exact model: model/fringe/fixed/cordic.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_cordic is
    generic (
        IN_W   : integer := 18;  -- width of the x and y inputs, s(IN_W), 8..30
        FINE_W : integer := 16;  -- output phase bits per period, 8..30
        STAGES : integer := 18;  -- CORDIC micro-rotations, 4..32 (>= FINE_W+1 for full precision)
        GUARD  : integer := 3;   -- extra fractional bits of x, y and the angle accumulator, 0..8
        USER_W : integer := 1;   -- sideband width, >= 1
        ITERATIVE : integer := 0 -- 1 = one micro-rotation stage iterated (one sample per STAGES clocks)
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;                              -- synchronous: clears valid only
        ce        : in  std_logic;                              -- clock enable
        -- vector in
        in_valid  : in  std_logic;
        x         : in  std_logic_vector(IN_W - 1 downto 0);    -- s(IN_W), cosine
        y         : in  std_logic_vector(IN_W - 1 downto 0);    -- s(IN_W), sine
        in_user   : in  std_logic_vector(USER_W - 1 downto 0);
        ready     : out std_logic;                              -- 1: in_valid now is taken (1 when ITERATIVE = 0)
        -- phase and magnitude out
        out_valid : out std_logic;
        phase     : out std_logic_vector(FINE_W - 1 downto 0);  -- u(FINE_W), fraction of a period
        mag       : out std_logic_vector(IN_W downto 0);        -- u(IN_W+1), magnitude * CORDIC gain
        out_user  : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_cordic;

architecture rtl of fringe_cordic is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_range("fringe_cordic", "IN_W", IN_W, 8, 30);
        check_range("fringe_cordic", "FINE_W", FINE_W, 8, 30);
        check_range("fringe_cordic", "STAGES", STAGES, 4, 32);
        check_range("fringe_cordic", "GUARD", GUARD, 0, 8);
        check_min("fringe_cordic", "USER_W", USER_W, 1);
        check_range("fringe_cordic", "ITERATIVE", ITERATIVE, 0, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := STAGES + CORDIC_LATENCY_BASE;
    constant ACC_W   : integer := FINE_W + GUARD;     -- angle accumulator, one turn = 2^ACC_W
    constant DP_W    : integer := IN_W + 2 + GUARD;   -- x/y datapath

    -- atan(2^-i) / (2 pi) as a 62-bit fraction of a turn, round half up (i = 0..31). The same
    -- table is ATAN62 in model/fringe/fixed/cordic.py and atan62 in rtl/verilog/fringe_cordic.v.
    type atan62_t is array (0 to 31) of unsigned(63 downto 0);
    constant ATAN62 : atan62_t := (
        x"0800000000000000",  --  0: atan(2^-0) = 45.0000000000 deg
        x"04B90147677CC21A",  --  1: atan(2^-1) = 26.5650511771 deg
        x"027ECE16D7B8E7A3",  --  2: atan(2^-2) = 14.0362434679 deg
        x"0144447507776687",  --  3: atan(2^-3) = 7.1250163489 deg
        x"00A2C350C39626BB",  --  4: atan(2^-4) = 3.5763343750 deg
        x"005175F85641189E",  --  5: atan(2^-5) = 1.7899106082 deg
        x"0028BD87970A098A",  --  6: atan(2^-6) = 0.8951737102 deg
        x"00145F15447510AC",  --  7: atan(2^-7) = 0.4476141709 deg
        x"000A2F94D1B430CE",  --  8: atan(2^-8) = 0.2238105004 deg
        x"000517CBAECC2ACE",  --  9: atan(2^-9) = 0.1119056771 deg
        x"00028BE600246E9F",  -- 10: atan(2^-10) = 0.0559528919 deg
        x"000145F3052A032E",  -- 11: atan(2^-11) = 0.0279764526 deg
        x"0000A2F98337FB18",  -- 12: atan(2^-12) = 0.0139882271 deg
        x"0000517CC1B05CBD",  -- 13: atan(2^-13) = 0.0069941137 deg
        x"000028BE60DABA44",  -- 14: atan(2^-14) = 0.0034970569 deg
        x"0000145F306DAE9F",  -- 15: atan(2^-15) = 0.0017485284 deg
        x"00000A2F9836E17F",  -- 16: atan(2^-16) = 0.0008742642 deg
        x"00000517CC1B7205",  -- 17: atan(2^-17) = 0.0004371321 deg
        x"0000028BE60DB92B",  -- 18: atan(2^-18) = 0.0002185661 deg
        x"00000145F306DC9B",  -- 19: atan(2^-19) = 0.0001092830 deg
        x"000000A2F9836E4E",  -- 20: atan(2^-20) = 0.0000546415 deg
        x"000000517CC1B727",  -- 21: atan(2^-21) = 0.0000273208 deg
        x"00000028BE60DB94",  -- 22: atan(2^-22) = 0.0000136604 deg
        x"000000145F306DCA",  -- 23: atan(2^-23) = 0.0000068302 deg
        x"0000000A2F9836E5",  -- 24: atan(2^-24) = 0.0000034151 deg
        x"0000000517CC1B72",  -- 25: atan(2^-25) = 0.0000017075 deg
        x"000000028BE60DB9",  -- 26: atan(2^-26) = 0.0000008538 deg
        x"0000000145F306DD",  -- 27: atan(2^-27) = 0.0000004269 deg
        x"00000000A2F9836E",  -- 28: atan(2^-28) = 0.0000002134 deg
        x"00000000517CC1B7",  -- 29: atan(2^-29) = 0.0000001067 deg
        x"0000000028BE60DC",  -- 30: atan(2^-30) = 0.0000000534 deg
        x"00000000145F306E"   -- 31: atan(2^-31) = 0.0000000267 deg
    );

    type acc_arr_t is array (natural range <>) of unsigned(ACC_W - 1 downto 0);
    type dp_arr_t  is array (natural range <>) of signed(DP_W - 1 downto 0);

    -- ATAN(i) = (ATAN62(i) + 2^(61-ACC_W)) >> (62-ACC_W), i < STAGES (< 2^(ACC_W-3)).
    function atan_table return acc_arr_t is
        variable t    : acc_arr_t(0 to STAGES - 1);
        variable full : unsigned(63 downto 0);
    begin
        for i in 0 to STAGES - 1 loop
            full := shift_right(ATAN62(i) + shift_left(to_unsigned(1, 64), 61 - ACC_W), 62 - ACC_W);
            t(i) := full(ACC_W - 1 downto 0);
        end loop;
        return t;
    end function atan_table;
    constant ATAN : acc_arr_t(0 to STAGES - 1) := atan_table;

    -- the pre-rotated input (x into the right half plane, scaled by 2^GUARD) and its angle
    signal x_pre, y_pre : signed(DP_W - 1 downto 0);
    signal z_pre        : unsigned(ACC_W - 1 downto 0);
    -- the vector and angle after the last micro-rotation
    signal x_last       : signed(DP_W - 1 downto 0);
    signal z_last       : unsigned(ACC_W - 1 downto 0);

begin

    p_pre : process (x, y)
        variable x_ext, y_ext : signed(DP_W - 1 downto 0);
    begin
        x_ext := resize(signed(x), DP_W);
        y_ext := resize(signed(y), DP_W);
        if x(IN_W - 1) = '1' then
            x_pre <= shift_left(-x_ext, GUARD);
            y_pre <= shift_left(-y_ext, GUARD);
            z_pre <= shift_left(to_unsigned(1, ACC_W), ACC_W - 1);  -- half a turn
        else
            x_pre <= shift_left(x_ext, GUARD);
            y_pre <= shift_left(y_ext, GUARD);
            z_pre <= (others => '0');
        end if;
    end process p_pre;

    g_pipelined : if ITERATIVE = 0 generate
        -- Index k: the values after k micro-rotations (k = 0: pre-rotated). y after the last
        -- micro-rotation is not needed.
        signal x_p : dp_arr_t(0 to STAGES);
        signal y_p : dp_arr_t(0 to STAGES - 1);
        signal z_p : acc_arr_t(0 to STAGES);
    begin
        p_stages : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    -- stage 1: pre-rotation register
                    x_p(0) <= x_pre;
                    y_p(0) <= y_pre;
                    z_p(0) <= z_pre;

                    -- stages 2..STAGES+1: micro-rotations
                    for k in 0 to STAGES - 1 loop
                        if y_p(k)(DP_W - 1) = '0' then
                            x_p(k + 1) <= x_p(k) + shift_right(y_p(k), k);
                            z_p(k + 1) <= z_p(k) + ATAN(k);
                            if k < STAGES - 1 then
                                y_p(k + 1) <= y_p(k) - shift_right(x_p(k), k);
                            end if;
                        else
                            x_p(k + 1) <= x_p(k) - shift_right(y_p(k), k);
                            z_p(k + 1) <= z_p(k) - ATAN(k);
                            if k < STAGES - 1 then
                                y_p(k + 1) <= y_p(k) + shift_right(x_p(k), k);
                            end if;
                        end if;
                    end loop;
                end if;
            end if;
        end process p_stages;

        x_last <= x_p(STAGES);
        z_last <= z_p(STAGES);
        ready  <= '1';

        -- valid (the only reset registers) and sideband, LATENCY stages
        u_valid : entity work.fringe_delay
            generic map (WIDTH => USER_W, DEPTH => LATENCY)
            port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
                      out_valid => out_valid, out_data => out_user);
    end generate g_pipelined;

    g_iterative : if ITERATIVE = 1 generate
        -- One register holds the sample: step = k while micro-rotation k is applied (k = 0 after
        -- the clock enable that takes the sample, which loads it pre-rotated). The last one's
        -- result goes to a register of its own (the output register's input, as the last
        -- pipeline stage), so the same clock enable loads the next sample: one micro-rotation
        -- every clock enable, a sample every STAGES. Same LATENCY as the pipeline.
        signal busy, valid_done, valid_o : std_logic;
        signal step                      : integer range 0 to STAGES - 1;
        signal xr, yr, x_done            : signed(DP_W - 1 downto 0);
        signal zr, z_done                : unsigned(ACC_W - 1 downto 0);
        signal atan_k                    : unsigned(ACC_W - 1 downto 0);  -- ATAN(step), registered with it
        signal user_r, user_done, user_o : std_logic_vector(USER_W - 1 downto 0);
        signal x_next, y_next            : signed(DP_W - 1 downto 0);
        signal z_next                    : unsigned(ACC_W - 1 downto 0);
        signal last, take                : std_logic;
    begin
        last  <= '1' when busy = '1' and step = STAGES - 1 else '0';
        take  <= in_valid and (not busy or last);
        ready <= not busy or last;

        -- the micro-rotation as in the pipeline (the Verilog selects the shifts in fixed LUT levels for
        -- the iCE40's loop; described here as the shifts themselves, the same values)
        x_next <= xr + shift_right(yr, step) when yr(DP_W - 1) = '0' else xr - shift_right(yr, step);
        y_next <= yr - shift_right(xr, step) when yr(DP_W - 1) = '0' else yr + shift_right(xr, step);
        z_next <= zr + atan_k when yr(DP_W - 1) = '0' else zr - atan_k;

        p_iter : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    busy       <= take or (busy and not last);
                    valid_done <= last;
                    valid_o    <= valid_done;
                    if take = '1' then
                        xr     <= x_pre;
                        yr     <= y_pre;
                        zr     <= z_pre;
                        step   <= 0;
                        atan_k <= ATAN(0);
                        user_r <= in_user;
                    elsif busy = '1' then
                        xr   <= x_next;
                        yr   <= y_next;
                        zr   <= z_next;
                        if last = '0' then
                            step   <= step + 1;
                            atan_k <= ATAN(step + 1);
                        end if;
                    end if;
                    x_done    <= x_next;    -- read only after the last micro-rotation
                    z_done    <= z_next;
                    user_done <= user_r;
                    user_o    <= user_done; -- with the output registers
                end if;
                if rst = '1' then       -- the control only, after the step: rst wins over ce
                    busy       <= '0';
                    valid_done <= '0';
                    valid_o    <= '0';
                end if;
            end if;
        end process p_iter;

        x_last    <= x_done;
        z_last    <= z_done;
        out_valid <= valid_o;
        out_user  <= user_o;
    end generate g_iterative;

    -- ---- stage STAGES+2: output rounding (x >= 0 here, below 1.17 * 2^(IN_W+GUARD)) -----------
    p_out : process (clk)
        variable x_rnd : signed(DP_W - 1 downto 0);
        variable z_rnd : unsigned(ACC_W - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                x_rnd := x_last + round_half(DP_W, GUARD);
                z_rnd := z_last + unsigned(round_half(ACC_W, GUARD));
                phase <= std_logic_vector(z_rnd(ACC_W - 1 downto GUARD));
                mag   <= std_logic_vector(x_rnd(IN_W + GUARD downto GUARD));
            end if;
        end if;
    end process p_out;

end architecture rtl;
