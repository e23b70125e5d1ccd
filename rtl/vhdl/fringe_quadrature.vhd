-- fringe_quadrature: offset, gain and quadrature correction (seed 001 eq. 21, Heydemann form).
--
-- VHDL-2008 twin of rtl/verilog/fringe_quadrature.v (same generics, ports and behaviour).
-- LATENCY = 5 clock enables, one sample per clock (SHARED_MUL = 1: the three products k_ss*ds, k_sc*dc,
-- k_cc*dc through one multiplier (fringe_split_mul: partial products of a split operand) in three clock enables, same
-- words and LATENCY, samples at least SHARED_MIN_CLOCKS = 4 clock enables apart, fixed/quadrature.py); ce = 0 freezes
-- every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_quadrature.md.
-- Bit-exact model: model/fringe/fixed/quadrature.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_quadrature is
    generic (
        WAVE_W : integer := 18;   -- data, offset and output width, 8..32
        COEF_W : integer := 18;   -- gain coefficient width, 8..27 (COEF_W-2 fractional bits)
        USER_W : integer := 1;    -- sideband width, >= 1
        SHARED_MUL : integer := 0     -- 1 = one multiplier for the three products (samples >= 4 clock enables apart)
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;   -- synchronous, active high: clears valid only
        ce        : in  std_logic;   -- clock enable: the pipeline advances when 1
        -- sample in
        in_valid  : in  std_logic;
        xs        : in  std_logic_vector(WAVE_W - 1 downto 0);   -- s(WAVE_W): sine channel
        xc        : in  std_logic_vector(WAVE_W - 1 downto 0);   -- s(WAVE_W): cosine channel
        in_user   : in  std_logic_vector(USER_W - 1 downto 0);
        -- coefficients, sampled with the sample
        ofs_s     : in  std_logic_vector(WAVE_W - 1 downto 0);   -- s(WAVE_W): sine offset
        ofs_c     : in  std_logic_vector(WAVE_W - 1 downto 0);   -- s(WAVE_W): cosine offset
        k_ss      : in  std_logic_vector(COEF_W - 1 downto 0);   -- s(COEF_W): sine gain (1/cos a)
        k_sc      : in  std_logic_vector(COEF_W - 1 downto 0);   -- s(COEF_W): cosine-into-sine (tan a)
        k_cc      : in  std_logic_vector(COEF_W - 1 downto 0);   -- s(COEF_W): cosine gain
        -- sample out
        out_valid : out std_logic;
        s         : out std_logic_vector(WAVE_W - 1 downto 0);   -- s(WAVE_W), WAVE_W-2 frac bits
        c         : out std_logic_vector(WAVE_W - 1 downto 0);   -- s(WAVE_W), WAVE_W-2 frac bits
        sat       : out std_logic;                               -- s or c saturated
        out_user  : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_quadrature;

architecture rtl of fringe_quadrature is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_range("fringe_quadrature", "WAVE_W", WAVE_W, 8, 32);
        check_range("fringe_quadrature", "COEF_W", COEF_W, 8, 27);
        check_min("fringe_quadrature", "USER_W", USER_W, 1);
        check_range("fringe_quadrature", "SHARED_MUL", SHARED_MUL, 0, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY   : integer := QUADRATURE_LATENCY;
    constant COEF_FRAC : integer := COEF_W - 2;
    constant D_W       : integer := WAVE_W + 1;        -- x - ofs, exact
    constant P_W       : integer := COEF_W + D_W;      -- k * (x - ofs), exact
    constant S_W       : integer := P_W + 1;           -- sum of two products + rounding, exact
    constant Q_W       : integer := S_W - COEF_FRAC;   -- after the shift: WAVE_W + 4
    constant RND       : signed(S_W - 1 downto 0) := shift_left(to_signed(1, S_W), COEF_FRAC - 1);
    constant MAX_W     : signed(WAVE_W - 1 downto 0) := '0' & (WAVE_W - 2 downto 0 => '1');
    constant MIN_W     : signed(WAVE_W - 1 downto 0) := '1' & (WAVE_W - 2 downto 0 => '0');

    -- Clamp q to s(WAVE_W): in range when the bits above the sign bit repeat it. The flag tells
    -- whether q was out of range.
    procedure saturate(q : in signed(Q_W - 1 downto 0); signal y : out std_logic_vector;
                       variable ovf : out boolean) is
    begin
        -- (compared as std_logic_vector: the predefined "/=", silent on pipeline-fill 'U's)
        if std_logic_vector(q(Q_W - 1 downto WAVE_W - 1)) /= (Q_W - 1 downto WAVE_W - 1 => q(Q_W - 1)) then
            y   <= std_logic_vector(MIN_W) when q(Q_W - 1) = '1' else std_logic_vector(MAX_W);
            ovf := true;
        else
            y   <= std_logic_vector(q(WAVE_W - 1 downto 0));
            ovf := false;
        end if;
    end procedure saturate;

    signal ds1, dc1           : signed(D_W - 1 downto 0);
    signal k_ss1, k_sc1, k_cc1 : signed(COEF_W - 1 downto 0);
    -- the sums the output stage shifts and saturates: k_ss*ds + k_sc*dc + RND and k_cc*dc + RND
    signal sum_s, sum_c       : signed(S_W - 1 downto 0);
    signal at1                : std_logic;   -- the sample is in stage 1 (SHARED_MUL = 1 picks the operands by it)
    signal user1              : std_logic_vector(USER_W - 1 downto 0);


begin

    p_data : process (clk)
        variable ovf_s, ovf_c : boolean;
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- stage 1: differences; coefficients travel with the sample (SHARED_MUL = 1 reads
                -- them until stage 4: they take only a valid sample)
                if SHARED_MUL = 0 or in_valid = '1' then
                    ds1   <= resize(signed(xs), D_W) - resize(signed(ofs_s), D_W);
                    dc1   <= resize(signed(xc), D_W) - resize(signed(ofs_c), D_W);
                    k_ss1 <= signed(k_ss);
                    k_sc1 <= signed(k_sc);
                    k_cc1 <= signed(k_cc);
                end if;
                -- stage 5: shift (floor) and saturate
                saturate(sum_s(S_W - 1 downto COEF_FRAC), s, ovf_s);
                saturate(sum_c(S_W - 1 downto COEF_FRAC), c, ovf_c);
                sat <= '1' when ovf_s or ovf_c else '0';
            end if;
        end if;
    end process p_data;

    g_parallel : if SHARED_MUL = 0 generate
        signal m_ss, m_sc, m_cc : std_logic_vector(P_W - 1 downto 0);
        signal pss3, psc3, pcc3 : signed(S_W - 1 downto 0);   -- k_ss*ds + RND, k_sc*dc, k_cc*dc + RND
        signal sum_s3, sum_c3   : signed(S_W - 1 downto 0);
    begin
        -- ---- stage 2: the products, bare: fringe_split_mul with LATENCY 1 registers the 18x18
        -- partial products of a wide difference or gain, and adds them without a register
        u_mul_ss : entity work.fringe_split_mul
            generic map (A_W => COEF_W, B_W => D_W, LATENCY => 1)
            port map (clk => clk, ce => ce, a => std_logic_vector(k_ss1), b => std_logic_vector(ds1), p => m_ss);
        u_mul_sc : entity work.fringe_split_mul
            generic map (A_W => COEF_W, B_W => D_W, LATENCY => 1)
            port map (clk => clk, ce => ce, a => std_logic_vector(k_sc1), b => std_logic_vector(dc1), p => m_sc);
        u_mul_cc : entity work.fringe_split_mul
            generic map (A_W => COEF_W, B_W => D_W, LATENCY => 1)
            port map (clk => clk, ce => ce, a => std_logic_vector(k_cc1), b => std_logic_vector(dc1), p => m_cc);

        -- ---- stage 3: the products assembled, with the rounding constant; stage 4: the sine sum
        p_sum : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    pss3   <= resize(signed(m_ss), S_W) + RND;
                    psc3   <= resize(signed(m_sc), S_W);
                    pcc3   <= resize(signed(m_cc), S_W) + RND;
                    sum_s3 <= pss3 + psc3;
                    sum_c3 <= pcc3;
                end if;
            end if;
        end process p_sum;
        sum_s <= sum_s3;
        sum_c <= sum_c3;
    end generate g_parallel;

    -- One multiplier, the sample's three products at stages 2, 3 and 4 (k_ss*ds, k_sc*dc, k_cc*dc);
    -- the stage-1 registers hold the sample until stage 4 reads them (samples >= 4 clock enables
    -- apart). prod is the product (fringe_split_mul, LATENCY 1: registered partial products, their sum
    -- unregistered); acc_s = k_ss*ds + RND at stage 3, sum_s3 adds k_sc*dc at stage 4, k_cc*dc + RND
    -- goes straight to the output stage: the parallel datapath's sums at the same clock enables.
    g_shared : if SHARED_MUL = 1 generate
        signal k_m         : signed(COEF_W - 1 downto 0);
        signal d_m         : signed(D_W - 1 downto 0);
        signal m           : std_logic_vector(P_W - 1 downto 0);
        signal prod        : signed(S_W - 1 downto 0);
        signal acc_s, sum_s3 : signed(S_W - 1 downto 0);
    begin
        -- The operands are registered (the DSP's input registers): k_ss and x_s - ofs_s with the
        -- sample (stage 1), then k_sc, dc and k_cc, dc from the stage-1 registers.
        p_ops : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    if in_valid = '1' then
                        k_m <= signed(k_ss);
                        d_m <= resize(signed(xs), D_W) - resize(signed(ofs_s), D_W);
                    elsif at1 = '1' then
                        k_m <= k_sc1;
                        d_m <= dc1;
                    else
                        k_m <= k_cc1;
                        d_m <= dc1;
                    end if;
                end if;
            end if;
        end process p_ops;

        u_mul : entity work.fringe_split_mul
            generic map (A_W => COEF_W, B_W => D_W, LATENCY => 1)
            port map (clk => clk, ce => ce, a => std_logic_vector(k_m), b => std_logic_vector(d_m), p => m);
        prod <= resize(signed(m), S_W);

        p_acc : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    acc_s  <= prod + RND;
                    sum_s3 <= acc_s + prod;
                end if;
            end if;
        end process p_acc;
        sum_s <= sum_s3;
        sum_c <= prod + RND;
    end generate g_shared;

    -- ---- valid (the only reset registers) and sideband, LATENCY stages: stage 1, then the rest
    u_valid1 : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => 1)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
                  out_valid => at1, out_data => user1);
    u_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => LATENCY - 1)
        port map (clk => clk, rst => rst, ce => ce, in_valid => at1, in_data => user1,
                  out_valid => out_valid, out_data => out_user);

end architecture rtl;
