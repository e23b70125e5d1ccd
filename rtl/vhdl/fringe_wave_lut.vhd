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
        check_range("fringe_wave_lut", "ADC_W", ADC_W, 4, 24);
        assert WAVE_ADDR_W >= 2 and WAVE_ADDR_W <= ADC_W - 1
            report "fringe_wave_lut: WAVE_ADDR_W = " & integer'image(WAVE_ADDR_W)
                   & " out of range 2..ADC_W-1 = " & integer'image(ADC_W - 1)
            severity failure;
        check_range("fringe_wave_lut", "WAVE_W", WAVE_W, 8, 32);
        check_min("fringe_wave_lut", "USER_W", USER_W, 1);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant LATENCY : integer := WAVE_LUT_LATENCY;
    constant FB      : integer := ADC_W - WAVE_ADDR_W;   -- fraction bits of the index, >= 1

    signal u0      : std_logic_vector(ADC_W - 1 downto 0);
    signal clip0   : std_logic;
    signal rd_addr : std_logic_vector(WAVE_ADDR_W + 1 downto 0);
    signal side_in, side_out : std_logic_vector(USER_W downto 0);   -- {clip, user}

begin

    -- ---- stage 0 (combinational): index --------------------------------------------------
    u0      <= (not adc(ADC_W - 1)) & adc(ADC_W - 2 downto 0);        -- adc + 2^(ADC_W-1)
    clip0   <= '1' when u0 = (u0'range => '0') or u0 = (u0'range => '1') else '0';
    rd_addr <= bank & branch & u0(ADC_W - 1 downto FB);

    -- ---- stages 1..4: x = value + ((slope * frac + 2^(FB-1)) >>> FB) --------------------------
    -- Exact modulo 2^WAVE_W: x lies between value[k] and value[k+1].
    u_table : entity work.fringe_interp_table
        generic map (ADDR_W => WAVE_ADDR_W + 1, W => WAVE_W, FB => FB, OUT_W => WAVE_W, ROUND_SHIFT => 0,
                     INIT_FILE => INIT_FILE)
        port map (clk => clk, ce => ce, wr_en => wr_en, wr_addr => wr_addr, wr_data => wr_data,
                  rd_addr => rd_addr, frac => u0(FB - 1 downto 0), result => x);

    -- ---- valid (the only reset registers), clip and sideband, LATENCY stages -------------------
    u_valid : entity work.fringe_delay
        generic map (WIDTH => USER_W + 1, DEPTH => LATENCY)
        port map (clk => clk, rst => rst, ce => ce, in_valid => in_valid, in_data => side_in,
                  out_valid => out_valid, out_data => side_out);
    side_in  <= clip0 & in_user;
    clip     <= side_out(USER_W);
    out_user <= side_out(USER_W - 1 downto 0);

end architecture rtl;
