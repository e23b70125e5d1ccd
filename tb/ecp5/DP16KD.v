// Behavioural model of DP16KD, one of the two ECP5 primitives rtl/verilog/tech/ecp5 uses, only in the modes it uses
// them (tb/test_tech_ecp5.py simulates the technology layer with them; Yosys's cells_sim_ecp5.v gives
// DP16KD and MULT18X18D no behaviour). From the ECP5 sysMEM / sysDSP usage guides (TN1264, TN1267):
// DP16KD: each port registers its address and data on CLK when CE; REGMODE "OUTREG" adds an output
// register loaded when OCE; DATA_WIDTH 18: address AD13..AD4, AD1/AD0 the byte enables of a write;
// 36 (the pseudo dual-port mode): port A writes {DIB, DIA} at AD13..AD5 (AD3..AD0 byte enables),
// port B reads {DOB, DOA}. MULT18X18D: signed A x B, REG_OUTPUT "CLK0": P registered on CLK0 when CE0.
// INITVAL_xx are not modelled (sim/synth.py fills them after synthesis): the array starts at zero.

`default_nettype none

/* verilator lint_off UNUSEDSIGNAL */
/* verilator lint_off UNUSEDPARAM */
module DP16KD #(
    parameter integer DATA_WIDTH_A = 18,
    parameter integer DATA_WIDTH_B = 18,
    parameter REGMODE_A = "NOREG",
    parameter REGMODE_B = "NOREG",
    parameter RESETMODE = "SYNC",
    parameter ASYNC_RESET_RELEASE = "SYNC",
    parameter CSDECODE_A = "0b000",
    parameter CSDECODE_B = "0b000",
    parameter WRITEMODE_A = "NORMAL",
    parameter WRITEMODE_B = "NORMAL",
    parameter GSR = "AUTO"
) (
    input  wire DIA17, DIA16, DIA15, DIA14, DIA13, DIA12, DIA11, DIA10, DIA9, DIA8, DIA7, DIA6, DIA5, DIA4, DIA3, DIA2, DIA1, DIA0,
    input  wire ADA13, ADA12, ADA11, ADA10, ADA9, ADA8, ADA7, ADA6, ADA5, ADA4, ADA3, ADA2, ADA1, ADA0,
    input  wire CEA, OCEA, CLKA, WEA, RSTA, CSA2, CSA1, CSA0,
    output wire DOA17, DOA16, DOA15, DOA14, DOA13, DOA12, DOA11, DOA10, DOA9, DOA8, DOA7, DOA6, DOA5, DOA4, DOA3, DOA2, DOA1, DOA0,
    input  wire DIB17, DIB16, DIB15, DIB14, DIB13, DIB12, DIB11, DIB10, DIB9, DIB8, DIB7, DIB6, DIB5, DIB4, DIB3, DIB2, DIB1, DIB0,
    input  wire ADB13, ADB12, ADB11, ADB10, ADB9, ADB8, ADB7, ADB6, ADB5, ADB4, ADB3, ADB2, ADB1, ADB0,
    input  wire CEB, OCEB, CLKB, WEB, RSTB, CSB2, CSB1, CSB0,
    output wire DOB17, DOB16, DOB15, DOB14, DOB13, DOB12, DOB11, DOB10, DOB9, DOB8, DOB7, DOB6, DOB5, DOB4, DOB3, DOB2, DOB1, DOB0
);
    reg  [17:0] mem [0:1023];
    wire [17:0] dia = {DIA17, DIA16, DIA15, DIA14, DIA13, DIA12, DIA11, DIA10, DIA9, DIA8, DIA7, DIA6, DIA5, DIA4, DIA3, DIA2, DIA1, DIA0}, dib = {DIB17, DIB16, DIB15, DIB14, DIB13, DIB12, DIB11, DIB10, DIB9, DIB8, DIB7, DIB6, DIB5, DIB4, DIB3, DIB2, DIB1, DIB0};
    wire [13:0] ada = {ADA13, ADA12, ADA11, ADA10, ADA9, ADA8, ADA7, ADA6, ADA5, ADA4, ADA3, ADA2, ADA1, ADA0}, adb = {ADB13, ADB12, ADB11, ADB10, ADB9, ADB8, ADB7, ADB6, ADB5, ADB4, ADB3, ADB2, ADB1, ADB0};
    reg  [35:0] rd, rd_q;
    integer i;

    /* verilator lint_off WIDTHEXPAND */   // string parameters of several lengths
    initial begin
        for (i = 0; i < 1024; i = i + 1) mem[i] = 18'd0;
        if (!(DATA_WIDTH_A == DATA_WIDTH_B && (DATA_WIDTH_A == 18 || DATA_WIDTH_A == 36)) ||
            (DATA_WIDTH_A == 18 && REGMODE_A != "NOREG") || REGMODE_B != "OUTREG")
            $fatal(1, "DP16KD model: mode not modelled (%m)");
    end
    /* verilator lint_on WIDTHEXPAND */

    // port A writes
    always @(posedge CLKA) begin
        if (CEA && WEA) begin
            if (DATA_WIDTH_A == 18) begin
                if (ada[0]) mem[ada[13:4]][8:0]  <= dia[8:0];
                if (ada[1]) mem[ada[13:4]][17:9] <= dia[17:9];
            end else begin
                if (ada[0]) mem[{ada[13:5], 1'b0}][8:0]  <= dia[8:0];
                if (ada[1]) mem[{ada[13:5], 1'b0}][17:9] <= dia[17:9];
                if (ada[2]) mem[{ada[13:5], 1'b1}][8:0]  <= dib[8:0];
                if (ada[3]) mem[{ada[13:5], 1'b1}][17:9] <= dib[17:9];
            end
        end
    end

    // port B reads: the array word of the address registered on CEB, then the output register (OCEB)
    always @(posedge CLKB) begin
        if (OCEB) rd_q <= rd;
        if (CEB) rd <= (DATA_WIDTH_B == 18) ? {mem[adb[13:4]], 18'd0}
                                            : {mem[{adb[13:5], 1'b1}], mem[{adb[13:5], 1'b0}]};
    end

    assign {DOB17, DOB16, DOB15, DOB14, DOB13, DOB12, DOB11, DOB10, DOB9, DOB8, DOB7, DOB6, DOB5, DOB4, DOB3, DOB2, DOB1, DOB0} = rd_q[35:18];
    assign {DOA17, DOA16, DOA15, DOA14, DOA13, DOA12, DOA11, DOA10, DOA9, DOA8, DOA7, DOA6, DOA5, DOA4, DOA3, DOA2, DOA1, DOA0} = rd_q[17:0];
endmodule
/* verilator lint_on UNUSEDPARAM */
/* verilator lint_on UNUSEDSIGNAL */

`default_nettype wire
