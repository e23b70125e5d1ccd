// Behavioural model of MULT18X18D in the modes rtl/verilog/tech/ecp5 uses (see DP16KD.v): A x B,
// each signed or unsigned by SIGNEDA / SIGNEDB, REG_OUTPUT "CLK0": P registered on CLK0 when CE0; with
// REG_INPUTA_CLK = REG_INPUTB_CLK = "CLK0" (CE0), A and B (with SIGNEDA / SIGNEDB, tied to constants
// by the layer) are registered on CLK0 when CE0 first, so P is the product of two clock enables before.

`default_nettype none

/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off UNUSEDPARAM */
module MULT18X18D #(
    parameter REG_INPUTA_CLK = "NONE", parameter REG_INPUTA_CE = "CE0", parameter REG_INPUTA_RST = "RST0",
    parameter REG_INPUTB_CLK = "NONE", parameter REG_INPUTB_CE = "CE0", parameter REG_INPUTB_RST = "RST0",
    parameter REG_INPUTC_CLK = "NONE", parameter REG_INPUTC_CE = "CE0", parameter REG_INPUTC_RST = "RST0",
    parameter REG_PIPELINE_CLK = "NONE", parameter REG_PIPELINE_CE = "CE0", parameter REG_PIPELINE_RST = "RST0",
    parameter REG_OUTPUT_CLK = "NONE", parameter REG_OUTPUT_CE = "CE0", parameter REG_OUTPUT_RST = "RST0",
    parameter GSR = "ENABLED", parameter RESETMODE = "SYNC"
) (
    input  wire A17, A16, A15, A14, A13, A12, A11, A10, A9, A8, A7, A6, A5, A4, A3, A2, A1, A0,
    input  wire B17, B16, B15, B14, B13, B12, B11, B10, B9, B8, B7, B6, B5, B4, B3, B2, B1, B0,
    input  wire C17, C16, C15, C14, C13, C12, C11, C10, C9, C8, C7, C6, C5, C4, C3, C2, C1, C0,
    input  wire SIGNEDA, SIGNEDB, SOURCEA, SOURCEB,
    input  wire CLK3, CLK2, CLK1, CLK0, CE3, CE2, CE1, CE0, RST3, RST2, RST1, RST0,
    output wire P35, P34, P33, P32, P31, P30, P29, P28, P27, P26, P25, P24, P23, P22, P21, P20, P19, P18, P17, P16, P15, P14, P13, P12, P11, P10, P9, P8, P7, P6, P5, P4, P3, P2, P1, P0
);
    /* verilator lint_off WIDTHEXPAND */   // string parameters of several lengths
    localparam integer REG_IN = (REG_INPUTA_CLK == "CLK0") ? 1 : 0;
    /* verilator lint_on WIDTHEXPAND */
    wire signed [18:0] a_d = {SIGNEDA & A17, A17, A16, A15, A14, A13, A12, A11, A10, A9, A8, A7, A6, A5, A4, A3, A2, A1, A0};
    wire signed [18:0] b_d = {SIGNEDB & B17, B17, B16, B15, B14, B13, B12, B11, B10, B9, B8, B7, B6, B5, B4, B3, B2, B1, B0};
    reg  signed [18:0] a_q, b_q;
    wire signed [18:0] a = (REG_IN != 0) ? a_q : a_d;
    wire signed [18:0] b = (REG_IN != 0) ? b_q : b_d;
    wire signed [37:0] ab = a * b;     // SIGNEDA/SIGNEDB: each operand two's complement or unsigned
    reg  [35:0]        p_q;

    /* verilator lint_off WIDTHEXPAND */   // string parameters of several lengths
    initial begin
        if (REG_INPUTA_CLK != REG_INPUTB_CLK || (REG_INPUTA_CLK != "NONE" && REG_INPUTA_CLK != "CLK0") ||
            (REG_INPUTA_CLK == "CLK0" && (REG_INPUTA_CE != "CE0" || REG_INPUTB_CE != "CE0")) ||
            REG_PIPELINE_CLK != "NONE" || REG_OUTPUT_CLK != "CLK0" || REG_OUTPUT_CE != "CE0")
            $fatal(1, "MULT18X18D model: mode not modelled (%m)");
    end
    /* verilator lint_on WIDTHEXPAND */

    always @(posedge CLK0) begin
        if (CE0) begin
            a_q <= a_d;
            b_q <= b_d;
            p_q <= ab[35:0];
        end
    end

    assign {P35, P34, P33, P32, P31, P30, P29, P28, P27, P26, P25, P24, P23, P22, P21, P20, P19, P18, P17, P16, P15, P14, P13, P12, P11, P10, P9, P8, P7, P6, P5, P4, P3, P2, P1, P0} = p_q;
endmodule
/* verilator lint_on UNUSEDPARAM */
/* verilator lint_on UNUSEDSIGNAL */

`default_nettype wire
