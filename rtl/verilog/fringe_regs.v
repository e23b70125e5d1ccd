// fringe_regs: fringe_core's register file (two banks), CTRL and the configuration write decode.
//
// A write presented on cfg_wr_* lands two clocks later, in the bank that was inactive when it was
// presented; a CTRL swap flips active_bank at the clock a write presented with it would land.
// Configuration, never reset. Parameters, ports and timing: docs/blocks/fringe_regs.md.
// Model: the register map model/fringe/fixed/regmap.py; test tb/test_fringe_regs.py.

`default_nettype none

module fringe_regs #(
    parameter integer WAVE_ADDR_W = 8,   // words per wave table bank and branch: 2^WAVE_ADDR_W (x 2 branches)
    parameter integer LP_ADDR_W   = 8,   // words per long-period table bank: 2^LP_ADDR_W
    parameter integer MAP_PSI_W   = 4,   // trim map bank: 2^(1+MAP_PSI_W+MAP_PHI_W) words
    parameter integer MAP_PHI_W   = 6,
    parameter integer FWD_W       = 6,   // words per drift forward table bank: 2^FWD_W
    parameter         REGS_INIT   = ""   // $readmemh image of the registers, 2 x 32 words of 32 bits; "" = zeros
) (
    input  wire                      clk,
    // configuration write port
    input  wire                      cfg_wr_en,
    input  wire [19:0]               cfg_wr_addr,   // {space, word}
    input  wire [63:0]               cfg_wr_data,
    // the register file: word {bank, index} at bits [32*(32*bank + index) +: 32] (2 x N_REGS words of REG_W
    // bits; the package's constants come after the ports: the width is checked below)
    output wire [2*32*32-1:0]        regs_q,
    output wire                      active_bank,
    // the landing table write (one clock): strobes, word address in a bank, its bank, data
    output reg                       wr_sin,
    output reg                       wr_cos,
    output reg                       wr_lp,
    output reg                       wr_trim,
    output reg  [1:0]                wr_trim_sel,   // 0 map, 1 speed, 2 magnitude
    output reg                       wr_fwd,
    output reg                       wr_fwd_sel,    // 0 sine, 1 cosine
    output reg  [15:0]               wr_word,
    output reg                       wr_bank,
    output reg  [63:0]               wr_data
);

    `include "fringe_pkg.vh"

    // regs[{bank, index}], index as in model/fringe/fixed/regmap.py (REG_*, CTRL_WORD: fringe_pkg.vh)
    reg [REG_W-1:0] regs [0:2*N_REGS-1];
    reg             bank_r;

    initial bank_r = 1'b0;   // power-up value (configuration: no reset)

    // CTRL is decoded in two halves of its word, each one compare in step 1: the high bits zero (with
    // the space and the write enable) and the low CTRL_LOW_W bits CTRL_WORD's (with the swap bit)
    localparam integer CTRL_LOW_W = 8;

    generate
        `FRINGE_MEM_INIT(REGS_INIT, regs, 2 * N_REGS, REG_W)
        // regs_q's width is written out in the port list, ahead of the package's constants
        `FRINGE_CHECK_RANGE(g_bad_regs_q, "fringe_regs", "regs_q width", 2 * N_REGS * REG_W, 2 * 32 * 32, 2 * 32 * 32)
        // CTRL's decode compares the word's low CTRL_LOW_W bits and its high bits apart (below)
        `FRINGE_CHECK_RANGE(g_bad_ctrl_word, "fringe_regs", "CTRL_WORD", CTRL_WORD, 0, (1 << CTRL_LOW_W) - 1)
    endgenerate

    wire [3:0]  cfg_sel  = cfg_wr_addr[19:16];
    wire [15:0] cfg_word = cfg_wr_addr[15:0];
    wire        in_bank  = ~bank_r;   // writes go to the inactive bank

    // The write decode is two registered steps (the iCE40's routing cannot take the 22-input compare and
    // the 32-way fan-out in one clock): step 1 registers partial decodes of the presented write, step 2
    // the one-hot register enables and the table enables; the write lands at the clock after step 2,
    // two clocks after it was presented, in the bank that was inactive when it was presented.
    reg               st1_en_reg, st1_en_ctrl_a, st1_en_ctrl_b;
    reg  [7:0]        st1_sel;                  // one-hot: sin, cos, lp, trim map, trim speed, trim amp, fwd sin, fwd cos
    reg               st1_wave_ok, st1_lp_ok, st1_trim_ok, st1_fwd_ok;
    reg  [15:0]       st1_word;
    reg               st1_bank;
    reg  [63:0]       st1_data;
    reg  [2*N_REGS-1:0] reg_we;
    reg               ctrl_swap;

    // power-up values: no write lands before the first one presented (as bank_r, not reset)
    initial begin
        st1_en_reg    = 1'b0;
        st1_en_ctrl_a = 1'b0;
        st1_sel       = 8'd0;
        reg_we        = {2*N_REGS{1'b0}};
        wr_sin        = 1'b0;
        wr_cos        = 1'b0;
        wr_lp         = 1'b0;
        wr_trim       = 1'b0;
        wr_fwd        = 1'b0;
        ctrl_swap     = 1'b0;
    end

    // step 1: which space, whether the word lies inside one bank (table words), CTRL in two halves
    always @(posedge clk) begin
        st1_en_reg    <= cfg_wr_en && cfg_sel == SPACE_REGS && (cfg_word >> REG_INDEX_W) == 16'd0;
        st1_en_ctrl_a <= cfg_wr_en && cfg_sel == SPACE_REGS && (cfg_word >> CTRL_LOW_W) == 16'd0;
        st1_en_ctrl_b <= cfg_word[CTRL_LOW_W-1:0] == CTRL_WORD[CTRL_LOW_W-1:0] && cfg_wr_data[CTRL_SWAP];
        st1_sel       <= {cfg_sel == SPACE_DRIFT_FWD_COS, cfg_sel == SPACE_DRIFT_FWD_SIN, cfg_sel == SPACE_TRIM_AMP,
                          cfg_sel == SPACE_TRIM_SPEED, cfg_sel == SPACE_TRIM_MAP, cfg_sel == SPACE_LONG_PERIOD,
                          cfg_sel == SPACE_WAVE_COS, cfg_sel == SPACE_WAVE_SIN} & {8{cfg_wr_en}};
        st1_wave_ok   <= (cfg_word >> (WAVE_ADDR_W + 1)) == 16'd0;
        st1_lp_ok     <= (cfg_word >> LP_ADDR_W) == 16'd0;
        st1_trim_ok   <= (cfg_word >> (MAP_PSI_W + MAP_PHI_W + 1)) == 16'd0;
        st1_fwd_ok    <= (cfg_word >> FWD_W) == 16'd0;
        st1_word      <= cfg_word;
        st1_bank      <= in_bank;
        st1_data      <= cfg_wr_data;
    end

    // step 2: one-hot register enables {bank, index}, table enables, CTRL
    integer wi;
    always @(posedge clk) begin
        for (wi = 0; wi < 2 * N_REGS; wi = wi + 1) begin
            reg_we[wi] <= st1_en_reg && st1_word[REG_INDEX_W-1:0] == wi[REG_INDEX_W-1:0] && st1_bank == wi[REG_INDEX_W];
        end
        wr_sin      <= st1_sel[0] && st1_wave_ok;
        wr_cos      <= st1_sel[1] && st1_wave_ok;
        wr_lp       <= st1_sel[2] && st1_lp_ok;
        wr_trim     <= (st1_sel[3] || st1_sel[4] || st1_sel[5]) && st1_trim_ok;
        wr_trim_sel <= {st1_sel[5], st1_sel[4]};   // 4, 5, 6 -> 0 map, 1 speed, 2 magnitude
        wr_fwd      <= (st1_sel[6] || st1_sel[7]) && st1_fwd_ok;
        wr_fwd_sel  <= st1_sel[7];                 // 7, 8 -> 0 sine, 1 cosine
        ctrl_swap   <= st1_en_ctrl_a && st1_en_ctrl_b;
        wr_word     <= st1_word;
        wr_bank     <= st1_bank;
        wr_data     <= st1_data;
    end

    genvar ri;
    generate
        for (ri = 0; ri < 2 * N_REGS; ri = ri + 1) begin : g_reg_wr
            always @(posedge clk) begin
                if (reg_we[ri]) begin
                    regs[ri] <= wr_data[REG_W-1:0];
                end
            end
            assign regs_q[REG_W*ri +: REG_W] = regs[ri];
        end
    endgenerate

    // CTRL swaps at the clock after step 2, as a write presented at the same time would land: every
    // write presented before it has landed by then (each carries its bank in wr_bank)
    always @(posedge clk) begin
        if (ctrl_swap) begin
            bank_r <= ~bank_r;
        end
    end

    assign active_bank = bank_r;

endmodule

`default_nettype wire
