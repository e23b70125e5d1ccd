// fringe_delay: a valid bit and a data word delayed by DEPTH clock enables (the blocks' valid and
// sideband pipelines). Document: docs/blocks/fringe_delay.md.
//
// LATENCY = DEPTH clock enables (ce = 1 cycles); DEPTH = 0 is a wire. ce = 0 freezes every stage;
// rst (synchronous, active high, wins over ce) clears only the valid stages, never the data.

`default_nettype none

module fringe_delay #(
    parameter integer WIDTH = 1,  // data bits, >= 1
    parameter integer DEPTH = 1   // stages (clock enables of delay), >= 0
) (
    input  wire             clk,
    input  wire             rst,       // synchronous, active high: clears valid only
    input  wire             ce,        // clock enable: the stages advance when 1
    input  wire             in_valid,
    input  wire [WIDTH-1:0] in_data,
    output wire             out_valid,
    output wire [WIDTH-1:0] out_data
);

    generate
        if (WIDTH < 1) begin : g_bad_width
            $error("fringe_delay: WIDTH = %0d must be >= 1 (instance %m)", WIDTH);
        end
        if (DEPTH < 0) begin : g_bad_depth
            $error("fringe_delay: DEPTH = %0d must be >= 0 (instance %m)", DEPTH);
        end

        if (DEPTH == 0) begin : g_wire
            assign out_valid = in_valid;
            assign out_data  = in_data;
            wire unused_ctrl = &{1'b0, clk, rst, ce};
        end else begin : g_stages
            // stage k holds what came in k + 1 clock enables ago
            reg [DEPTH-1:0]       valid_sr;
            reg [DEPTH*WIDTH-1:0] data_sr;
            integer k;

            always @(posedge clk) begin
                if (ce) begin
                    valid_sr[0]         <= in_valid;
                    data_sr[0 +: WIDTH] <= in_data;
                    for (k = 1; k < DEPTH; k = k + 1) begin
                        valid_sr[k]               <= valid_sr[k-1];
                        data_sr[k*WIDTH +: WIDTH] <= data_sr[(k-1)*WIDTH +: WIDTH];
                    end
                end
                if (rst) begin              // wins over ce; the data stages are never cleared
                    valid_sr <= {DEPTH{1'b0}};
                end
            end

            assign out_valid = valid_sr[DEPTH-1];
            assign out_data  = data_sr[(DEPTH-1)*WIDTH +: WIDTH];
        end
    endgenerate

endmodule

`default_nettype wire
