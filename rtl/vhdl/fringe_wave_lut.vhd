-- fringe_wave_lut: waveform inverse of one channel as an interpolated table (seed 001).
--
-- VHDL-2008 twin of rtl/verilog/fringe_wave_lut.v (same generics, ports and behaviour).
-- LATENCY = 4 clock enables, one sample per clock; ce = 0 freezes
-- every register, rst (synchronous, active high) clears only the valid pipeline and the state, never the data registers.
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_wave_lut.md.
-- Bit-exact model: model/fringe/fixed/wave_lut.py.

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_wave_lut is
    generic (
        ADC_W       : integer := 12;   -- ADC code width, 4..24
        WAVE_ADDR_W : integer := 8;    -- table address bits per branch, 2..ADC_W-1
        WAVE_W      : integer := 18;   -- table value and output width, 8..32
        INIT_FILE   : string  := "";   -- $readmemh image of both banks (4*2^WAVE_ADDR_W words); "" = zeros
        USER_W      : integer := 1     -- sideband width, >= 1
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;     -- synchronous, active high: clears valid only
        ce        : in  std_logic;     -- clock enable: the pipeline advances when 1
        -- sample in
        in_valid  : in  std_logic;
        adc       : in  std_logic_vector(ADC_W - 1 downto 0);        -- s(ADC_W)
        branch    : in  std_logic;     -- other channel on its positive side
        bank      : in  std_logic;     -- table bank serving this sample
        in_user   : in  std_logic_vector(USER_W - 1 downto 0);
        -- table write port: address {bank, branch, addr}, word {slope, value}
        wr_en     : in  std_logic;
        wr_addr   : in  std_logic_vector(WAVE_ADDR_W + 1 downto 0);
        wr_data   : in  std_logic_vector(2 * WAVE_W - 1 downto 0);
        -- sample out
        out_valid : out std_logic;
        x         : out std_logic_vector(WAVE_W - 1 downto 0);       -- s(WAVE_W), WAVE_W-2 frac bits
        clip      : out std_logic;
        out_user  : out std_logic_vector(USER_W - 1 downto 0)
    );
end entity fringe_wave_lut;

architecture rtl of fringe_wave_lut is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        assert ADC_W >= 4 and ADC_W <= 24
            report "fringe_wave_lut: ADC_W = " & integer'image(ADC_W) & " out of range 4..24"
            severity failure;
        assert WAVE_ADDR_W >= 2 and WAVE_ADDR_W <= ADC_W - 1
            report "fringe_wave_lut: WAVE_ADDR_W = " & integer'image(WAVE_ADDR_W)
                   & " out of range 2..ADC_W-1 = " & integer'image(ADC_W - 1)
            severity failure;
        assert WAVE_W >= 8 and WAVE_W <= 32
            report "fringe_wave_lut: WAVE_W = " & integer'image(WAVE_W) & " out of range 8..32"
            severity failure;
        assert USER_W >= 1
            report "fringe_wave_lut: USER_W = " & integer'image(USER_W) & " must be >= 1"
            severity failure;
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := WAVE_LUT_LATENCY;
    constant FB      : integer := ADC_W - WAVE_ADDR_W;   -- fraction bits of the index, >= 1
    constant PROD_W  : integer := WAVE_W + FB + 1;        -- s(WAVE_W) * u(FB+1)
    constant RND_X   : signed(FB downto 0) := shift_left(to_signed(1, FB + 1), FB - 1);  -- 2^(FB-1)

    -- stage 0 (combinational)
    signal u0      : std_logic_vector(ADC_W - 1 downto 0);
    signal clip0   : std_logic;
    signal rd_addr : std_logic_vector(WAVE_ADDR_W + 1 downto 0);
    -- stage 1
    signal word1   : std_logic_vector(2 * WAVE_W - 1 downto 0);
    signal frac1   : unsigned(FB - 1 downto 0);
    signal clip1   : std_logic;
    -- stage 2
    signal prod2   : signed(PROD_W - 1 downto 0);
    signal value2  : signed(WAVE_W - 1 downto 0);
    signal frac0r  : unsigned(FB - 1 downto 0);
    signal clip0r  : std_logic;
    signal word1r  : std_logic_vector(2 * WAVE_W - 1 downto 0);
    signal clip2   : std_logic;
    -- valid and sideband

begin

    -- ---- stage 0 (combinational): index --------------------------------------------------
    u0      <= (not adc(ADC_W - 1)) & adc(ADC_W - 2 downto 0);        -- adc + 2^(ADC_W-1)
    clip0   <= '1' when u0 = (u0'range => '0') or u0 = (u0'range => '1') else '0';
    rd_addr <= bank & branch & u0(ADC_W - 1 downto FB);

    -- ---- stage 1: table read ---------------------------------------------------------------
    u_table : entity work.fringe_table_ram
        generic map (
            ADDR_W    => WAVE_ADDR_W + 1,
            DATA_W    => 2 * WAVE_W,
            INIT_FILE => INIT_FILE
        )
        port map (
            clk     => clk,
            wr_en   => wr_en,
            wr_addr => wr_addr,
            wr_data => wr_data,
            rd_en   => ce,
            rd_addr => rd_addr,
            rd_data => word1
        );

    p_data : process (clk)
        variable sum2 : signed(WAVE_W + FB - 1 downto 0);
    begin
        if rising_edge(clk) then
            if ce = '1' then
                -- stage 1: table read; stage 1b: the RAM's output register
                frac0r <= unsigned(u0(FB - 1 downto 0));
                clip0r <= clip0;
                word1r <= word1;
                frac1  <= frac0r;
                clip1  <= clip0r;
                -- stage 2: slope * frac
                prod2  <= signed(word1r(2 * WAVE_W - 1 downto WAVE_W)) * signed('0' & frac1);
                value2 <= signed(word1r(WAVE_W - 1 downto 0));
                clip2  <= clip1;
                -- stage 3: ({value, 2^(FB-1)} + product) >>> FB = value + ((product + 2^(FB-1))
                -- >>> FB), one add, exact modulo 2^WAVE_W (x lies between two table values)
                sum2   := (value2 & RND_X(FB - 1 downto 0)) + prod2(FB + WAVE_W - 1 downto 0);
                x      <= std_logic_vector(sum2(WAVE_W + FB - 1 downto FB));
                clip   <= clip2;
            end if;
        end if;
    end process p_data;

    -- ---- valid (the only reset registers) and sideband, LATENCY stages ---------------------
    u_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W, DEPTH => LATENCY)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => in_user,
                  out_valid => out_valid, out_data => out_user);

end architecture rtl;
