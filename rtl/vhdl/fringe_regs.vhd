-- fringe_regs: fringe_core's register file (two banks), CTRL and the configuration write decode.
--
-- VHDL-2008 twin of rtl/verilog/fringe_regs.v (same generics, ports and behaviour).
-- A write presented on cfg_wr_* lands two clocks later, in the bank that was inactive when it was
-- presented; a CTRL swap flips active_bank at the clock a write presented with it would land.
-- Configuration, never reset. Parameters, ports and timing: docs/blocks/fringe_regs.md.
-- Model: the register map model/fringe/fixed/regmap.py; test tb/test_fringe_regs.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_regs is
    generic (
        WAVE_ADDR_W : integer := 8;    -- words per wave table bank and branch: 2^WAVE_ADDR_W (x 2 branches)
        LP_ADDR_W   : integer := 8;    -- words per long-period table bank: 2^LP_ADDR_W
        MAP_PSI_W   : integer := 4;    -- trim map bank: 2^(1+MAP_PSI_W+MAP_PHI_W) words
        MAP_PHI_W   : integer := 6;
        FWD_W       : integer := 6;    -- words per drift forward table bank: 2^FWD_W
        REGS_INIT   : string  := ""    -- $readmemh image of the registers, 2 x 32 words of 32 bits; "" = zeros
    );
    port (
        clk         : in  std_logic;
        -- configuration write port
        cfg_wr_en   : in  std_logic;
        cfg_wr_addr : in  std_logic_vector(19 downto 0);            -- {space, word}
        cfg_wr_data : in  std_logic_vector(63 downto 0);
        -- the register file: word {bank, index} at bits 32*(32*bank + index) + 31 .. 32*(32*bank + index)
        regs_q      : out std_logic_vector(2 * N_REGS * REG_W - 1 downto 0);
        active_bank : out std_logic;
        -- the landing table write (one clock): strobes, word address in a bank, its bank, data
        wr_sin      : out std_logic;
        wr_cos      : out std_logic;
        wr_lp       : out std_logic;
        wr_trim     : out std_logic;
        wr_trim_sel : out std_logic_vector(1 downto 0);             -- 0 map, 1 speed, 2 magnitude
        wr_fwd      : out std_logic;
        wr_fwd_sel  : out std_logic;                                -- 0 sine, 1 cosine
        wr_word     : out std_logic_vector(15 downto 0);
        wr_bank     : out std_logic;
        wr_data     : out std_logic_vector(63 downto 0)
    );
end entity fringe_regs;

architecture rtl of fringe_regs is

    -- register indices REG_*, CTRL_WORD: fringe_pkg (generated from model/fringe/fixed/regmap.py)
    subtype regs_t is word_array(0 to 2 * N_REGS - 1)(REG_W - 1 downto 0);   -- bank 0, then bank 1

    -- CTRL is decoded in two halves of its word, each one compare in step 1: the high bits zero (with
    -- the space and the write enable) and the low CTRL_LOW_W bits CTRL_WORD's (with the swap bit)
    constant CTRL_LOW_W : integer := 8;

    function generics_ok return boolean is
    begin
        check_range("fringe_regs", "CTRL_WORD", CTRL_WORD, 0, 2 ** CTRL_LOW_W - 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    signal regs   : regs_t := read_memh(REGS_INIT, 2 * N_REGS, REG_W, "fringe_regs: REGS_INIT");
    signal bank_r : std_logic := '0';

    signal cfg_sel      : std_logic_vector(3 downto 0);
    -- the spaces of st1_sel's bits: sine, cosine, long period, trim map, speed, magnitude, drift sine, cosine
    constant SEL_SPACES : integer_vector(0 to 7) := (SPACE_WAVE_SIN, SPACE_WAVE_COS, SPACE_LONG_PERIOD, SPACE_TRIM_MAP,
                                                     SPACE_TRIM_SPEED, SPACE_TRIM_AMP, SPACE_DRIFT_FWD_SIN,
                                                     SPACE_DRIFT_FWD_COS);
    signal cfg_word     : unsigned(15 downto 0);
    signal in_bank      : std_logic;
    -- power-up values: no write lands before the first one issued (as bank_r, not reset)
    -- step 1 of the write decode (partial decodes of the presented write)
    signal st1_en_reg    : std_logic := '0';
    signal st1_en_ctrl_a : std_logic := '0';
    signal st1_en_ctrl_b : std_logic;
    signal st1_sel       : std_logic_vector(7 downto 0) := (others => '0');  -- one-hot: sin, cos, lp, map, speed, amp, fwd sin, fwd cos
    signal st1_wave_ok, st1_lp_ok, st1_trim_ok, st1_fwd_ok : std_logic;
    signal st1_word      : unsigned(15 downto 0);
    signal st1_bank      : std_logic;
    signal st1_data      : std_logic_vector(63 downto 0);
    signal ctrl_swap     : std_logic := '0';
    -- step 2: the one-hot register enables and the landing write's data
    signal reg_we        : std_logic_vector(2 * N_REGS - 1 downto 0) := (others => '0');
    signal wr_data_r     : std_logic_vector(63 downto 0);

begin

    cfg_sel  <= cfg_wr_addr(19 downto 16);
    cfg_word <= unsigned(cfg_wr_addr(15 downto 0));
    in_bank  <= not bank_r;                 -- writes go to the inactive bank

    -- The write decode is two registered steps (the iCE40's routing cannot take the 22-input compare and
    -- the 32-way fan-out in one clock): step 1 registers partial decodes of the presented write, step 2
    -- the one-hot register enables and the table enables; the write lands at the clock after step 2,
    -- two clocks after it was presented, in the bank that was inactive when it was presented.
    p_cfg_step1 : process (clk)
        function b(c : boolean) return std_logic is
        begin
            if c then
                return '1';
            end if;
            return '0';
        end function b;
    begin
        if rising_edge(clk) then
            st1_en_reg    <= b(cfg_wr_en = '1' and to_integer(unsigned(cfg_sel)) = SPACE_REGS
                               and shift_right(cfg_word, REG_INDEX_W) = 0);
            st1_en_ctrl_a <= b(cfg_wr_en = '1' and to_integer(unsigned(cfg_sel)) = SPACE_REGS
                               and shift_right(cfg_word, CTRL_LOW_W) = 0);
            -- (the package's CTRL_SWAP by its full name: the signal ctrl_swap hides it)
            st1_en_ctrl_b <= b(cfg_word(CTRL_LOW_W - 1 downto 0) = to_unsigned(CTRL_WORD, CTRL_LOW_W)
                               and cfg_wr_data(work.fringe_pkg.CTRL_SWAP) = '1');
            for k in 0 to 7 loop
                st1_sel(k) <= b(cfg_wr_en = '1' and to_integer(unsigned(cfg_sel)) = SEL_SPACES(k));
            end loop;
            st1_wave_ok <= b(shift_right(cfg_word, WAVE_ADDR_W + 1) = 0);
            st1_lp_ok   <= b(shift_right(cfg_word, LP_ADDR_W) = 0);
            st1_trim_ok <= b(shift_right(cfg_word, MAP_PSI_W + MAP_PHI_W + 1) = 0);
            st1_fwd_ok  <= b(shift_right(cfg_word, FWD_W) = 0);
            st1_word    <= cfg_word;
            st1_bank    <= in_bank;
            st1_data    <= cfg_wr_data;
        end if;
    end process p_cfg_step1;

    p_cfg_dec : process (clk)
    begin
        if rising_edge(clk) then
            for i in 0 to 2 * N_REGS - 1 loop
                if st1_en_reg = '1' and st1_word(REG_INDEX_W - 1 downto 0) = to_unsigned(i mod N_REGS, REG_INDEX_W)
                   and (st1_bank = '1') = (i >= N_REGS) then
                    reg_we(i) <= '1';
                else
                    reg_we(i) <= '0';
                end if;
            end loop;
            wr_sin      <= st1_sel(0) and st1_wave_ok;
            wr_cos      <= st1_sel(1) and st1_wave_ok;
            wr_lp       <= st1_sel(2) and st1_lp_ok;
            wr_trim     <= (st1_sel(3) or st1_sel(4) or st1_sel(5)) and st1_trim_ok;
            wr_trim_sel <= st1_sel(5) & st1_sel(4);   -- 4, 5, 6 -> 0 map, 1 speed, 2 magnitude
            wr_fwd      <= (st1_sel(6) or st1_sel(7)) and st1_fwd_ok;
            wr_fwd_sel  <= st1_sel(7);                -- 7, 8 -> 0 sine, 1 cosine
            ctrl_swap   <= st1_en_ctrl_a and st1_en_ctrl_b;
            wr_word     <= std_logic_vector(st1_word);
            wr_bank     <= st1_bank;
            wr_data_r   <= st1_data;
        end if;
    end process p_cfg_dec;
    wr_data <= wr_data_r;

    p_regs : process (clk)
    begin
        if rising_edge(clk) then
            for i in 0 to 2 * N_REGS - 1 loop
                if reg_we(i) = '1' then
                    regs(i) <= wr_data_r(REG_W - 1 downto 0);
                end if;
            end loop;
        end if;
    end process p_regs;

    g_regs_q : for i in 0 to 2 * N_REGS - 1 generate
        regs_q(REG_W * i + REG_W - 1 downto REG_W * i) <= regs(i);
    end generate g_regs_q;

    -- CTRL swaps at the clock after step 2, as a write presented at the same time would land: every
    -- write presented before it has landed by then (each carries its bank in wr_bank)
    p_ctrl : process (clk)
    begin
        if rising_edge(clk) then
            if ctrl_swap = '1' then
                bank_r <= not bank_r;
            end if;
        end if;
    end process p_ctrl;

    active_bank <= bank_r;

end architecture rtl;
