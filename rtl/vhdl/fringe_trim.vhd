-- fringe_trim: closed-loop angle trim: an error map over (direction, sector of the revolution,
-- fine phase) and two fine-phase-dependent gains (speed, magnitude) give a correction
-- subtracted from the position.
--
-- VHDL-2008 twin of rtl/verilog/fringe_trim.v (same generics, ports and behaviour).
-- LATENCY = 13 clock enables, one sample per clock; ce = 0 freezes
-- every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_trim.md.
-- Bit-exact model: model/fringe/fixed/trim.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_trim is
    generic (
        LINES      : integer := 256;  -- signal periods per revolution, 1..2^20; POS_W = FINE_W + clog2(LINES) <= 31
        FINE_W     : integer := 16;   -- fine phase bits per period, 8..30
        AMP_W      : integer := 12;   -- magnitude width, 4..32
        SPEED_LOG2 : integer := 5;    -- speed window 2^SPEED_LOG2 samples, 0..8
        MAP_PSI_W  : integer := 4;    -- 2^MAP_PSI_W map sectors per revolution, 0..8
        MAP_PHI_W  : integer := 6;    -- 2^MAP_PHI_W bins per signal period, 2..min(10, FINE_W-1)
        TRIM_W     : integer := 18;   -- width of table values and slopes, 8..24
        TRIM_FRAC  : integer := 4;    -- fraction bits of map values and of the sum (fine counts), 0..16
        G_SHIFT    : integer := 20;   -- right shift of the gain products into the sum, 1..48
        SECT_RECIP : natural := 1;    -- sector multiplier, from sector_mapping() (checked; < 2^31 in VHDL; unused if MAP_PSI_W = 0)
        SECT_SHIFT : integer := 20;   -- sector shift, 0..127, from sector_mapping() (checked; unused if MAP_PSI_W = 0)
        START_SPEED : integer := 0;   -- the first sample's speed after reset (no window yet), -REV/2..REV/2-1
        MAG_SMOOTH_LOG2 : integer := 0;   -- the magnitude terms take mag's running average over ~2^K samples, 0 (off)..12
        MAP_INIT   : string  := "";   -- hex image of the map, 2 banks x 2^(1+MAP_PSI_W+MAP_PHI_W) words; "" = zeros
        SPEED_INIT : string  := "";   -- hex image of the speed table, 2 banks x 2^MAP_PHI_W words; "" = zeros
        AMP_INIT   : string  := "";   -- hex image of the amp table, 2 banks x 2^MAP_PHI_W words; "" = zeros
        USER_W     : integer := 1     -- sideband width, >= 1
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;                              -- synchronous: clears valid and the fill counter
        ce        : in  std_logic;                              -- clock enable
        -- sample in
        in_valid  : in  std_logic;
        pos       : in  std_logic_vector(FINE_W + clog2(LINES) - 1 downto 0);
                                                                -- u(POS_W), in [0, REV)
        mag       : in  std_logic_vector(AMP_W - 1 downto 0);   -- u(AMP_W)
        bank      : in  std_logic;                              -- table bank of this sample
        in_user   : in  std_logic_vector(USER_W - 1 downto 0);
        -- table write port (software side), independent of ce
        wr_en     : in  std_logic;
        wr_sel    : in  std_logic_vector(1 downto 0);           -- 0 map, 1 speed table, 2 amp table, 3 ignored
        wr_addr   : in  std_logic_vector(MAP_PSI_W + MAP_PHI_W + 1 downto 0);  -- {bank, dir, sector, bin}
        wr_data   : in  std_logic_vector(2 * TRIM_W - 1 downto 0);            -- {slope, value}
        -- position out
        out_valid : out std_logic;
        pos_out   : out std_logic_vector(FINE_W + clog2(LINES) - 1 downto 0);
                                                                -- u(POS_W), in [0, REV)
        dir       : out std_logic;                              -- 1: moving backwards (speed < 0)
        sat       : out std_logic;                              -- the trim was clipped
        out_user  : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_trim;

architecture rtl of fringe_trim is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
        constant PHI_MAX : integer := minimum(10, FINE_W - 1);
        variable half    : integer;   -- REV/2, once the position widths are known to be legal
    begin
        check_position("fringe_trim", FINE_W, LINES, 31);
        half := LINES * 2**(FINE_W - 1);
        check_range("fringe_trim", "AMP_W", AMP_W, 4, 32);
        check_range("fringe_trim", "SPEED_LOG2", SPEED_LOG2, 0, 8);
        check_range("fringe_trim", "MAP_PSI_W", MAP_PSI_W, 0, 8);
        assert MAP_PHI_W >= 2 and MAP_PHI_W <= PHI_MAX
            report "fringe_trim: MAP_PHI_W = " & integer'image(MAP_PHI_W) & " out of range 2..min(10, FINE_W-1) = "
                   & integer'image(PHI_MAX)
            severity failure;
        check_range("fringe_trim", "TRIM_W", TRIM_W, 8, 24);
        check_range("fringe_trim", "TRIM_FRAC", TRIM_FRAC, 0, 16);
        check_range("fringe_trim", "G_SHIFT", G_SHIFT, 1, 48);
        check_range("fringe_trim", "MAG_SMOOTH_LOG2", MAG_SMOOTH_LOG2, 0, 12);
        assert START_SPEED >= -half and START_SPEED <= half - 1
            report "fringe_trim: START_SPEED = " & integer'image(START_SPEED) & " out of range -REV/2..REV/2-1 = "
                   & integer'image(-half) & ".." & integer'image(half - 1)
            severity failure;
        if MAP_PSI_W > 0 then
            check_range("fringe_trim", "SECT_SHIFT", SECT_SHIFT, 0, 127);
            check_mapping("fringe_trim", "SECT", "MAP_PSI_W", "sector_mapping", SECT_RECIP, SECT_SHIFT, MAP_PSI_W,
                          LINES, FINE_W);
        end if;
        check_min("fringe_trim", "USER_W", USER_W, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := TRIM_LATENCY;
    constant POS_W   : integer := FINE_W + clog2(LINES);            -- clog2(REV)
    constant N       : integer := 2**SPEED_LOG2;                    -- speed window
    constant FB      : integer := FINE_W - MAP_PHI_W;               -- fraction bits within a bin, >= 1
    constant MA_W    : integer := 1 + MAP_PSI_W + MAP_PHI_W;        -- map word address in a bank
    constant PSI_R   : integer := maximum(MAP_PSI_W, 1);            -- sector register width
    constant TW      : integer := TRIM_W;
    constant GW      : integer := TW + 1;                           -- gs, ga, s(TW+1)
    constant P1_W    : integer := POS_W + GW;                       -- speed x gs
    constant P2_W    : integer := maximum(AMP_W + GW, G_SHIFT) + 1; -- mag x ga + 2^(G_SHIFT-1)
    constant S_W     : integer := maximum(P1_W, P2_W) + 1;          -- their sum
    constant SS_W    : integer := S_W - G_SHIFT;                    -- the sum >>> G_SHIFT
    constant VR_W    : integer := maximum(TW, TRIM_FRAC) + 2;       -- value + 2^(TRIM_FRAC-1)
    constant MR_W    : integer := VR_W + 1;                         -- + the interpolated step
    constant MAP_PIECE_W : integer := 11;                           -- map RAM pieces of 2048 words (u_map)
    constant TT_W    : integer := maximum(MR_W, SS_W) + 1;          -- total (+ 2^(TRIM_FRAC-1))
    constant C_W     : integer := TT_W - TRIM_FRAC;                 -- corr before clipping
    constant CX_W    : integer := maximum(C_W, FINE_W) + 1;         -- corr, sign-extended
    constant WW      : integer := POS_W + 2;                        -- signed positions
    constant RECIP_W : integer := bit_width(SECT_RECIP);
    constant T_W     : integer := maximum(POS_W + RECIP_W, SECT_SHIFT + PSI_R);   -- sector product
    constant REV_W   : signed(WW - 1 downto 0) := signed(shift_left(to_unsigned(LINES, WW), FINE_W));
    constant HALF_W  : signed(WW - 1 downto 0) := signed(shift_left(to_unsigned(LINES, WW), FINE_W - 1));
    constant SC_W    : integer := POS_W + SPEED_LOG2;               -- the speed scaled from a start-up window
    constant SX_W    : integer := SC_W + 1;                         -- and -+ REV/2 beside it
    constant HALF_X  : signed(SX_W - 1 downto 0) := signed(shift_left(to_unsigned(LINES, SX_W), FINE_W - 1));
    constant SAT_HI  : signed(POS_W - 1 downto 0) := resize(HALF_X - 1, POS_W);   -- REV/2 - 1
    constant SAT_LO  : signed(POS_W - 1 downto 0) := resize(-HALF_X, POS_W);      -- -REV/2
    constant CLIP_LO : signed(FINE_W - 1 downto 0) := shift_left(to_signed(-1, FINE_W), FINE_W - 1);  -- -2^(FINE_W-1)
    constant CLIP_HI : signed(FINE_W - 1 downto 0) := not CLIP_LO;                                    -- 2^(FINE_W-1) - 1

    -- The sum A = (m + 2^(TRIM_FRAC-1)) * 2^G_SHIFT + 2^(G_SHIFT-1) + speed * gs + mag * ga, formed
    -- modulo 2^A_W (A >>> G_SHIFT = total + 2^(TRIM_FRAC-1), exact in A_W bits).
    constant A_W     : integer := TT_W + G_SHIFT;
    constant E_W     : integer := A_W + 64;                         -- wider than every term

    -- x * 2^sh modulo 2^A_W
    function term(x : signed; sh : integer) return unsigned is
        variable r : signed(E_W - 1 downto 0);
    begin
        r := shift_left(resize(x, E_W), sh);
        return unsigned(r(A_W - 1 downto 0));
    end function term;

    -- The speed window, one-hot: 2^floor(log2(f)), the top bit of f (0 when f = 0).
    function top_bit(f : unsigned) return unsigned is
        variable r : unsigned(f'range) := (others => '0');
    begin
        for j in f'low to f'high loop
            if f(j) = '1' then
                r := (others => '0');
                r(j) := '1';
            end if;
        end loop;
        return r;
    end function top_bit;

    -- speed history: 2N words (initialised so that GHDL computes on defined values before it fills)
    type hist_t is array (0 to 2 * N - 1) of unsigned(POS_W - 1 downto 0);
    signal hist     : hist_t := (others => (others => '0'));
    signal hist_q   : unsigned(POS_W - 1 downto 0);
    signal wp       : unsigned(SPEED_LOG2 downto 0) := (others => '0');   -- any start value works
    signal fill     : unsigned(SPEED_LOG2 downto 0);   -- accepted samples since reset, saturating at N
    signal win      : unsigned(SPEED_LOG2 downto 0);   -- the window: N when full, else top_bit(fill)
    signal accept   : std_logic;
    signal avg      : unsigned(AMP_W - 1 downto 0);    -- the magnitude the terms take

    signal s1_pos, s2_pos, s2_old, s3_pos, s4_pos, s11_pos
                    : unsigned(POS_W - 1 downto 0);
    signal s1_mag, s2_mag, s3_mag, s4_mag, s6_mag : unsigned(AMP_W - 1 downto 0);
    signal s1_bank, s2_bank, s3_bank, s4_bank : std_logic;
    signal s1_win, s2_win, s3_win, s4_win : unsigned(SPEED_LOG2 downto 0);
    signal s5_scaled : signed(SC_W - 1 downto 0);
    signal s2_sector, s3_sector, s4_sector : unsigned(PSI_R - 1 downto 0);
    signal s3_d     : signed(POS_W downto 0);
    signal s4_speed, s6_speed : signed(POS_W - 1 downto 0);
    signal s4_dir, s11_dir, s12_dir : std_logic;
    signal s6_carry  : std_logic_vector(AMP_W - 1 downto 0);           -- mag at stage 6
    signal s11_carry : std_logic_vector(POS_W downto 0);               -- {dir, pos} at stage 11
    signal s6_carry_valid, s11_carry_valid : std_logic;
    signal s6_gs, s6_ga : std_logic_vector(GW - 1 downto 0);   -- from the gain tables
    signal p_sg     : std_logic_vector(POS_W + GW - 1 downto 0);   -- speed x gs
    signal p_ma     : std_logic_vector(AMP_W + GW - 1 downto 0);   -- mag x ga
    signal s9_m     : std_logic_vector(MR_W - 1 downto 0);      -- from the map
    signal s10_am, s11_a : unsigned(A_W - 1 downto 0);
    signal s12_corr : signed(FINE_W - 1 downto 0);
    signal s12_sat, s12_neg : std_logic;
    signal s12_pos, s12_alt : signed(WW - 1 downto 0);

    signal gain_rd_addr : std_logic_vector(MAP_PHI_W downto 0);
    signal map_rd_addr  : std_logic_vector(MA_W downto 0);
    signal gain_frac    : std_logic_vector(FB - 1 downto 0);
    signal map_frac     : std_logic_vector(FB - 1 downto 0);
    signal wr_small     : boolean;
    signal wr_addr_small : std_logic_vector(MAP_PHI_W downto 0);
    signal wr_en_map, wr_en_speed, wr_en_amp : std_logic;

begin

    -- ---- valid (reset) and sideband, LATENCY stages ------------------------------------------------
    u_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => LATENCY)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
                  out_valid => out_valid, out_data => out_user);

    -- ---- the magnitude the terms take: mag itself, or its running average (MAG_SMOOTH_LOG2 = K > 0):
    -- acc = mag << K at the first sample since reset, then acc + mag - (acc >> K); avg = acc >> K. acc
    -- stays in u(AMP_W + K) (model: trim.magnitudes). A one-sample recursion: it cannot be pipelined. ----
    g_mag_avg : if MAG_SMOOTH_LOG2 > 0 generate
        constant K : natural := MAG_SMOOTH_LOG2;
        signal acc         : unsigned(AMP_W + K - 1 downto 0) := (others => '0');
        signal acc_started : std_logic;     -- a sample came since reset
        signal acc_next    : unsigned(AMP_W + K - 1 downto 0);
    begin
        acc_next <= acc + resize(unsigned(mag), AMP_W + K) - shift_right(acc, K) when acc_started = '1' else
                    shift_left(resize(unsigned(mag), AMP_W + K), K);
        avg      <= acc_next(AMP_W + K - 1 downto K);

        p_acc : process(clk)
        begin
            if rising_edge(clk) then
                if rst = '1' then
                    acc_started <= '0';
                elsif accept = '1' then
                    acc_started <= '1';
                end if;
                if accept = '1' then
                    acc <= acc_next;
                end if;
            end if;
        end process p_acc;
    end generate g_mag_avg;

    g_mag_direct : if MAG_SMOOTH_LOG2 = 0 generate
        avg <= unsigned(mag);
    end generate g_mag_direct;

    -- ---- speed history: written at wp, read at wp - win (win accepted samples earlier): win = N (wp
    -- xor N) once N samples came since the reset, before that the longest power-of-two window there
    -- is (1, 2, 4, ...), START_SPEED for the first sample (no window) ---------------------------------
    accept <= ce and in_valid and not rst;
    win    <= top_bit(fill);

    p_hist : process (clk)
        variable back : unsigned(SPEED_LOG2 downto 0);
    begin
        if rising_edge(clk) then
            if accept = '1' then
                hist(to_integer(wp)) <= unsigned(pos);
                wp <= wp + 1;
            end if;
            if ce = '1' then
                -- the first sample reads N back (its speed is START_SPEED): never the word being written
                back := win;
                if fill = 0 then
                    back := to_unsigned(N, SPEED_LOG2 + 1);
                end if;
                hist_q <= hist(to_integer(wp - back));
            end if;
            if rst = '1' then
                fill <= (others => '0');
            elsif accept = '1' and fill(SPEED_LOG2) = '0' then
                fill <= fill + 1;
            end if;
        end if;
    end process p_hist;

    -- ---- tables -------------------------------------------------------------------------------------
    wr_small      <= unsigned(wr_addr(MA_W - 1 downto MAP_PHI_W)) = 0;
    wr_addr_small <= wr_addr(MA_W) & wr_addr(MAP_PHI_W - 1 downto 0);
    wr_en_map     <= '1' when wr_en = '1' and wr_sel = "00" else '0';
    wr_en_speed   <= '1' when wr_en = '1' and wr_sel = "01" and wr_small else '0';
    wr_en_amp     <= '1' when wr_en = '1' and wr_sel = "10" and wr_small else '0';
    gain_rd_addr  <= s2_bank & std_logic_vector(s2_pos(FINE_W - 1 downto FB));
    gain_frac     <= std_logic_vector(s2_pos(FB - 1 downto 0));
    map_frac      <= std_logic_vector(s4_pos(FB - 1 downto 0));

    g_addr_sector : if MAP_PSI_W > 0 generate
        map_rd_addr <= s4_bank & s4_dir & std_logic_vector(s4_sector) & std_logic_vector(s4_pos(FINE_W - 1 downto FB));
    else generate
        map_rd_addr <= s4_bank & s4_dir & std_logic_vector(s4_pos(FINE_W - 1 downto FB));
    end generate g_addr_sector;

    -- gs, ga (stages 3..6) and m + 2^(TRIM_FRAC-1) (stages 5..9) = value (+ 2^(TRIM_FRAC-1))
    -- + ((slope * frac + 2^(FB-1)) >>> FB). The map lies in RAM pieces of 2^MAP_PIECE_W words, each
    -- registered before the registered select (see the Verilog).
    u_speed : entity work.fringe_interp_table
        generic map (ADDR_W => MAP_PHI_W, W => TW, FB => FB, OUT_W => GW, ROUND_SHIFT => 0,
                     INIT_FILE => SPEED_INIT)
        port map (clk => clk, ce => ce, wr_en => wr_en_speed, wr_addr => wr_addr_small, wr_data => wr_data,
                  rd_addr => gain_rd_addr, frac => gain_frac, result => s6_gs);

    u_amp : entity work.fringe_interp_table
        generic map (ADDR_W => MAP_PHI_W, W => TW, FB => FB, OUT_W => GW, ROUND_SHIFT => 0,
                     INIT_FILE => AMP_INIT)
        port map (clk => clk, ce => ce, wr_en => wr_en_amp, wr_addr => wr_addr_small, wr_data => wr_data,
                  rd_addr => gain_rd_addr, frac => gain_frac, result => s6_ga);

    u_map : entity work.fringe_interp_table
        generic map (ADDR_W => MA_W, W => TW, FB => FB, OUT_W => MR_W, ROUND_SHIFT => TRIM_FRAC,
                     INIT_FILE => MAP_INIT, PIECE_W => MAP_PIECE_W)
        port map (clk => clk, ce => ce, wr_en => wr_en_map, wr_addr => wr_addr, wr_data => wr_data,
                  rd_addr => map_rd_addr, frac => map_frac, result => s9_m);

    -- ---- 5, 6: magnitude carried beside the tables (the speed: p_data); 5..11: direction and position ----
    u_gain_carry : entity work.fringe_delay
        generic map (WIDTH => AMP_W, DEPTH => 2)
        port map (clk => clk, rst => rst, ce => ce, in_valid => '0', in_data => std_logic_vector(s4_mag),
                  out_valid => s6_carry_valid, out_data => s6_carry);
    s6_mag   <= unsigned(s6_carry);

    u_pos_carry : entity work.fringe_delay
        generic map (WIDTH => 1 + POS_W, DEPTH => 7)
        port map (clk => clk, rst => rst, ce => ce, in_valid => '0', in_data => s4_dir & std_logic_vector(s4_pos),
                  out_valid => s11_carry_valid, out_data => s11_carry);
    s11_dir <= s11_carry(POS_W);
    s11_pos <= unsigned(s11_carry(POS_W - 1 downto 0));

    -- ---- 7..10: the gain products in 18x18 partial products (speed x gs 4 stages, mag x ga 3) ---------
    u_speed_gain : entity work.fringe_split_mul
        generic map (A_W => POS_W, A_SIGNED => 1, B_W => GW, B_SIGNED => 1, LATENCY => 4)
        port map (clk => clk, ce => ce, a => std_logic_vector(s6_speed), b => s6_gs, p => p_sg);

    u_amp_gain : entity work.fringe_split_mul
        generic map (A_W => AMP_W, A_SIGNED => 0, B_W => GW, B_SIGNED => 1, LATENCY => 3)
        port map (clk => clk, ce => ce, a => std_logic_vector(s6_mag), b => s6_ga, p => p_ma);

    -- ---- the data pipeline --------------------------------------------------------------------------
    p_data : process (clk)
        variable t       : unsigned(T_W - 1 downto 0);
        variable d_x, d_hi, d_lo, d_wrap : signed(WW - 1 downto 0);
        variable speed4  : signed(POS_W - 1 downto 0);
        variable speed_x, scaled5 : signed(SC_W - 1 downto 0);
        variable sc_x, sc_hi, sc_lo : signed(SX_W - 1 downto 0);
        variable corr_x  : signed(CX_W - 1 downto 0);
        variable over    : boolean;
        variable pos_x, corr_w, a, b : signed(WW - 1 downto 0);
        variable use_b   : boolean;
        variable tm      : unsigned(A_W - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- 1: input registers (the history read is in p_hist)
                s1_pos  <= unsigned(pos);
                s1_mag  <= avg;
                s1_bank <= bank;
                s1_win  <= win;

                -- 2: history output register; sector product
                s2_pos  <= s1_pos;
                s2_old  <= hist_q;
                s2_mag  <= s1_mag;
                s2_bank <= s1_bank;
                s2_win  <= s1_win;
                if MAP_PSI_W > 0 then
                    t := resize(s1_pos * to_unsigned(SECT_RECIP, RECIP_W), T_W);
                    s2_sector <= t(SECT_SHIFT + PSI_R - 1 downto SECT_SHIFT);
                else
                    s2_sector <= (others => '0');
                end if;

                -- 3: pos - old in (-REV, REV); the gain tables read at {bank, bin}
                s3_d      <= signed('0' & s2_pos) - signed('0' & s2_old);
                s3_pos    <= s2_pos;
                s3_mag    <= s2_mag;
                s3_bank   <= s2_bank;
                s3_win    <= s2_win;
                s3_sector <= s2_sector;

                -- 4: speed wrapped into [-REV/2, REV/2); dir
                -- 2d >= REV <=> d - REV/2 >= 0;  2d < -REV <=> d + REV/2 < 0 (REV is even)
                d_x  := resize(s3_d, WW);
                d_hi := d_x - HALF_W;
                d_lo := d_x + HALF_W;
                if d_hi(WW - 1) = '0' then
                    d_wrap := d_x - REV_W;
                elsif d_lo(WW - 1) = '1' then
                    d_wrap := d_x + REV_W;
                else
                    d_wrap := d_x;
                end if;
                -- the first sample since reset (no window yet) takes START_SPEED as if measured over N samples
                if s3_win /= 0 then
                    speed4 := d_wrap(POS_W - 1 downto 0);
                    s4_win <= s3_win;
                else
                    speed4 := to_signed(START_SPEED, POS_W);
                    s4_win <= to_unsigned(N, SPEED_LOG2 + 1);
                end if;
                s4_speed  <= speed4;
                s4_dir    <= speed4(POS_W - 1);    -- the scaling and saturation below keep the sign
                s4_pos    <= s3_pos;
                s4_mag    <= s3_mag;
                s4_bank   <= s3_bank;
                s4_sector <= s3_sector;

                -- 5, 6: the speed scaled to N samples and saturated beside the tables (a stage each,
                -- so the wrap's carry chain gets nothing added); magnitude carried (u_gain_carry)
                -- 5: speed * 2^(SPEED_LOG2 - k) for win = 2^k (N: unchanged), a one-hot select of shifts
                speed_x := resize(s4_speed, SC_W);
                scaled5 := (others => '0');
                for j in 0 to SPEED_LOG2 loop
                    if s4_win(j) = '1' then
                        scaled5 := scaled5 or shift_left(speed_x, SPEED_LOG2 - j);
                    end if;
                end loop;
                s5_scaled <= scaled5;

                -- 6: saturated to [-REV/2, REV/2 - 1]: scaled - REV/2 >= 0 above, scaled + REV/2 < 0
                -- below (the compares in parallel, SX_W bits: shorter than the sum's A_W)
                sc_x  := resize(s5_scaled, SX_W);
                sc_hi := sc_x - HALF_X;
                sc_lo := sc_x + HALF_X;
                if sc_hi(SX_W - 1) = '0' then
                    s6_speed <= SAT_HI;
                elsif sc_lo(SX_W - 1) = '1' then
                    s6_speed <= SAT_LO;
                else
                    s6_speed <= sc_x(POS_W - 1 downto 0);
                end if;

                -- 5..11: direction and position (u_pos_carry); 7..10: speed x gs (u_speed_gain,
                -- 4 stages), mag x ga (u_amp_gain, 3 stages)

                -- 10: mag x ga + (m + 2^(TRIM_FRAC-1)) * 2^G_SHIFT + 2^(G_SHIFT-1) (bit fields)
                tm    := term(signed(s9_m), G_SHIFT);
                tm(G_SHIFT - 1) := '1';
                s10_am <= term(signed(p_ma), 0) + tm;

                -- 11: A; A >>> G_SHIFT = total + 2^(TRIM_FRAC-1)
                s11_a <= term(signed(p_sg), 0) + s10_am;

                -- 12: corr = total >>> TRIM_FRAC clipped to s(FINE_W); pos -+ REV for stage 13
                corr_x := resize(signed(s11_a(A_W - 1 downto G_SHIFT + TRIM_FRAC)), CX_W);
                -- in range <=> bits CX_W-1 .. FINE_W-1 all equal the sign
                if corr_x(CX_W - 1) = '1' then
                    over := not (corr_x(CX_W - 1 downto FINE_W - 1) = (CX_W - FINE_W downto 0 => '1'));
                else
                    over := corr_x(CX_W - 1 downto FINE_W - 1) /= (CX_W - FINE_W downto 0 => '0');
                end if;
                if not over then
                    s12_corr <= corr_x(FINE_W - 1 downto 0);
                elsif corr_x(CX_W - 1) = '1' then
                    s12_corr <= CLIP_LO;
                else
                    s12_corr <= CLIP_HI;
                end if;
                s12_sat <= '1' when over else '0';
                s12_neg <= corr_x(CX_W - 1);
                s12_dir <= s11_dir;
                pos_x   := signed(resize(s11_pos, WW));
                s12_pos <= pos_x;
                -- corr < 0: pos - corr may reach REV, alternative pos - REV - corr;
                -- corr >= 0: pos - corr may fall below 0, alternative pos + REV - corr
                if corr_x(CX_W - 1) = '1' then
                    s12_alt <= pos_x - REV_W;
                else
                    s12_alt <= pos_x + REV_W;
                end if;

                -- 13: pos - corr, wrapped into [0, REV)
                corr_w := resize(s12_corr, WW);
                a := s12_pos - corr_w;
                b := s12_alt - corr_w;
                if s12_neg = '1' then
                    use_b := b(WW - 1) = '0';
                else
                    use_b := a(WW - 1) = '1';
                end if;
                if use_b then
                    pos_out <= std_logic_vector(b(POS_W - 1 downto 0));
                else
                    pos_out <= std_logic_vector(a(POS_W - 1 downto 0));
                end if;
                dir <= s12_dir;
                sat <= s12_sat;
            end if;
        end if;
    end process p_data;

end architecture rtl;
