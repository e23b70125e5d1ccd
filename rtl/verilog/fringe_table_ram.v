// fringe_table_ram: two-bank table RAM, one write port, one registered read port.
//
// LATENCY = 1 clock (rd_en); no rst/ce ports (rd_en plays the role of ce).
// Parameters, ports, arithmetic and pipeline: docs/blocks/fringe_table_ram.md.
// Bit-exact model: model/fringe/fixed/table_ram.py (the image format).

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

    `include "fringe_pkg.vh"

    localparam integer DEPTH = 2 << ADDR_W;  // both banks

    generate
        `FRINGE_CHECK_RANGE(g_bad_addr_w, "fringe_table_ram", "ADDR_W", ADDR_W, 1, 24)
        `FRINGE_CHECK_RANGE(g_bad_data_w, "fringe_table_ram", "DATA_W", DATA_W, 1, 64)
    endgenerate

    // no_rw_check: read-during-write to one address is a don't-care (callers never read the
    // bank they write), so Yosys maps to bare block RAM without collision bypass logic.
    (* no_rw_check *)
    reg [DATA_W-1:0] mem [0:DEPTH-1];

    generate
        `FRINGE_MEM_INIT(INIT_FILE, mem, DEPTH, DATA_W)
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
