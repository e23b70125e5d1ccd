// fringe_mul_ecp5: ECP5 technology layer of a registered product p = a * b (one clock enable; two with
// REG_IN = 1), each operand signed or unsigned and at most 18 bits: a MULT18X18D whose output register
// (REG_OUTPUT) holds p. REG_IN = 1: its input registers (REG_INPUTA/B) hold a and b first, taking the
// place of the caller's operand registers (the caller hands their D): nextpnr-ecp5 then times the
// multiply inside the DSP instead of as a 3.49 ns setup (grade 6) on its inputs.
// Verilog only, read by sim/synth.py for ECP5 (FRINGE_TECH_ECP5); the generic code registers a * b
// itself. Yosys 0.70's synth_ecp5 maps a product to a bare MULT18X18D and leaves the register in the
// fabric: register -> DSP -> register paths measured 7.5-8 ns on grade 6.

`default_nettype none

module fringe_mul_ecp5 #(
    parameter integer A_W      = 18,  // 1..18
    parameter integer A_SIGNED = 1,   // 1: a is two's complement, 0: unsigned
    parameter integer B_W      = 18,  // 1..18
    parameter integer B_SIGNED = 1,
    parameter integer REG_IN   = 0    // 1: a, b registered in the DSP first (p two clock enables later)
) (
    input  wire                   clk,
    input  wire                   ce,
    input  wire [A_W-1:0]         a,
    input  wire [B_W-1:0]         b,
    output wire [A_W+B_W-1:0]     p     // a * b (signed if either operand is), registered (REG_IN = 1: twice)
);

    generate
        if (A_W < 1 || A_W > 18 || B_W < 1 || B_W > 18) begin : g_bad
            $error("fringe_mul_ecp5: A_W = %0d, B_W = %0d must be 1..18 (instance %m)", A_W, B_W);
        end
        if (REG_IN != 0 && REG_IN != 1) begin : g_bad_reg_in
            $error("fringe_mul_ecp5: REG_IN = %0d must be 0 or 1 (instance %m)", REG_IN);
        end
    endgenerate

    // both operands or neither: with one input register nextpnr-ecp5 times the DSP as unregistered
    localparam REG_INPUT_CLK = (REG_IN != 0) ? "CLK0" : "NONE";

    wire [17:0] ax = {{(18-A_W){(A_SIGNED != 0) & a[A_W-1]}}, a};
    wire [17:0] bx = {{(18-B_W){(B_SIGNED != 0) & b[B_W-1]}}, b};
    wire [35:0] px;

    MULT18X18D #(
        .REG_INPUTA_CLK(REG_INPUT_CLK), .REG_INPUTA_CE("CE0"), .REG_INPUTA_RST("RST0"),
        .REG_INPUTB_CLK(REG_INPUT_CLK), .REG_INPUTB_CE("CE0"), .REG_INPUTB_RST("RST0"),
        .REG_INPUTC_CLK("NONE"),
        .REG_PIPELINE_CLK("NONE"),
        .REG_OUTPUT_CLK("CLK0"), .REG_OUTPUT_CE("CE0"), .REG_OUTPUT_RST("RST0"),
        .GSR("DISABLED"), .RESETMODE("SYNC")
    ) u_mul (
        .A0(ax[0]), .A1(ax[1]), .A2(ax[2]), .A3(ax[3]), .A4(ax[4]), .A5(ax[5]), .A6(ax[6]), .A7(ax[7]),
        .A8(ax[8]), .A9(ax[9]), .A10(ax[10]), .A11(ax[11]), .A12(ax[12]), .A13(ax[13]), .A14(ax[14]),
        .A15(ax[15]), .A16(ax[16]), .A17(ax[17]),
        .B0(bx[0]), .B1(bx[1]), .B2(bx[2]), .B3(bx[3]), .B4(bx[4]), .B5(bx[5]), .B6(bx[6]), .B7(bx[7]),
        .B8(bx[8]), .B9(bx[9]), .B10(bx[10]), .B11(bx[11]), .B12(bx[12]), .B13(bx[13]), .B14(bx[14]),
        .B15(bx[15]), .B16(bx[16]), .B17(bx[17]),
        .C0(1'b0), .C1(1'b0), .C2(1'b0), .C3(1'b0), .C4(1'b0), .C5(1'b0), .C6(1'b0), .C7(1'b0), .C8(1'b0),
        .C9(1'b0), .C10(1'b0), .C11(1'b0), .C12(1'b0), .C13(1'b0), .C14(1'b0), .C15(1'b0), .C16(1'b0), .C17(1'b0),
        .SIGNEDA(A_SIGNED != 0), .SIGNEDB(B_SIGNED != 0), .SOURCEA(1'b0), .SOURCEB(1'b0),
        .CLK0(clk), .CLK1(1'b0), .CLK2(1'b0), .CLK3(1'b0),
        .CE0(ce), .CE1(1'b0), .CE2(1'b0), .CE3(1'b0),
        .RST0(1'b0), .RST1(1'b0), .RST2(1'b0), .RST3(1'b0),
        .P0(px[0]), .P1(px[1]), .P2(px[2]), .P3(px[3]), .P4(px[4]), .P5(px[5]), .P6(px[6]), .P7(px[7]),
        .P8(px[8]), .P9(px[9]), .P10(px[10]), .P11(px[11]), .P12(px[12]), .P13(px[13]), .P14(px[14]),
        .P15(px[15]), .P16(px[16]), .P17(px[17]), .P18(px[18]), .P19(px[19]), .P20(px[20]), .P21(px[21]),
        .P22(px[22]), .P23(px[23]), .P24(px[24]), .P25(px[25]), .P26(px[26]), .P27(px[27]), .P28(px[28]),
        .P29(px[29]), .P30(px[30]), .P31(px[31]), .P32(px[32]), .P33(px[33]), .P34(px[34]), .P35(px[35])
    );

    assign p = px[A_W+B_W-1:0];

endmodule

`default_nettype wire
