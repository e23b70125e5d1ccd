-- fringe_split_mul: an exact pipelined product p = a * b of operands of any width, built from
-- partial products that each fit one 18x18 signed multiplier (LO_W = 17; 15 for 16x16).
-- VHDL-2008 twin of rtl/verilog/fringe_split_mul.v. Document: docs/blocks/fringe_split_mul.md.
--
-- LATENCY clock enables (>= 1): stage 1 registers the bare partial products, stages 2..LATENCY add
-- them in groups of G (the smallest G with G^(LATENCY-1) >= the number of partial products), one
-- carry chain per term; LATENCY = 1: p is the unregistered sum of the registered partial products
-- (for a caller that registers it with terms of its own). ce = 0 freezes every stage; no reset (data only).

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_split_mul is
    generic (
        A_W      : integer := 18;  -- width of a, >= 1
        A_SIGNED : integer := 1;   -- 1: a is two's complement, 0: unsigned
        B_W      : integer := 18;  -- width of b, >= 1
        B_SIGNED : integer := 1;   -- 1: b is two's complement, 0: unsigned
        LATENCY  : integer := 2;   -- clock enables from a, b to p, >= 1 (1: p is not registered)
        LO_W     : integer := 17   -- bits of a low chunk, >= 1: partial products of (LO_W+1)-bit signed chunks
    );
    port (
        clk : in  std_logic;
        ce  : in  std_logic;                                  -- clock enable
        a   : in  std_logic_vector(A_W - 1 downto 0);
        b   : in  std_logic_vector(B_W - 1 downto 0);
        p   : out std_logic_vector(A_W + B_W - 1 downto 0)    -- a * b (signed if either operand is)
    );
end entity fringe_split_mul;

architecture rtl of fringe_split_mul is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        assert A_W >= 1 and B_W >= 1 and LO_W >= 1 and LATENCY >= 1
            report "fringe_split_mul: A_W = " & integer'image(A_W) & ", B_W = " & integer'image(B_W) & ", LO_W = "
                   & integer'image(LO_W) & ", LATENCY = " & integer'image(LATENCY) & " must be >= 1"
            severity failure;
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    -- ---- chunks: x = sum_i C_i * 2^(L i); C_i = {0, L bits} below the top, the top chunk signed
    constant L   : integer := maximum(1, LO_W);   -- an illegal LO_W stops at the check below, not at a division
    constant P_W : integer := A_W + B_W;                 -- holds the product exactly

    function signed_w(w, is_signed : integer) return integer is
    begin
        if is_signed /= 0 then
            return w;
        end if;
        return w + 1;
    end function signed_w;

    function n_chunks(x : integer) return integer is
    begin
        return maximum(1, (x + L - 2) / L);
    end function n_chunks;

    constant AS_W : integer := signed_w(A_W, A_SIGNED);   -- a as a signed operand
    constant BS_W : integer := signed_w(B_W, B_SIGNED);
    constant NA : integer := n_chunks(AS_W);
    constant NB : integer := n_chunks(BS_W);
    constant NP  : integer := NA * NB;                    -- partial products, term k = (k / NB, k mod NB)
    constant NS  : integer := LATENCY - 1;                -- adding stages

    -- the smallest g >= 2 with g^n_stages >= n_terms (1 for one term: the adding stages only delay;
    -- no adding stage: all terms, as the Verilog's)
    function group_size(n_terms, n_stages : integer) return integer is
        variable g : integer := 2;
    begin
        if n_terms <= 1 then
            return 1;
        elsif n_stages = 0 then
            return n_terms;
        end if;
        while g ** n_stages < n_terms loop
            g := g + 1;
        end loop;
        return g;
    end function group_size;

    constant G : integer := group_size(NP, NS);

    -- width of chunk i of an operand with x signed bits in n chunks (the top one holds the sign)
    function chunk_w(i, n, x : integer) return integer is
    begin
        if i < n - 1 then
            return L + 1;
        end if;
        return x - L * (n - 1);
    end function chunk_w;

    -- lowest bit and signed width (from bit 0) of term tm after stage s: its partial products
    -- k in [tm G^s, (tm + 1) G^s) have no bits below L (i + j) and fit s(L (i + j) + chunk widths)
    function term_lo(s, tm : integer) return integer is
        variable lo : integer := P_W;
    begin
        for k in tm * G ** s to minimum((tm + 1) * G ** s, NP) - 1 loop
            lo := minimum(lo, L * (k / NB + k mod NB));
        end loop;
        return lo;
    end function term_lo;

    function term_hi(s, tm : integer) return integer is
        variable hi, n : integer := 0;
    begin
        for k in tm * G ** s to minimum((tm + 1) * G ** s, NP) - 1 loop
            hi := maximum(hi, L * (k / NB + k mod NB) + chunk_w(k / NB, NA, AS_W) + chunk_w(k mod NB, NB, BS_W));
            n  := n + 1;
        end loop;
        return minimum(P_W, hi + clog2(n));
    end function term_hi;

    -- the same value with its known-zero bits below lo and its sign copies from bit hi on written as
    -- such (a synthesis hint: those flip-flops merge or vanish); the value itself is unchanged
    function shaped(v : unsigned(P_W - 1 downto 0); lo, hi : integer) return unsigned is
        variable res : unsigned(P_W - 1 downto 0);
    begin
        for k in 0 to P_W - 1 loop
            if k < lo then
                res(k) := '0';
            elsif k < hi then
                res(k) := v(k);
            else
                res(k) := v(hi - 1);
            end if;
        end loop;
        return res;
    end function shaped;

    type term_array is array (0 to NP - 1) of unsigned(P_W - 1 downto 0);
    type stage_array is array (0 to NS) of term_array;

    constant XA_W : integer := NA * L + L + 1;          -- operands extended to whole chunks
    constant XB_W : integer := NB * L + L + 1;

    signal a_ext   : signed(XA_W - 1 downto 0);
    signal b_ext   : signed(XB_W - 1 downto 0);
    signal prod : term_array;
    signal stage : stage_array;

begin

    a_ext <= resize(signed(a), XA_W) when A_SIGNED /= 0 else signed(resize(unsigned(a), XA_W));
    b_ext <= resize(signed(b), XB_W) when B_SIGNED /= 0 else signed(resize(unsigned(b), XB_W));

    -- ---- stage 1: the partial products, each at its weight, registered bare ------------------------
    g_prod : for k in 0 to NP - 1 generate
        constant I : integer := k / NB;
        constant J : integer := k mod NB;
        signal ca, cb : signed(L downto 0);
        signal m      : signed(2 * L + 1 downto 0);
        signal mw     : signed(P_W + 2 * L + 1 downto 0);
    begin
        ca <= signed('0' & a_ext(L * I + L - 1 downto L * I)) when I < NA - 1 else a_ext(L * I + L downto L * I);
        cb <= signed('0' & b_ext(L * J + L - 1 downto L * J)) when J < NB - 1 else b_ext(L * J + L downto L * J);
        m  <= ca * cb;
        mw <= shift_left(resize(m, mw'length), L * (I + J));
        prod(k) <= unsigned(mw(P_W - 1 downto 0));
    end generate g_prod;

    g_stage : for s in 0 to NS generate
        g_term : for tm in 0 to NP - 1 generate
            constant LO : integer := term_lo(s, tm);
            constant HI : integer := term_hi(s, tm);
        begin
            g_live : if LO < P_W generate
                g_first : if s = 0 generate
                    p_reg : process (clk)
                    begin
                        if rising_edge(clk) then
                            if ce = '1' then
                                stage(s)(tm) <= shaped(prod(tm), LO, HI);
                            end if;
                        end if;
                    end process p_reg;
                else generate
                    -- the sum of terms G tm .. G tm + G - 1 of the stage before
                    p_reg : process (clk)
                        variable acc : unsigned(P_W - 1 downto 0);
                    begin
                        if rising_edge(clk) then
                            if ce = '1' then
                                acc := (others => '0');
                                for c in 0 to G - 1 loop
                                    if G * tm + c < NP then
                                        acc := acc + stage(s - 1)(G * tm + c);
                                    end if;
                                end loop;
                                stage(s)(tm) <= shaped(acc, LO, HI);
                            end if;
                        end if;
                    end process p_reg;
                end generate g_first;
            else generate
                stage(s)(tm) <= (others => '0');
            end generate g_live;
        end generate g_term;
    end generate g_stage;

    g_sum_out : if NS = 0 generate
        -- LATENCY = 1: the registered partial products added without a register
        p_sum : process (stage)
            variable acc : unsigned(P_W - 1 downto 0);
        begin
            acc := (others => '0');
            for k in 0 to NP - 1 loop
                acc := acc + stage(0)(k);
            end loop;
            p <= std_logic_vector(acc);
        end process p_sum;
    else generate
        p <= std_logic_vector(stage(NS)(0));
    end generate g_sum_out;

end architecture rtl;
