-- fringe_delay: a valid bit and a data word delayed by DEPTH clock enables (the blocks' valid and
-- sideband pipelines). VHDL-2008 twin of rtl/verilog/fringe_delay.v. Document:
-- docs/blocks/fringe_delay.md.
--
-- LATENCY = DEPTH clock enables (ce = 1 cycles); DEPTH = 0 is a wire. ce = 0 freezes every stage;
-- rst (synchronous, active high, wins over ce) clears only the valid stages, never the data.

library ieee;
use ieee.std_logic_1164.all;
use work.fringe_pkg.all;

entity fringe_delay is
    generic (
        WIDTH : integer := 1;  -- data bits, >= 1
        DEPTH : integer := 1   -- stages (clock enables of delay), >= 0
    );
    port (
        clk       : in  std_logic;
        rst       : in  std_logic;                             -- synchronous: clears valid only
        ce        : in  std_logic;                             -- clock enable
        in_valid  : in  std_logic;
        in_data   : in  std_logic_vector(WIDTH - 1 downto 0);
        out_valid : out std_logic;
        out_data  : out std_logic_vector(WIDTH - 1 downto 0)
    );
end entity fringe_delay;

architecture rtl of fringe_delay is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_min("fringe_delay", "WIDTH", WIDTH, 1);
        check_min("fringe_delay", "DEPTH", DEPTH, 0);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

begin

    g_wire : if DEPTH = 0 generate
        out_valid <= in_valid;
        out_data  <= in_data;
    end generate g_wire;

    g_stages : if DEPTH > 0 generate
        -- stage k holds what came in k clock enables ago
        type data_sr_t is array (1 to DEPTH) of std_logic_vector(WIDTH - 1 downto 0);
        signal valid_sr : std_logic_vector(1 to DEPTH);
        signal data_sr  : data_sr_t;
    begin
        p_stages : process (clk)
        begin
            if rising_edge(clk) then
                if ce = '1' then
                    valid_sr <= in_valid & valid_sr(1 to DEPTH - 1);
                    data_sr  <= in_data & data_sr(1 to DEPTH - 1);
                end if;
                if rst = '1' then           -- wins over ce; the data stages are never cleared
                    valid_sr <= (others => '0');
                end if;
            end if;
        end process p_stages;

        out_valid <= valid_sr(DEPTH);
        out_data  <= data_sr(DEPTH);
    end generate g_stages;

end architecture rtl;
