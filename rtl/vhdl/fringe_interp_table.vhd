-- fringe_interp_table: two-bank table of {slope, value} words, linearly interpolated.
--
-- VHDL-2008 twin of rtl/verilog/fringe_interp_table.v (same generics, ports and behaviour).
-- LATENCY = 4 clock enables from rd_addr/frac to result (5 with PIECE_W > 0); ce = 0 freezes every
-- register; no reset (data only: the caller's fringe_delay carries valid).
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_interp_table.md.
-- Model: model/fringe/fixed/interp_table.py (fringe.fixed.table_ram.interpolate with the offset and width).

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_interp_table is
    generic (
        ADDR_W      : integer := 8;    -- address bits of one bank, 1..24
        W           : integer := 18;   -- slope and value field width (word = {slope, value}), 2..32
        FB          : integer := 4;    -- fraction bits, 1..30
        OUT_W       : integer := 19;   -- result width, W..W+40 (W: the result wraps modulo 2^W)
        ROUND_SHIFT : integer := 0;    -- adds 2^(ROUND_SHIFT-1) to the result (0: nothing), 0..40
        INIT_FILE   : string  := "";   -- $readmemh image, 2*2^ADDR_W words; "" = zeros
        PIECE_W     : integer := 0     -- 0: one RAM; 1..25: RAMs of 2^PIECE_W words, each registered, then a
                                       -- registered select (one clock enable more); 0..25
    );
    port (
        clk     : in  std_logic;
        ce      : in  std_logic;                              -- the pipeline advances when 1
        -- write port (software side)
        wr_en   : in  std_logic;
        wr_addr : in  std_logic_vector(ADDR_W downto 0);      -- {bank, address}
        wr_data : in  std_logic_vector(2 * W - 1 downto 0);   -- {slope, value}, both s(W)
        -- read (sample side)
        rd_addr : in  std_logic_vector(ADDR_W downto 0);      -- {bank, address}
        frac    : in  std_logic_vector(FB - 1 downto 0);      -- u(FB)
        result  : out std_logic_vector(OUT_W - 1 downto 0)    -- s(OUT_W)
    );
end entity fringe_interp_table;

architecture rtl of fringe_interp_table is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_range("fringe_interp_table", "W", W, 2, 32);
        check_range("fringe_interp_table", "FB", FB, 1, 30);
        assert OUT_W >= W and OUT_W <= W + 40
            report "fringe_interp_table: OUT_W = " & integer'image(OUT_W) & " out of range W..W+40 = "
                   & integer'image(W) & ".." & integer'image(W + 40)
            severity failure;
        check_range("fringe_interp_table", "ROUND_SHIFT", ROUND_SHIFT, 0, 40);
        check_range("fringe_interp_table", "PIECE_W", PIECE_W, 0, 25);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    function latency_of return integer is
    begin
        if PIECE_W > 0 then
            return 5;
        end if;
        return 4;
    end function latency_of;
    constant LATENCY : integer := latency_of;
    constant A_W     : integer := ADDR_W + 1;                 -- {bank, address}
    function pw_of return integer is
    begin
        if PIECE_W > 0 and PIECE_W < A_W then
            return PIECE_W;
        end if;
        return A_W;
    end function pw_of;
    constant PW      : integer := pw_of;
    constant NP      : integer := 2 ** (A_W - PW);
    constant S_W     : integer := OUT_W + FB;                 -- {result, fraction}
    constant RND     : unsigned(FB - 1 downto 0) := shift_left(to_unsigned(1, FB), FB - 1);  -- 2^(FB-1)

    -- 2^(ROUND_SHIFT-1) above the fraction, modulo 2^S_W (0 when ROUND_SHIFT = 0)
    function offset_value return unsigned is
        variable v : unsigned(S_W - 1 downto 0) := (others => '0');
    begin
        if ROUND_SHIFT > 0 and ROUND_SHIFT - 1 + FB < S_W then
            v(ROUND_SHIFT - 1 + FB) := '1';
        end if;
        return v;
    end function offset_value;
    constant OFFSET  : unsigned(S_W - 1 downto 0) := offset_value;

    signal wordm         : std_logic_vector(2 * W - 1 downto 0);   -- the word into stage M
    signal fc1, fc2      : std_logic_vector(FB - 1 downto 0);
    signal fcm           : std_logic_vector(FB - 1 downto 0);       -- fc beside wordm
    signal prod3         : signed(W + FB - 1 downto 0);
    signal base3         : unsigned(S_W - 1 downto 0);

begin

    -- 1: table read (the RAM's read register); 2: the RAM's output register (a block RAM's clock-to-out
    -- then feeds no logic); fc = frac - 2^(FB-1) = frac xor 2^(FB-1), s(FB) with a live sign bit (see the
    -- Verilog). PIECE_W > 0: NP RAMs of 2^PW words, piece k holding words k * 2^PW .. of the one INIT_FILE
    -- and no others; stage 2 registers each piece's word, stage 3 selects the sample's.
    p_fc : process (clk)
    begin
        if rising_edge(clk) then
            if ce = '1' then
                fc1 <= frac xor std_logic_vector(RND);
                fc2 <= fc1;
            end if;
        end if;
    end process p_fc;

    g_one : if PIECE_W = 0 generate
        signal word_q, word2 : std_logic_vector(2 * W - 1 downto 0);
    begin
        u_table : entity work.fringe_table_ram
            generic map (ADDR_W => ADDR_W, DATA_W => 2 * W, INIT_FILE => INIT_FILE)
            port map (clk => clk, wr_en => wr_en, wr_addr => wr_addr, wr_data => wr_data,
                      rd_en => ce, rd_addr => rd_addr, rd_data => word_q);

        p_word : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    word2 <= word_q;
                end if;
            end if;
        end process p_word;
        wordm <= word2;
        fcm   <= fc2;
    end generate g_one;

    g_pieces : if PIECE_W > 0 generate
        type words_t is array (0 to NP - 1) of std_logic_vector(2 * W - 1 downto 0);
        signal piece_q, piece2 : words_t;
        signal word3           : std_logic_vector(2 * W - 1 downto 0);
        signal fc3             : std_logic_vector(FB - 1 downto 0);
        signal sel1, sel2      : integer range 0 to NP - 1;
        -- the piece number of an address {bank, address}
        function piece_of(a : std_logic_vector) return integer is
        begin
            return to_integer(shift_right(unsigned(a), PW));
        end function piece_of;
    begin
        g_piece : for k in 0 to NP - 1 generate
            -- Only the piece's own 2^PW words: words k * 2^PW .. of the one INIT_FILE (read_memh's first).
            subtype piece_t is word_array(0 to 2 ** PW - 1)(2 * W - 1 downto 0);
            signal mem : piece_t := read_memh(INIT_FILE, 2 ** PW, 2 * W, "fringe_interp_table: INIT_FILE",
                                              k * 2 ** PW);
        begin
            p_ram : process (clk)
            begin
                if rising_edge(clk) then
                    if wr_en = '1' and piece_of(wr_addr) = k then
                        mem(to_integer(unsigned(wr_addr(PW - 1 downto 0)))) <= wr_data;
                    end if;
                    if ce = '1' then
                        piece_q(k) <= mem(to_integer(unsigned(rd_addr(PW - 1 downto 0))));
                    end if;
                end if;
            end process p_ram;
        end generate g_piece;

        p_sel : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    sel1   <= piece_of(rd_addr);
                    sel2   <= sel1;
                    piece2 <= piece_q;
                    fc3    <= fc2;
                    word3  <= piece2(sel2);
                end if;
            end if;
        end process p_sel;
        wordm <= word3;
        fcm   <= fc3;
    end generate g_pieces;

    p_pipe : process (clk)
        variable slope2 : signed(W - 1 downto 0);
        variable value2 : signed(W - 1 downto 0);
        variable sum3   : unsigned(S_W - 1 downto 0);
        variable vx     : std_logic_vector(S_W - 1 downto 0);   -- {value, 2^(FB-1)}
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- M (3; 4 with PIECE_W > 0): slope * fc (bare); base = {value, 2^(FB-1)} + slope * 2^(FB-1)
                -- + offset * 2^FB
                slope2 := signed(wordm(2 * W - 1 downto W));
                value2 := signed(wordm(W - 1 downto 0));
                prod3  <= slope2 * signed(fcm);
                vx     := std_logic_vector(resize(value2, OUT_W)) & std_logic_vector(RND);
                base3  <= unsigned(vx) + shift_left(unsigned(resize(slope2, S_W)), FB - 1) + OFFSET;
                -- R (4; 5 with PIECE_W > 0): result = (base + product) >>> FB, modulo 2^OUT_W
                sum3   := base3 + unsigned(resize(prod3, S_W));
                result <= std_logic_vector(sum3(S_W - 1 downto FB));
            end if;
        end if;
    end process p_pipe;

end architecture rtl;
