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
use std.textio.all;

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
    constant HEX_W  : integer := 4 * ((DATA_W + 3) / 4);   -- word rounded up to hex digits

    type mem_t is array (0 to DEPTH - 1) of std_logic_vector(DATA_W - 1 downto 0);
    type mem_ptr_t is access mem_t;

    -- Reads a $readmemh image: one word per line, "//" comment lines and empty lines skipped.
    impure function init_mem(fname : string) return mem_t is
        file     f    : text;
        variable l    : line;
        -- On the heap: a large table as a plain variable exceeds GHDL's stack limit.
        variable m    : mem_ptr_t := new mem_t'(others => (others => '0'));
        variable w    : std_logic_vector(HEX_W - 1 downto 0);
        variable good : boolean;
        variable n    : integer := 0;
        variable ch   : character;
        variable stat : file_open_status;
    begin
        if fname'length = 0 then
            return m.all;
        end if;
        file_open(stat, f, fname, read_mode);
        assert stat = open_ok
            report "fringe_table_ram: cannot open INIT_FILE """ & fname & """"
            severity failure;
        while not endfile(f) and n < DEPTH loop
            readline(f, l);
            -- skip leading blanks
            while l'length > 0 loop
                exit when l(l'left) /= ' ' and l(l'left) /= HT;
                read(l, ch);
            end loop;
            if l'length = 0 then
                next;
            end if;
            if l'length >= 2 then
                if l(l'left to l'left + 1) = "//" then
                    next;
                end if;
            end if;
            hread(l, w, good);
            assert good
                report "fringe_table_ram: INIT_FILE """ & fname & """ word " & integer'image(n)
                       & " is not a hex number of " & integer'image(HEX_W / 4) & " digits"
                severity failure;
            m(n) := w(DATA_W - 1 downto 0);
            n    := n + 1;
        end loop;
        file_close(f);
        return m.all;
    end function init_mem;

    signal mem : mem_t := init_mem(INIT_FILE);

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
