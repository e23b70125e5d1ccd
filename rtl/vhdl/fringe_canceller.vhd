-- fringe_canceller: adaptive canceller of an additive tone on the corrected channels (c, s), between
-- the quadrature stage and the CORDIC; the tone is estimated from the radius of the Lissajous figure.
--
-- VHDL-2008 twin of rtl/verilog/fringe_canceller.v (same generics, ports and behaviour).
-- LATENCY = 4 clock enables (in_valid to out_valid), one sample per clock; ADAPT_LATENCY = 15 (a
-- block's last sample to its update in place); ce = 0 freezes every register, rst (synchronous,
-- active high) clears the valid pipeline, the NCO, the counters, the sums and the coefficients,
-- never the data registers. Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_canceller.md.
-- Bit-exact model: model/fringe/fixed/canceller.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_canceller is
    generic (
        WAVE_W     : integer := 18;   -- width of c, s (radius 2^(WAVE_W-2)), 8..31
        LUT_W      : integer := 10;   -- 2^LUT_W sine table entries per turn, 4..12
        C_W        : integer := 16;   -- sine table value width, 8..18
        BLOCK_LOG2 : integer := 4;    -- B = 2^BLOCK_LOG2 samples per update, 4..12
        MU_LOG2    : integer := 6;    -- final update step 2^-MU_LOG2 per block, 1..12
        A_FRAC     : integer := 4;    -- fraction bits of the coefficients, 0..12
        A_W        : integer := 20;   -- coefficient width, 8..min(32, WAVE_W + A_FRAC)
        GEAR_OFFSET : integer := 0;   -- the gear shift starts this many gears lower, 0..MU_LOG2-1
        LUT_INIT   : string  := "";   -- hex image of the sine table, 2^LUT_W words of C_W bits ("" = zeros: no cancellation)
        USER_W     : integer := 1     -- sideband width, >= 1
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;                                -- synchronous, active high
        ce        : in  std_logic;                                -- clock enable
        in_valid  : in  std_logic;
        c         : in  std_logic_vector(WAVE_W - 1 downto 0);    -- s(WAVE_W)
        s         : in  std_logic_vector(WAVE_W - 1 downto 0);
        freq      : in  std_logic_vector(31 downto 0);            -- NCO word of this sample's bank (CANCEL_FREQ), u(32)
        in_user   : in  std_logic_vector(USER_W - 1 downto 0);
        out_valid : out std_logic;
        c_out     : out std_logic_vector(WAVE_W - 1 downto 0);    -- c - n_c, saturated to s(WAVE_W)
        s_out     : out std_logic_vector(WAVE_W - 1 downto 0);
        sat       : out std_logic;                                -- this sample's subtraction saturated
        track_sat : out std_logic;                                -- its coefficients came from a saturated update (held)
        out_user  : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_canceller;

architecture rtl of fringe_canceller is

    constant LATENCY       : integer := CANCEL_LATENCY;
    constant ADAPT_LATENCY : integer := CANCEL_ADAPT_LATENCY;

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
        constant A_W_MAX : integer := minimum(32, WAVE_W + A_FRAC);
        constant SH0     : integer := BLOCK_LOG2 + C_W - 2 - A_FRAC;
    begin
        check_range("fringe_canceller", "WAVE_W", WAVE_W, 8, 31);
        check_range("fringe_canceller", "LUT_W", LUT_W, 4, 12);
        check_range("fringe_canceller", "C_W", C_W, 8, 18);
        check_range("fringe_canceller", "BLOCK_LOG2", BLOCK_LOG2, 4, 12);
        check_range("fringe_canceller", "MU_LOG2", MU_LOG2, 1, 12);
        check_range("fringe_canceller", "A_FRAC", A_FRAC, 0, 12);
        check_range("fringe_canceller", "GEAR_OFFSET", GEAR_OFFSET, 0, MU_LOG2 - 1,
                    "MU_LOG2-1 = " & integer'image(MU_LOG2 - 1));
        check_range("fringe_canceller", "A_W", A_W, 8, A_W_MAX,
                    "min(32, WAVE_W + A_FRAC) = " & integer'image(A_W_MAX));
        assert SH0 >= 0
            report "fringe_canceller: BLOCK_LOG2 + C_W - 2 - A_FRAC = " & integer'image(SH0) & " must be >= 0"
            severity failure;
        check_min("fringe_canceller", "USER_W", USER_W, 1);
        -- the update of block j must be in place before block j + 2 begins (and before block j + 1
        -- ends: one update in flight at a time); B >= 16 holds it
        assert ADAPT_LATENCY <= 2 ** BLOCK_LOG2
            report "fringe_canceller: ADAPT_LATENCY = " & integer'image(ADAPT_LATENCY) & " exceeds B = "
                   & integer'image(2 ** BLOCK_LOG2)
            severity failure;
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    -- ---- widths -------------------------------------------------------------------------------------
    constant W    : integer := WAVE_W;
    constant SH0  : integer := BLOCK_LOG2 + C_W - 2 - A_FRAC;
    constant NSH  : integer := C_W - 1 + A_FRAC;                    -- shift of the estimate
    constant PW   : integer := A_W + C_W;                           -- A * cw
    constant DW   : integer := W + 3;                               -- c - n_c (|n_c| <= 2^W)
    constant EW   : integer := maximum(PW + 2, NSH + DW) + 1;       -- c 2^NSH + 2^(NSH-1) - 1 - A cw - B sw
    constant SQ_W : integer := 2 * W;                               -- c_out^2, e * c_out
    constant T_W  : integer := 2 * W + 1;                           -- c_out^2 + s_out^2 - 2^(2W-4)
    constant U_W  : integer := W + 1;                               -- u = (e * c_out) >>> (W - 2)
    constant UC_W : integer := U_W + C_W;                           -- u * cw
    constant S_W  : integer := UC_W + BLOCK_LOG2;                   -- block sums
    constant R_W  : integer := A_W + 2;                             -- the step, clipped (saturates either way)
    constant XR_W : integer := maximum(S_W, R_W) + 1;
    constant N_W  : integer := A_W + 3;                             -- X + step
    constant N_LUT : integer := 2 ** LUT_W;
    constant CAP  : integer := 2 ** (MU_LOG2 - GEAR_OFFSET - 1);    -- gear counter top (gears from the first to MU_LOG2)
    constant CNT_LAST : unsigned(BLOCK_LOG2 - 1 downto 0) := (others => '1');
    constant K_LOW : signed(NSH - 1 downto 0) := '0' & (NSH - 2 downto 0 => '1');   -- 2^(NSH-1) - 1
    constant R2K  : signed(T_W - 1 downto 0) := shift_left(to_signed(1, T_W), 2 * W - 4);   -- R 2^(W-2)

    subtype rom_t is word_array(0 to N_LUT - 1)(C_W - 1 downto 0);
    signal rom : rom_t := read_memh(LUT_INIT, N_LUT, C_W, "fringe_canceller: LUT_INIT");

    type coef_t is array (0 to 3) of signed(A_W - 1 downto 0);
    type prod_t is array (0 to 3) of signed(PW - 1 downto 0);
    type term_t is array (0 to 3) of std_logic_vector(UC_W - 1 downto 0);

    -- input side
    signal acc_in    : std_logic;
    signal nco       : unsigned(31 downto 0);
    signal cnt       : unsigned(BLOCK_LOG2 - 1 downto 0);
    signal inflight  : std_logic;
    signal blk_first : std_logic;
    signal upd_wr    : std_logic;
    signal act_sat, lat_sat, prv_sat : std_logic;
    signal upd_sat   : std_logic;
    signal in_last   : std_logic;

    -- output path
    signal sw1, cw1, sw2, cw2 : signed(C_W - 1 downto 0);
    signal c3, s3    : signed(W - 1 downto 0);
    signal x3        : std_logic_vector(2 * W downto 0);          -- {act_sat, s, c} 3 clock enables on
    signal prod3     : prod_t;
    signal c4, s4    : signed(W - 1 downto 0);
    signal lut2      : std_logic_vector(2 * C_W - 1 downto 0);      -- {sw, cw} at stage 2

    -- adaptation
    signal a12_valid, a12_last, unused_v1, unused_v2, unused_v3 : std_logic;
    signal lut10     : std_logic_vector(2 * C_W - 1 downto 0);
    signal y4, y8    : std_logic_vector(2 * W - 1 downto 0);        -- {s_out, c_out}
    signal sq_c, sq_s, pe_c, pe_s : std_logic_vector(SQ_W - 1 downto 0);
    signal t7        : signed(T_W - 1 downto 0);
    signal e8        : signed(W - 1 downto 0);
    signal u10       : std_logic_vector(2 * U_W - 1 downto 0);      -- {u_s, u_c}
    signal term12    : term_t;
    signal a13_go, a14_go : std_logic;
    signal kp1       : integer range 1 to CAP;                      -- j + 1 of the block being updated
    signal gear      : integer range 1 to 12;                       -- G_j = min(MU_LOG2, GEAR_OFFSET + bit_length(j + 1))
    signal sat_k     : std_logic_vector(3 downto 0);

    function is_pow2(v : integer) return boolean is
    begin
        return v > 0 and 2 ** clog2(v) = v;
    end function is_pow2;

begin

    -- ---- input side: NCO, sample counter, the coefficients of the current block -------------------------
    acc_in    <= ce and in_valid and not rst;
    -- (no numeric_std comparison on the undefined counter before the first reset)
    blk_first <= '1' when acc_in = '1' and cnt = 0 else '0';
    in_last   <= '1' when not is_x(cnt) and cnt = CNT_LAST else '0';
    upd_wr    <= ce and a14_go and not rst;
    upd_sat   <= sat_k(0) or sat_k(1) or sat_k(2) or sat_k(3);

    p_in : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                nco      <= (others => '0');
                cnt      <= (others => '0');
                inflight <= '0';
                act_sat  <= '0';
                lat_sat  <= '0';
                prv_sat  <= '0';
            else
                if acc_in = '1' then
                    nco <= nco + unsigned(freq);
                    cnt <= cnt + 1;
                end if;
                if acc_in = '1' and in_last = '1' then
                    inflight <= '1';
                elsif upd_wr = '1' then
                    inflight <= '0';
                end if;
                -- track_sat beside the coefficients: latest (lat), the one before (prv), the input block's (act)
                if blk_first = '1' then
                    act_sat <= lat_sat when inflight = '1' else prv_sat;
                end if;
                if upd_wr = '1' then
                    prv_sat <= lat_sat;
                    lat_sat <= lat_sat or upd_sat;
                end if;
            end if;
        end if;
    end process p_in;

    -- ---- stages 1..4: table reads, their registers, the products, c - n saturated ---------------------
    lut2 <= std_logic_vector(sw2) & std_logic_vector(cw2);

    p_out : process (clk)
        variable idx_s, idx_c : unsigned(LUT_W - 1 downto 0);
        variable sum_c, sum_s : signed(EW - 1 downto 0);
        variable dc, ds       : signed(DW - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- 1: table reads at the sample's phase (the block RAM's register), input registers
                idx_s := nco(31 downto 32 - LUT_W);
                idx_c := idx_s + to_unsigned(2 ** (LUT_W - 2), LUT_W);
                sw1 <= signed(rom(to_integer(idx_s)));
                cw1 <= signed(rom(to_integer(idx_c)));
                -- 2: the table words registered (no logic after the RAM), the block's coefficients (g_coef)
                sw2 <= sw1;
                cw2 <= cw1;
                -- 3: the products (g_coef); c, s and track_sat wait in u_x_carry
                -- 4: c - n = c - ((A cw + B sw + 2^(NSH-1)) >>> NSH) = (c 2^NSH + 2^(NSH-1) - 1 - A cw - B sw) >>> NSH
                -- (one sum: the rounding and the subtraction in one carry chain), saturated to s(W)
                sum_c := resize(c3 & K_LOW, EW) - resize(prod3(0), EW) - resize(prod3(1), EW);
                sum_s := resize(s3 & K_LOW, EW) - resize(prod3(2), EW) - resize(prod3(3), EW);
                dc := sum_c(NSH + DW - 1 downto NSH);     -- |c - n_c| < 2^(W+1): the bits above are sign copies
                ds := sum_s(NSH + DW - 1 downto NSH);
                c4 <= saturate(dc, W);
                s4 <= saturate(ds, W);
                if outside(dc, W) or outside(ds, W) then
                    sat <= '1';
                else
                    sat <= '0';
                end if;
            end if;
        end if;
    end process p_out;

    -- stages 1..3: the sample, and (from stage 2) its block's track_sat, wait for the products
    u_x_carry : entity work.fringe_delay
        generic map (WIDTH => 2 * W + 1, DEPTH => 3)
        port map (clk => clk, rst => rst, ce => ce, in_valid => '0', in_data => act_sat & s & c,
                  out_valid => unused_v3, out_data => x3);
    c3        <= signed(x3(W - 1 downto 0));
    s3        <= signed(x3(2 * W - 1 downto W));
    track_sat <= x3(2 * W);     -- stage 4: act_sat was taken a stage after the sample

    c_out <= std_logic_vector(c4);
    s_out <= std_logic_vector(s4);

    u_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => LATENCY)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
                  out_valid => out_valid, out_data => out_user);

    -- ---- adaptation (stages 5..13): e, u and the terms of the block sums --------------------------------
    -- 5..6 c_out^2, s_out^2   7 t = c^2 + s^2 - 2^(2W-4)   8 e = clip(t >>> (W-2))   9..10 e c_out, e s_out
    -- 11..12 u * cw, u * sw   13 the sums (the block's last sample: snapshot, sums cleared)
    u_adapt_valid : entity work.fringe_delay
        generic map (WIDTH => 1, DEPTH => 12)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data(0) => in_last,
                  out_valid => a12_valid, out_data(0) => a12_last);

    u_lut_carry : entity work.fringe_delay
        generic map (WIDTH => 2 * C_W, DEPTH => 8)
        port map (clk => clk, rst => rst, ce => ce, in_valid => '0', in_data => lut2,
                  out_valid => unused_v1, out_data => lut10);

    y4 <= std_logic_vector(s4) & std_logic_vector(c4);

    u_y_carry : entity work.fringe_delay
        generic map (WIDTH => 2 * W, DEPTH => 4)
        port map (clk => clk, rst => rst, ce => ce, in_valid => '0', in_data => y4,
                  out_valid => unused_v2, out_data => y8);

    u_sq_c : entity work.fringe_split_mul
        generic map (A_W => W, A_SIGNED => 1, B_W => W, B_SIGNED => 1, LATENCY => 2)
        port map (clk => clk, ce => ce, a => std_logic_vector(c4), b => std_logic_vector(c4), p => sq_c);
    u_sq_s : entity work.fringe_split_mul
        generic map (A_W => W, A_SIGNED => 1, B_W => W, B_SIGNED => 1, LATENCY => 2)
        port map (clk => clk, ce => ce, a => std_logic_vector(s4), b => std_logic_vector(s4), p => sq_s);

    p_e : process (clk)
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- 7: (c^2 + s^2) >> (W-2) - R = (c^2 + s^2 - R 2^(W-2)) >>> (W-2)
                t7 <= signed('0' & sq_c) + signed('0' & sq_s) - R2K;
                -- 8: e clipped to s(W)
                e8 <= saturate(t7(T_W - 1 downto W - 2), W);
            end if;
        end if;
    end process p_e;

    u_ec : entity work.fringe_split_mul
        generic map (A_W => W, A_SIGNED => 1, B_W => W, B_SIGNED => 1, LATENCY => 2)
        port map (clk => clk, ce => ce, a => std_logic_vector(e8), b => y8(W - 1 downto 0), p => pe_c);
    u_es : entity work.fringe_split_mul
        generic map (A_W => W, A_SIGNED => 1, B_W => W, B_SIGNED => 1, LATENCY => 2)
        port map (clk => clk, ce => ce, a => std_logic_vector(e8), b => y8(2 * W - 1 downto W), p => pe_s);

    -- fits s(W+1): |e c_out| < 2^(2W-2)
    u10 <= pe_s(2 * W - 2 downto W - 2) & pe_c(2 * W - 2 downto W - 2);

    -- ---- stage 13: sums; 14: step = round(S >>> SH) clipped; 15: X + step saturated, in place ----------
    p_gear : process (clk)
    begin
        if rising_edge(clk) then
            if rst = '1' then
                a13_go <= '0';
                a14_go <= '0';
                kp1    <= 1;
                gear   <= GEAR_OFFSET + 1;
            elsif ce = '1' then
                a13_go <= a12_valid and a12_last;
                a14_go <= a13_go;
                if a14_go = '1' and kp1 /= CAP then
                    kp1 <= kp1 + 1;
                    if is_pow2(kp1 + 1) then                   -- j + 2 a power of two
                        gear <= gear + 1;
                    end if;
                end if;
            end if;
        end if;
    end process p_gear;

    -- coefficient k: A_C, B_C, A_S, B_S = channel k / 2 (c, s) times table word k mod 2 (cw, sw)
    g_coef : for k in 0 to 3 generate
        signal act_r, lat_r, prv_r : signed(A_W - 1 downto 0);     -- this block's, the latest, the one before
        signal a2                  : signed(A_W - 1 downto 0);     -- the sample's (stage 2)
        signal acc, snap           : signed(S_W - 1 downto 0);
        signal stp14               : signed(R_W - 1 downto 0);
        signal rb14                : std_logic;
        signal nx                  : signed(N_W - 1 downto 0);
        signal lut2k, lut10k       : signed(C_W - 1 downto 0);
    begin
        lut2k  <= signed(lut2((k mod 2 + 1) * C_W - 1 downto (k mod 2) * C_W));
        lut10k <= signed(lut10((k mod 2 + 1) * C_W - 1 downto (k mod 2) * C_W));

        u_term : entity work.fringe_split_mul
            generic map (A_W => U_W, A_SIGNED => 1, B_W => C_W, B_SIGNED => 1, LATENCY => 2)
            port map (clk => clk, ce => ce, a => u10((k / 2 + 1) * U_W - 1 downto (k / 2) * U_W),
                      b => std_logic_vector(lut10k), p => term12(k));

        nx       <= resize(lat_r, N_W) + resize(stp14, N_W) + resize(signed'('0' & rb14), N_W);
        sat_k(k) <= '1' when not is_x(nx) and outside(nx, A_W) else '0';

        -- the block sum, the step, and the coefficient in its three places
        p_coef : process (clk)
            variable acc_n : signed(S_W - 1 downto 0);
            variable v14   : signed(S_W - 1 downto 0);
            variable r14   : signed(XR_W - 1 downto 0);
        begin
            if rising_edge(clk) then
                acc_n := acc + resize(signed(term12(k)), S_W);
                -- (S + 2^(SH-1)) >>> SH = (S >>> SH) + S[SH-1]
                v14 := shift_right(snap, SH0 + gear - 1);
                r14 := shift_right(resize(v14, XR_W), 1);
                if ce = '1' then
                    a2       <= act_r;                                             -- 2
                    prod3(k) <= a2 * lut2k;                                        -- 3
                    -- 14: the step clipped to s(A_W+2): beyond it X + step saturates either way
                    stp14 <= saturate(r14, R_W);
                    rb14  <= v14(0);
                    if a12_valid = '1' and a12_last = '1' then                    -- 13
                        snap <= acc_n;
                    end if;
                end if;
                -- cleared by a reset and by the block's last sample (after its snapshot)
                if rst = '1' or (ce = '1' and a12_valid = '1' and a12_last = '1') then
                    acc <= (others => '0');
                elsif ce = '1' and a12_valid = '1' then
                    acc <= acc_n;
                end if;
                -- block b begins: coefs[b] is the latest unless the update of block b - 1 is in place
                if blk_first = '1' then
                    act_r <= lat_r when inflight = '1' else prv_r;
                end if;
                if upd_wr = '1' then                                               -- 15
                    prv_r <= lat_r;
                    lat_r <= saturate(nx, A_W);
                end if;
                if rst = '1' then           -- after the update: rst wins
                    act_r <= (others => '0');
                    lat_r <= (others => '0');
                    prv_r <= (others => '0');
                end if;
            end if;
        end process p_coef;
    end generate g_coef;

end architecture rtl;
