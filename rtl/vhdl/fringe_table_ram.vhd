-- fringe_table_ram: two-bank table RAM, one write port, one registered read port.
--
-- VHDL-2008 twin of rtl/verilog/fringe_table_ram.v (same generics, ports and behaviour).
-- Simple dual-port RAM of 2 * 2^ADDR_W words of DATA_W bits, one clock. The address MSB
-- selects the bank: software writes the inactive bank while samples read the active one; the
-- top flips the bank between samples, so a sample never sees a mix of old and new tables.
--
-- Read:  rd_data <= mem(rd_addr) when rd_en (tie rd_en to the pipeline's ce). LATENCY = 1.
-- Write: mem(wr_addr) <= wr_data when wr_en (independent of rd_en).
-- A read of the word written in the same clock returns the old word in simulation; real
-- block RAMs differ by device, so callers never read the bank they write.
--
-- No reset on the array or on the read register (block-RAM inference). Initial contents:
-- INIT_FILE, the same $readmemh image as the Verilog (2 * 2^ADDR_W words, bank 0 then bank 1,
-- one hex word of ceil(DATA_W/4) digits per line, lines starting with "//" and empty lines
-- skipped), read with std.textio at elaboration; all zeros when INIT_FILE is "".

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
        assert ADDR_W >= 1 and ADDR_W <= 24
            report "fringe_table_ram: ADDR_W = " & integer'image(ADDR_W) & " out of range 1..24"
            severity failure;
        assert DATA_W >= 1 and DATA_W <= 64
            report "fringe_table_ram: DATA_W = " & integer'image(DATA_W) & " out of range 1..64"
            severity failure;
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
