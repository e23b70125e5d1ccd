-- fringe_pkg: what every fringe block shares, VHDL-2008 (twin: rtl/verilog/fringe_pkg.vh).
--
-- Integer arithmetic for widths (clog2, bit_width: no real log2), the exact reciprocal-mapping
-- check of fringe_long_period and fringe_trim, rounding and saturation helpers, the reader of the
-- $readmemh images (fringe_table_ram, the register file), and the constants generated from the
-- Python single source (register map, address spaces, status bits, block latencies).

library ieee;
use ieee.std_logic_1164.all;
use ieee.numeric_std.all;
use std.textio.all;

package fringe_pkg is

    -- ceil(log2(v)), 0 for v <= 1 (as Verilog's $clog2)
    function clog2(v : natural) return natural;
    -- bits of the unsigned number v, at least 1
    function bit_width(v : natural) return positive;
    -- trailing zero bits of v >= 1 (its 2-adic valuation)
    function trailing_zeros(v : positive) return natural;

    -- True when floor(p * recip / 2^shift) = floor(p * 2^addr_w / REV) for every position
    -- 0 <= p < REV = lines * 2^fine_w (Granlund-Montgomery bound, model:
    -- fringe.fixed.long_period.mapping_ok): with E = recip * REV - 2^(addr_w + shift) and
    -- 2^G = gcd(2^addr_w, REV), E >= 0 and (REV - 1) * E < 2^(G + shift). 256-bit arithmetic.
    function mapping_exact(recip, shift, addr_w, lines, fine_w : natural) return boolean;

    -- The generic checks of every block (called in its generics_ok, at elaboration): fail with
    -- "<unit>: <name> = <v> out of range <lo>..<hi>" / "<unit>: <name> = <v> must be >= <lo>";
    -- hi_text, when given, is printed for hi ("2^20").
    procedure check_range(unit, name : string; v, lo, hi : integer; hi_text : string := "");
    procedure check_min(unit, name : string; v, lo : integer);
    -- The position checks of the blocks that count in REV = LINES * 2^FINE_W (period count, long
    -- period, trim): FINE_W 8..30, LINES 1..2^20, POS_W = FINE_W + clog2(LINES) <= pos_w_max
    procedure check_position(unit : string; fine_w, lines, pos_w_max : integer);
    -- The checks of the drift tracker's halves, fringe_drift_normaliser and fringe_drift_observer (the
    -- model's check_state_params and check_observer_params): the state and the block (ADC_W, BLOCK_LOG2,
    -- OFS_FRAC, ADC_W + OFS_FRAC <= 32, GINV_W, HOLD), and the observer's own (FINE_W, MU_LOG2, FWD_W,
    -- TABLE_W, TABLE_FRAC, KG_W, KG_SHIFT)
    procedure check_drift_state(unit : string; adc_w, block_log2, ofs_frac, ginv_w, hold : integer);
    procedure check_drift_observer(unit : string; fine_w, mu_log2, fwd_w, table_w, table_frac, kg_w, kg_shift : integer);
    -- mapping_exact, or fail with "<unit>: <prefix>_RECIP = .., <prefix>_SHIFT = .. do not map every
    -- position to floor(pos * 2^<addr_name> / REV); take them from <helper>()"
    procedure check_mapping(unit, prefix, addr_name, helper : string; recip, shift, addr_w, lines, fine_w : natural);

    -- 2^(k-1) as s(w), the rounding constant of (v + 2^(k-1)) >>> k; 0 when k = 0
    function round_half(w, k : natural) return signed;
    -- v saturated to s(w) (v at least w bits wide)
    function saturate(v : signed; w : positive) return signed;
    -- v outside s(w): the bits from w-1 up are not all equal to the sign
    function outside(v : signed; w : positive) return boolean;
    -- x mod M from three candidates computed in parallel, two's complement of one width (the top bit
    -- the sign; unsigned: a sum held in unsigned bits): mid = x, up = x + M, down = x - M for
    -- -M <= x < 2M: up when mid < 0, down when down >= 0, else mid
    function wrapped(mid, up, down : signed) return signed;
    function wrapped(mid, up, down : unsigned) return unsigned;

    -- Words of a $readmemh image, as fringe_table_ram and the register file hold them.
    type word_array is array (natural range <>) of std_logic_vector;
    -- Words first .. first + depth - 1 of the image `fname` (one hex word of ceil(width/4) digits per
    -- line, "//" comment lines and empty lines skipped; missing words are 0); all zeros when fname is "".
    -- `what` names the file in the failure messages ("fringe_table_ram: INIT_FILE"). A RAM piece reads
    -- its own slice (first > 0), so it holds depth words, not the whole image.
    impure function read_memh(fname : string; depth, width : positive; what : string;
                              first : natural := 0) return word_array;

    -- LATENCY of fringe_core and fringe_top (trim, drift, cancel: the TRIM, DRIFT and CANCEL generics, 0 or
    -- 1): the input registers and the blocks in the chain, from the generated block latencies below
    function core_latency(cordic_stages, trim, drift, cancel : natural) return natural;

    -- BEGIN generated constants (written by python sim/hdlgen.py; do not edit)
    constant REG_W                   : integer := 32;  -- bits per register word
    constant N_REGS                  : integer := 32;  -- register words per bank
    constant REG_INDEX_W             : integer := 5;  -- bits of a register's index in its bank
    constant REG_K_SS                : integer := 0;  -- s(COEF_W)
    constant REG_K_SC                : integer := 1;  -- s(COEF_W)
    constant REG_K_CC                : integer := 2;  -- s(COEF_W)
    constant REG_OFS_S               : integer := 3;  -- s(WAVE_W)
    constant REG_OFS_C               : integer := 4;  -- s(WAVE_W)
    constant REG_MID_S               : integer := 5;  -- s(ADC_W+1)
    constant REG_THR_HI_S            : integer := 6;  -- s(ADC_W+1)
    constant REG_THR_LO_S            : integer := 7;  -- s(ADC_W+1)
    constant REG_MID_C               : integer := 8;  -- s(ADC_W+1)
    constant REG_THR_HI_C            : integer := 9;  -- s(ADC_W+1)
    constant REG_THR_LO_C            : integer := 10;  -- s(ADC_W+1)
    constant REG_COARSE_OFS          : integer := 11;  -- s(POS_W+1)
    constant REG_ZERO                : integer := 12;  -- u(POS_W)
    constant REG_DIR                 : integer := 13;  -- u(1)
    constant REG_AMP_LOW             : integer := 14;  -- u(WAVE_W+1)
    constant REG_AMP_HIGH            : integer := 15;  -- u(WAVE_W+1)
    constant REG_W0_S                : integer := 16;  -- s(ADC_W+DRIFT_TABLE_FRAC)
    constant REG_W0_C                : integer := 17;  -- s(ADC_W+DRIFT_TABLE_FRAC)
    constant REG_KG_S                : integer := 18;  -- u(DRIFT_KG_W)
    constant REG_KG_C                : integer := 19;  -- u(DRIFT_KG_W)
    constant REG_CANCEL_FREQ         : integer := 20;  -- u(32)
    constant CTRL_WORD               : integer := 128;  -- register-space word of CTRL
    constant CTRL_SWAP               : integer := 0;  -- CTRL bit: 1 swaps the banks
    constant SPACE_LSB               : integer := 16;  -- cfg_wr_addr bit where the address space starts
    constant SPACE_REGS              : integer := 0;  -- cfg_wr_addr[19:16] of the regs image
    constant SPACE_WAVE_SIN          : integer := 1;  -- cfg_wr_addr[19:16] of the wave_sin image
    constant SPACE_WAVE_COS          : integer := 2;  -- cfg_wr_addr[19:16] of the wave_cos image
    constant SPACE_LONG_PERIOD       : integer := 3;  -- cfg_wr_addr[19:16] of the long_period image
    constant SPACE_TRIM_MAP          : integer := 4;  -- cfg_wr_addr[19:16] of the trim_map image
    constant SPACE_TRIM_SPEED        : integer := 5;  -- cfg_wr_addr[19:16] of the trim_speed image
    constant SPACE_TRIM_AMP          : integer := 6;  -- cfg_wr_addr[19:16] of the trim_amp image
    constant SPACE_DRIFT_FWD_SIN     : integer := 7;  -- cfg_wr_addr[19:16] of the drift_fwd_sin image
    constant SPACE_DRIFT_FWD_COS     : integer := 8;  -- cfg_wr_addr[19:16] of the drift_fwd_cos image
    constant STATUS_W                : integer := 8;  -- bits of the status word
    constant STATUS_CLIP_SIN         : integer := 0;  -- status bit
    constant STATUS_CLIP_COS         : integer := 1;  -- status bit
    constant STATUS_AMP_LOW          : integer := 2;  -- status bit
    constant STATUS_AMP_HIGH         : integer := 3;  -- status bit
    constant STATUS_OVERSPEED        : integer := 4;  -- status bit
    constant STATUS_COARSE_ERR       : integer := 5;  -- status bit
    constant STATUS_SATURATED        : integer := 6;  -- status bit
    constant STATUS_BANK             : integer := 7;  -- status bit
    constant CORE_INPUT_LATENCY      : integer := 2;  -- fringe_core input registers
    constant WAVE_LUT_LATENCY        : integer := 4;  -- fringe_wave_lut
    constant QUADRATURE_LATENCY      : integer := 5;  -- fringe_quadrature
    constant CORDIC_LATENCY_BASE     : integer := 2;  -- fringe_cordic: STAGES + this
    constant CORDIC_ITER_CLOCKS_BASE : integer := 0;  -- fringe_cordic ITERATIVE = 1: a sample every STAGES + this clock enables
    constant PERIOD_COUNT_LATENCY    : integer := 4;  -- fringe_period_count
    constant TRIM_LATENCY            : integer := 13;  -- fringe_trim
    constant LONG_PERIOD_LATENCY     : integer := 8;  -- fringe_long_period
    constant DRIFT_NORM_LATENCY      : integer := 5;  -- fringe_drift_normaliser
    constant DRIFT_OBS_LATENCY       : integer := 16;  -- fringe_drift_observer
    constant DRIFT_SWEEP_MIN_LOG2    : integer := 4;  -- fringe_drift_observer: a block that swept 2^-this of a period updates
    constant DRIFT_PARTIAL_MU_MIN    : integer := 2;  -- fringe_drift_observer: ... if MU_LOG2 is at least this
    constant CANCEL_LATENCY          : integer := 4;  -- fringe_canceller
    constant CANCEL_ADAPT_LATENCY    : integer := 15;  -- fringe_canceller: a block's last sample to its update in place
    -- END generated constants

end package fringe_pkg;

package body fringe_pkg is

    function clog2(v : natural) return natural is
        variable b : natural := 0;
    begin
        while b < 31 and 2 ** b < v loop
            b := b + 1;
        end loop;
        return b;
    end function clog2;

    function bit_width(v : natural) return positive is
        variable b : positive := 1;
    begin
        while b < 31 and 2 ** b <= v loop
            b := b + 1;
        end loop;
        return b;
    end function bit_width;

    function trailing_zeros(v : positive) return natural is
        variable r : positive := v;
        variable k : natural  := 0;
    begin
        while r mod 2 = 0 loop
            r := r / 2;
            k := k + 1;
        end loop;
        return k;
    end function trailing_zeros;

    function mapping_exact(recip, shift, addr_w, lines, fine_w : natural) return boolean is
        variable rev_x, prod, pw, e, lhs, rhs : unsigned(255 downto 0);
        variable g_log : natural;
    begin
        if lines = 0 or recip = 0 then
            return false;
        end if;
        g_log := minimum(addr_w, fine_w + trailing_zeros(lines));
        rev_x := shift_left(to_unsigned(lines, 256), fine_w);
        prod  := resize(to_unsigned(recip, 256) * rev_x, 256);
        pw    := shift_left(to_unsigned(1, 256), addr_w + shift);
        if prod < pw then
            return false;
        end if;
        e   := prod - pw;
        lhs := resize((rev_x - 1) * e, 256);
        rhs := shift_left(to_unsigned(1, 256), g_log + shift);
        return lhs < rhs;
    end function mapping_exact;

    procedure check_range(unit, name : string; v, lo, hi : integer; hi_text : string := "") is
    begin
        if hi_text'length > 0 then
            assert v >= lo and v <= hi
                report unit & ": " & name & " = " & integer'image(v) & " out of range "
                       & integer'image(lo) & ".." & hi_text
                severity failure;
        else
            assert v >= lo and v <= hi
                report unit & ": " & name & " = " & integer'image(v) & " out of range "
                       & integer'image(lo) & ".." & integer'image(hi)
                severity failure;
        end if;
    end procedure check_range;

    procedure check_min(unit, name : string; v, lo : integer) is
    begin
        assert v >= lo
            report unit & ": " & name & " = " & integer'image(v) & " must be >= " & integer'image(lo)
            severity failure;
    end procedure check_min;

    procedure check_position(unit : string; fine_w, lines, pos_w_max : integer) is
    begin
        check_range(unit, "FINE_W", fine_w, 8, 30);
        check_range(unit, "LINES", lines, 1, 2**20, "2^20");
        assert fine_w + clog2(lines) <= pos_w_max
            report unit & ": POS_W = FINE_W + clog2(LINES) = " & integer'image(fine_w + clog2(lines))
                   & " exceeds " & integer'image(pos_w_max)
            severity failure;
    end procedure check_position;

    procedure check_drift_state(unit : string; adc_w, block_log2, ofs_frac, ginv_w, hold : integer) is
    begin
        check_range(unit, "ADC_W", adc_w, 4, 24);
        check_range(unit, "BLOCK_LOG2", block_log2, 4, 12);
        check_range(unit, "OFS_FRAC", ofs_frac, 0, 8);
        assert adc_w + ofs_frac <= 32
            report unit & ": ADC_W + OFS_FRAC = " & integer'image(adc_w + ofs_frac) & " exceeds 32"
            severity failure;
        check_range(unit, "GINV_W", ginv_w, 8, 24);
        check_range(unit, "HOLD", hold, 0, 1);
    end procedure check_drift_state;

    procedure check_drift_observer(unit : string; fine_w, mu_log2, fwd_w, table_w, table_frac, kg_w, kg_shift : integer) is
    begin
        check_range(unit, "FINE_W", fine_w, 8, 30);
        check_range(unit, "MU_LOG2", mu_log2, 0, 8);
        assert fwd_w >= 2 and fwd_w <= minimum(10, fine_w - 1)
            report unit & ": FWD_W = " & integer'image(fwd_w) & " out of range 2..min(10, FINE_W-1) = "
                   & integer'image(minimum(10, fine_w - 1))
            severity failure;
        check_range(unit, "TABLE_W", table_w, 8, 24);
        check_range(unit, "TABLE_FRAC", table_frac, 0, 12);
        check_range(unit, "KG_W", kg_w, 8, 24);
        check_range(unit, "KG_SHIFT", kg_shift, 1, 60);
    end procedure check_drift_observer;

    procedure check_mapping(unit, prefix, addr_name, helper : string; recip, shift, addr_w, lines, fine_w : natural) is
    begin
        assert mapping_exact(recip, shift, addr_w, lines, fine_w)
            report unit & ": " & prefix & "_RECIP = " & integer'image(recip) & ", " & prefix & "_SHIFT = "
                   & integer'image(shift) & " do not map every position to floor(pos * 2^" & addr_name & " / REV);"
                   & " take them from " & helper & "()"
            severity failure;
    end procedure check_mapping;

    function round_half(w, k : natural) return signed is
    begin
        if k = 0 then
            return to_signed(0, w);
        end if;
        return shift_left(to_signed(1, w), k - 1);
    end function round_half;

    function saturate(v : signed; w : positive) return signed is
        constant MX : signed(w - 1 downto 0) := '0' & (w - 2 downto 0 => '1');
        constant MN : signed(w - 1 downto 0) := '1' & (w - 2 downto 0 => '0');
    begin
        if v > resize(MX, v'length) then
            return MX;
        elsif v < resize(MN, v'length) then
            return MN;
        end if;
        return resize(v, w);
    end function saturate;

    function wrapped(mid, up, down : signed) return signed is
    begin
        if mid(mid'high) = '1' then
            return up;
        elsif down(down'high) = '0' then
            return down;
        end if;
        return mid;
    end function wrapped;

    function wrapped(mid, up, down : unsigned) return unsigned is
    begin
        return unsigned(wrapped(signed(mid), signed(up), signed(down)));
    end function wrapped;

    function outside(v : signed; w : positive) return boolean is
        variable top : signed(v'length - w downto 0);
    begin
        top := v(v'high downto v'low + w - 1);
        return not (top = (top'range => '0') or top = (top'range => '1'));
    end function outside;

    function core_latency(cordic_stages, trim, drift, cancel : natural) return natural is
    begin
        return CORE_INPUT_LATENCY + WAVE_LUT_LATENCY + QUADRATURE_LATENCY + cordic_stages + CORDIC_LATENCY_BASE
               + PERIOD_COUNT_LATENCY + LONG_PERIOD_LATENCY + trim * TRIM_LATENCY + drift * DRIFT_NORM_LATENCY
               + cancel * CANCEL_LATENCY;
    end function core_latency;

    impure function read_memh(fname : string; depth, width : positive; what : string;
                              first : natural := 0) return word_array is
        constant HEX_W : positive := 4 * ((width + 3) / 4);   -- a word rounded up to hex digits
        subtype image_t is word_array(0 to depth - 1)(width - 1 downto 0);
        type image_ptr_t is access image_t;
        file     f    : text;
        variable l    : line;
        -- On the heap: a large table as a plain variable exceeds GHDL's stack limit.
        variable m    : image_ptr_t := new image_t'(others => (others => '0'));
        variable w    : std_logic_vector(HEX_W - 1 downto 0);
        variable good : boolean;
        variable n    : natural := 0;
        variable ch   : character;
        variable stat : file_open_status;
    begin
        if fname'length = 0 then
            return m.all;
        end if;
        file_open(stat, f, fname, read_mode);
        assert stat = open_ok
            report what & ": cannot open """ & fname & """" severity failure;
        while not endfile(f) and n < first + depth loop
            readline(f, l);
            while l'length > 0 loop                           -- skip leading blanks
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
                report what & " """ & fname & """ word " & integer'image(n) & " is not a hex number of "
                       & integer'image(HEX_W / 4) & " digits"
                severity failure;
            if n >= first then
                m(n - first) := w(width - 1 downto 0);
            end if;
            n := n + 1;
        end loop;
        file_close(f);
        return m.all;
    end function read_memh;

end package body fringe_pkg;
