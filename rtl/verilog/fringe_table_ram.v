// fringe_table_ram: two-bank table RAM, one write port, one registered read port.
//
// Simple dual-port RAM of 2 * 2^ADDR_W words of DATA_W bits, one clock. The address MSB
// selects the bank: software writes the inactive bank through the write port while samples
// read the active one; the top flips the bank between samples, so a sample never sees a mix
// of old and new tables.
//
// Read:  rd_data <= mem[rd_addr] when rd_en (tie rd_en to the pipeline's ce). LATENCY = 1.
// Write: mem[wr_addr] <= wr_data when wr_en (independent of rd_en).
// A read of the word written in the same clock returns the old word in simulation; real
// block RAMs differ by device, so callers never read the bank they write.
//
// Written for block-RAM inference (Yosys iCE40 / ECP5): no reset on the array or on the read
// register, no byte enables. Initial contents: INIT_FILE, a $readmemh file of 2 * 2^ADDR_W
// words (bank 0 then bank 1, one hex word per line, `//` comments allowed; give every word:
// the HDLs differ on missing ones), or all zeros when INIT_FILE is "".
//
// No rst/ce ports: the RAM holds no valid state; rd_en plays the role of ce.

`default_nettype none

module fringe_table_ram #(
    parameter integer ADDR_W    = 9,   // address bits of one bank, 1..24
    parameter integer DATA_W    = 36,  // word width, 1..64
    parameter         INIT_FILE = ""   // $readmemh image, 2*2^ADDR_W words; "" = zeros
) (
    input  wire              clk,
    // write port (software side)
    input  wire              wr_en,
    input  wire [ADDR_W:0]   wr_addr,   // {bank, address}
    input  wire [DATA_W-1:0] wr_data,
    // read port (sample side)
    input  wire              rd_en,     // tie to ce
    input  wire [ADDR_W:0]   rd_addr,   // {bank, address}
    output reg  [DATA_W-1:0] rd_data    // registered: valid one clock after rd_en
);

    localparam integer DEPTH = 2 << ADDR_W;  // both banks

    generate
        if (ADDR_W < 1 || ADDR_W > 24) begin : g_bad_addr_w
            $error("fringe_table_ram: ADDR_W = %0d out of range 1..24 (instance %m)", ADDR_W);
        end
        if (DATA_W < 1 || DATA_W > 64) begin : g_bad_data_w
            $error("fringe_table_ram: DATA_W = %0d out of range 1..64 (instance %m)", DATA_W);
        end
    endgenerate

    // no_rw_check: read-during-write to one address is a don't-care (callers never read the
    // bank they write), so Yosys maps to bare block RAM without collision bypass logic.
    (* no_rw_check *)
    reg [DATA_W-1:0] mem [0:DEPTH-1];

    // Two separate initial blocks: Yosys 0.23 loses the $readmemh image when a zeroing loop
    // precedes it in the same block.
    generate
        if (INIT_FILE != "") begin : g_init_file
            initial $readmemh(INIT_FILE, mem);
        end else begin : g_init_zero
            integer i;
            initial begin
                for (i = 0; i < DEPTH; i = i + 1) begin
                    mem[i] = {DATA_W{1'b0}};
                end
            end
        end
    endgenerate

    always @(posedge clk) begin
        if (wr_en) begin
            mem[wr_addr] <= wr_data;
        end
    end

    always @(posedge clk) begin
        if (rd_en) begin
            rd_data <= mem[rd_addr];
        end
    end

endmodule

`default_nettype wire
