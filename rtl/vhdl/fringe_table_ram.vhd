-- fringe_table_ram: two-bank table RAM, one write port, one registered read port.
--
-- VHDL-2008 twin of rtl/verilog/fringe_table_ram.v (same generics, ports and behaviour).
-- LATENCY = 1 clock (rd_en); no rst/ce ports (rd_en plays the role of ce).
-- Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_table_ram.md.
-- Bit-exact model: model/fringe/fixed/table_ram.py (the image format).

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use work.fringe_pkg.all;

entity fringe_table_ram is
    generic (
        ADDR_W    : integer := 9;    -- address bits of one bank, 1..24
        DATA_W    : integer := 36;   -- word width, 1..64
        INIT_FILE : string  := ""    -- $readmemh image, 2*2^ADDR_W words; "" = zeros
    );
    port (
        clk     : in  std_logic;
        -- write port (software side)
        wr_en   : in  std_logic;
        wr_addr : in  std_logic_vector(ADDR_W downto 0);   -- {bank, address}
        wr_data : in  std_logic_vector(DATA_W - 1 downto 0);
        -- read port (sample side)
        rd_en   : in  std_logic;                           -- tie to ce
        rd_addr : in  std_logic_vector(ADDR_W downto 0);   -- {bank, address}
        rd_data : out std_logic_vector(DATA_W - 1 downto 0) -- registered
    );
end entity fringe_table_ram;

architecture rtl of fringe_table_ram is

    -- Stops elaboration with a clear message on illegal generics (before anything is sized).
    function generics_ok return boolean is
    begin
        check_range("fringe_table_ram", "ADDR_W", ADDR_W, 1, 24);
        check_range("fringe_table_ram", "DATA_W", DATA_W, 1, 64);
        return true;
    end function generics_ok;
    constant GENERICS_CHECKED : boolean := generics_ok;

    constant DEPTH  : integer := 2 * 2 ** ADDR_W;          -- both banks
    subtype mem_t is word_array(0 to DEPTH - 1)(DATA_W - 1 downto 0);

    signal mem : mem_t := read_memh(INIT_FILE, DEPTH, DATA_W, "fringe_table_ram: INIT_FILE");

begin

    p_ram : process (clk)
    begin
        if rising_edge(clk) then
            if wr_en = '1' then
                mem(to_integer(unsigned(wr_addr))) <= wr_data;
            end if;
            if rd_en = '1' then
                rd_data <= mem(to_integer(unsigned(rd_addr)));
            end if;
        end if;
    end process p_ram;

end architecture rtl;
