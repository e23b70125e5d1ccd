// fringe_ram_ecp5: ECP5 technology layer of a table RAM read through its output register
// (DP16KD with REGMODE "OUTREG"). Verilog only, read by sim/synth.py for ECP5 (FRINGE_TECH_ECP5);
// simulators and other families use the generic code of fringe_table_ram / fringe_interp_table.
//
// rd_data = the word at rd_addr two clock enables (ce) earlier: the DP16KD's address register (CEB)
// and its output register (OCEB), the generic RAM read register and the caller's register after it.
// Yosys 0.70 maps an inferred RAM with REGMODE "NOREG" only (share/lattice/brams_map_16kd.v), whose
// clock-to-out is 5.83 ns on grade 6 against 0.96 ns with the output register.
//
// Tiling: 2^AW <= 512 words: DP16KD in its 512 x 36 mode, ceil(DW / 36) blocks; deeper: 1024 x 18,
// ceil(DW / 18) blocks per 1024 words (a row), the rows' outputs chosen after the output registers by
// the read address delayed alike. Initial contents: INITVAL_xx stay zero here (Yosys cannot read a file
// into a parameter); each block names its slice of INIT_FILE in attributes and sim/synth.py writes
// the INITVALs into the netlist (fill_ecp5_initvals), the layout Yosys's own mapping uses.

`default_nettype none

module fringe_ram_ecp5 #(
    parameter integer AW         = 9,   // address bits, >= 1
    parameter integer DW         = 36,  // word width, >= 1
    /* verilator lint_off UNUSEDPARAM */   // read by sim/synth.py through the blocks' attributes
    parameter         INIT_FILE  = "",  // $readmemh image; "" = zeros
    parameter integer INIT_FIRST = 0    // the image word at address 0 (a RAM piece's slice)
    /* verilator lint_on UNUSEDPARAM */
) (
    input  wire          clk,
    input  wire          wr_en,
    input  wire [AW-1:0] wr_addr,
    input  wire [DW-1:0] wr_data,
    input  wire          ce,        // the read's clock enable: address and output registers
    input  wire [AW-1:0] rd_addr,
    output wire [DW-1:0] rd_data    // two clock enables after rd_addr
);

    localparam integer MODE = (AW <= 9) ? 36 : 18;                // data bits per block
    localparam integer BAW  = (MODE == 36) ? 9 : 10;               // address bits per block
    localparam integer RW   = (AW > BAW) ? AW - BAW : 0;           // row-select bits
    localparam integer ROWS = 1 << RW;
    localparam integer COLS = (DW + MODE - 1) / MODE;
    localparam integer PDW  = COLS * MODE;

    generate
        if (AW < 1 || DW < 1) begin : g_bad
            $error("fringe_ram_ecp5: AW = %0d, DW = %0d must be >= 1 (instance %m)", AW, DW);
        end
    endgenerate

    wire [PDW-1:0]      wd = {{(PDW-DW){1'b0}}, wr_data};
    wire [ROWS*PDW-1:0] q;
    localparam integer LAW  = (AW < BAW) ? AW : BAW;              // address bits inside a block
    wire [13:0]         wa = {{(14-LAW){1'b0}}, wr_addr[LAW-1:0]} << (14 - BAW);
    wire [13:0]         ra = {{(14-LAW){1'b0}}, rd_addr[LAW-1:0]} << (14 - BAW);
    wire                unused_lo = &{1'b0, wa[3:0], ra[3:0]};     // byte enables / zeros there

    genvar gr, gc;
    generate
        for (gr = 0; gr < ROWS; gr = gr + 1) begin : g_row
            wire we;
            if (RW > 0) begin : g_sel
                assign we = wr_en && (wr_addr[AW-1:BAW] == gr);
            end else begin : g_one
                assign we = wr_en;
            end
            for (gc = 0; gc < COLS; gc = gc + 1) begin : g_col
                wire [35:0] di, dout;
                if (MODE == 36) begin : g_36
                    assign di = wd[gc*36 +: 36];
                end else begin : g_18
                    assign di = {18'd0, wd[gc*18 +: 18]};
                end
                // read by sim/synth.py: the block's words are image words
                // INIT_FIRST + row * 2^BAW + (0 .. 2^BAW - 1), bits col * MODE .. + MODE - 1
                (* fringe_init_file = INIT_FILE, fringe_init_first = INIT_FIRST + (gr << BAW),
                   fringe_init_words = (1 << LAW), fringe_init_bit = gc * MODE,
                   fringe_init_width = MODE, fringe_init_dw = DW *)
                DP16KD #(
                    .DATA_WIDTH_A(MODE), .DATA_WIDTH_B(MODE),
                    .REGMODE_A((MODE == 36) ? "OUTREG" : "NOREG"), .REGMODE_B("OUTREG"),
                    .RESETMODE("SYNC"), .ASYNC_RESET_RELEASE("SYNC"),
                    .CSDECODE_A("0b000"), .CSDECODE_B("0b000"),
                    .WRITEMODE_A("NORMAL"), .WRITEMODE_B("NORMAL"), .GSR("AUTO")
                ) u_ram (
                    // port A writes (36 mode: the byte enables ADA0..3 are the write enables)
                    .CLKA(clk), .CEA(1'b1), .OCEA(ce), .RSTA(1'b0),
                    .WEA((MODE == 36) ? 1'b1 : we),
                    .CSA0(1'b0), .CSA1(1'b0), .CSA2(1'b0),
                    .ADA0(we), .ADA1(we), .ADA2((MODE == 36) ? we : 1'b0), .ADA3((MODE == 36) ? we : 1'b0),
                    .ADA4(wa[4]), .ADA5(wa[5]), .ADA6(wa[6]), .ADA7(wa[7]), .ADA8(wa[8]), .ADA9(wa[9]),
                    .ADA10(wa[10]), .ADA11(wa[11]), .ADA12(wa[12]), .ADA13(wa[13]),
                    .DIA0(di[0]), .DIA1(di[1]), .DIA2(di[2]), .DIA3(di[3]), .DIA4(di[4]), .DIA5(di[5]),
                    .DIA6(di[6]), .DIA7(di[7]), .DIA8(di[8]), .DIA9(di[9]), .DIA10(di[10]), .DIA11(di[11]),
                    .DIA12(di[12]), .DIA13(di[13]), .DIA14(di[14]), .DIA15(di[15]), .DIA16(di[16]), .DIA17(di[17]),
                    .DOA0(dout[0]), .DOA1(dout[1]), .DOA2(dout[2]), .DOA3(dout[3]), .DOA4(dout[4]), .DOA5(dout[5]),
                    .DOA6(dout[6]), .DOA7(dout[7]), .DOA8(dout[8]), .DOA9(dout[9]), .DOA10(dout[10]),
                    .DOA11(dout[11]), .DOA12(dout[12]), .DOA13(dout[13]), .DOA14(dout[14]), .DOA15(dout[15]),
                    .DOA16(dout[16]), .DOA17(dout[17]),
                    // port B reads (36 mode: the high half of the write data on DIB, of the read on DOB)
                    .CLKB(clk), .CEB(ce), .OCEB(ce), .RSTB(1'b0), .WEB(1'b0),
                    .CSB0(1'b0), .CSB1(1'b0), .CSB2(1'b0),
                    .ADB0(1'b0), .ADB1(1'b0), .ADB2(1'b0), .ADB3(1'b0),
                    .ADB4(ra[4]), .ADB5(ra[5]), .ADB6(ra[6]), .ADB7(ra[7]), .ADB8(ra[8]), .ADB9(ra[9]),
                    .ADB10(ra[10]), .ADB11(ra[11]), .ADB12(ra[12]), .ADB13(ra[13]),
                    .DIB0(di[18]), .DIB1(di[19]), .DIB2(di[20]), .DIB3(di[21]), .DIB4(di[22]), .DIB5(di[23]),
                    .DIB6(di[24]), .DIB7(di[25]), .DIB8(di[26]), .DIB9(di[27]), .DIB10(di[28]), .DIB11(di[29]),
                    .DIB12(di[30]), .DIB13(di[31]), .DIB14(di[32]), .DIB15(di[33]), .DIB16(di[34]), .DIB17(di[35]),
                    .DOB0(dout[18]), .DOB1(dout[19]), .DOB2(dout[20]), .DOB3(dout[21]), .DOB4(dout[22]),
                    .DOB5(dout[23]), .DOB6(dout[24]), .DOB7(dout[25]), .DOB8(dout[26]), .DOB9(dout[27]),
                    .DOB10(dout[28]), .DOB11(dout[29]), .DOB12(dout[30]), .DOB13(dout[31]), .DOB14(dout[32]),
                    .DOB15(dout[33]), .DOB16(dout[34]), .DOB17(dout[35])
                );
                if (MODE == 36) begin : g_q36
                    assign q[gr*PDW + gc*36 +: 36] = dout;
                end else begin : g_q18
                    assign q[gr*PDW + gc*18 +: 18] = dout[35:18];
                end
            end
        end

        if (RW > 0) begin : g_rows
            // the row of the word in the output registers: the read address's row, delayed alike
            reg [RW-1:0] row1, row2;
            always @(posedge clk) begin
                if (ce) begin
                    row1 <= rd_addr[AW-1:BAW];
                    row2 <= row1;
                end
            end
            assign rd_data = q[row2 * PDW +: DW];
        end else begin : g_one_row
            assign rd_data = q[DW-1:0];
        end
    endgenerate

endmodule

`default_nettype wire
