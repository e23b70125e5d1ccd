// fringe_split_mul: an exact pipelined product p = a * b of operands of any width, built from
// partial products that each fit one 18x18 signed multiplier (LO_W = 17; 15 for 16x16).
// Document: docs/blocks/fringe_split_mul.md.
//
// LATENCY clock enables (>= 1): stage 1 registers the bare partial products, stages 2..LATENCY add
// them in groups of G (the smallest G with G^(LATENCY-1) >= the number of partial products), one
// carry chain per term; LATENCY = 1: p is the unregistered sum of the registered partial products
// (for a caller that registers it with terms of its own). ce = 0 freezes every stage; no reset (data only).

`default_nettype none

// the technology layers that add a narrow partial product up in the fabric (ECP5, iCE40); undefined at the end
`ifdef FRINGE_TECH_ECP5
`define FRINGE_SPLIT_FABRIC_NARROW
`elsif FRINGE_TECH_ICE40
`define FRINGE_SPLIT_FABRIC_NARROW
`endif

module fringe_split_mul #(
    parameter integer A_W      = 18,  // width of a, >= 1
    parameter integer A_SIGNED = 1,   // 1: a is two's complement, 0: unsigned
    parameter integer B_W      = 18,  // width of b, >= 1
    parameter integer B_SIGNED = 1,   // 1: b is two's complement, 0: unsigned
    parameter integer LATENCY  = 2,   // clock enables from a, b to p, >= 1 (1: p is not registered)
    parameter integer LO_W     = 17   // bits of a low chunk, >= 1: partial products of (LO_W+1)-bit signed chunks
) (
    input  wire               clk,
    input  wire               ce,     // clock enable: the stages advance when 1
    input  wire [A_W-1:0]     a,
    input  wire [B_W-1:0]     b,
    output wire [A_W+B_W-1:0] p       // a * b, signed if either operand is signed, else unsigned
);

    // ---- chunks: x = sum_i C_i * 2^(L i); C_i = {0, L bits} below the top, the top chunk signed ----
    localparam integer L   = (LO_W < 1) ? 1 : LO_W;   // an illegal LO_W stops at the check below, not at a division
    localparam integer P_W = A_W + B_W;                    // holds the product exactly
    localparam integer AS_W  = A_W + ((A_SIGNED != 0) ? 0 : 1);   // a as a signed operand
    localparam integer BS_W  = B_W + ((B_SIGNED != 0) ? 0 : 1);
    localparam integer NA  = (AS_W + L - 2) / L > 0 ? (AS_W + L - 2) / L : 1;
    localparam integer NB  = (BS_W + L - 2) / L > 0 ? (BS_W + L - 2) / L : 1;
    localparam integer NP   = NA * NB;                      // partial products, term k = (k / NB, k % NB)
    localparam integer NS   = LATENCY - 1;                  // adding stages
    localparam integer G   = group_size(NP, NS);
    localparam integer PAD = L + 1;                        // operands extended to whole chunks

    // the smallest g >= 2 with g^r >= t (1 if t = 1: the adding stages only delay)
    function integer group_size(input integer t, input integer r);
        integer g, n, k;   // not s: it would hide a caller's port of that name
        begin
            group_size = 1;
            if (t > 1) begin
                g = 2;
                n = 2;
                for (k = 1; k < r; k = k + 1) n = n * 2;
                while (n < t) begin
                    g = g + 1;
                    n = g;
                    for (k = 1; k < r; k = k + 1) n = n * g;
                end
                group_size = g;
            end
        end
    endfunction

    // width of chunk i of an operand with x signed bits in n chunks (the top one holds the sign)
    function integer chunk_w(input integer i, input integer n, input integer x);
        chunk_w = (i < n - 1) ? L + 1 : x - L * (n - 1);
    endfunction

    // lowest bit and signed width (from bit 0) of term t after stage st: its partial products
    // k in [t G^st, (t + 1) G^st) have no bits below L (i + j) and fit s(L (i + j) + chunk widths)
    function integer term_lo(input integer st, input integer t);
        integer span, k, lo;
        begin
            span = 1;
            for (k = 0; k < st; k = k + 1) span = span * G;
            term_lo = P_W;
            for (k = t * span; k < (t + 1) * span && k < NP; k = k + 1) begin
                lo = L * (k / NB + k % NB);
                if (lo < term_lo) term_lo = lo;
            end
        end
    endfunction

    function integer term_hi(input integer st, input integer t);
        integer span, k, hi, n;
        begin
            span = 1;
            for (k = 0; k < st; k = k + 1) span = span * G;
            term_hi = 0;
            n = 0;
            for (k = t * span; k < (t + 1) * span && k < NP; k = k + 1) begin
                hi = L * (k / NB + k % NB) + chunk_w(k / NB, NA, AS_W) + chunk_w(k % NB, NB, BS_W);
                if (hi > term_hi) term_hi = hi;
                n = n + 1;
            end
            term_hi = term_hi + $clog2(n);
            if (term_hi > P_W) term_hi = P_W;
        end
    endfunction

    // the same value with its known-zero bits below lo and its sign copies from bit hi on written as
    // such (a synthesis hint: those flip-flops merge or vanish); the value itself is unchanged
    function [P_W-1:0] shaped(input [P_W-1:0] v, input integer lo, input integer hi);
        integer k;
        begin
            for (k = 0; k < P_W; k = k + 1) shaped[k] = (k < lo) ? 1'b0 : ((k < hi) ? v[k] : v[(hi > 0) ? hi - 1 : 0]);
        end
    endfunction

    // ---- parameter checks -------------------------------------------------------------------------
    generate
        if (A_W < 1 || B_W < 1 || LO_W < 1 || LATENCY < 1) begin : g_bad_generics
            $error("fringe_split_mul: A_W = %0d, B_W = %0d, LO_W = %0d, LATENCY = %0d must be >= 1 (instance %m)",
                   A_W, B_W, LO_W, LATENCY);
        end
    endgenerate

    wire [NA*L+PAD-1:0] a_ext = (A_SIGNED != 0) ? {{(NA*L+PAD-A_W){a[A_W-1]}}, a} : {{(NA*L+PAD-A_W){1'b0}}, a};
    wire [NB*L+PAD-1:0] b_ext = (B_SIGNED != 0) ? {{(NB*L+PAD-B_W){b[B_W-1]}}, b} : {{(NB*L+PAD-B_W){1'b0}}, b};

    // ---- stage 1: the partial products, each at its weight, registered bare -------------------------
    wire [NP*P_W-1:0] prod;
`ifdef FRINGE_SPLIT_FABRIC_NARROW
    wire [NP*2*(L+1)-1:0] chunks;   // {ca, cb} of each partial product (the technology layers multiply them)
`endif
    genvar gk, gs;
    generate
        for (gk = 0; gk < NP; gk = gk + 1) begin : g_prod
            localparam integer I = gk / NB;
            localparam integer J = gk % NB;
            wire signed [L:0]       ca = (I < NA - 1) ? {1'b0, a_ext[L*I +: L]} : a_ext[L*I +: L+1];
            wire signed [L:0]       cb = (J < NB - 1) ? {1'b0, b_ext[L*J +: L]} : b_ext[L*J +: L+1];
            wire signed [2*L+1:0]   m  = ca * cb;
            wire [P_W+2*L+1:0]      mw = {{P_W{m[2*L+1]}}, m} << (L * (I + J));
            assign prod[gk*P_W +: P_W] = mw[P_W-1:0];
`ifdef FRINGE_SPLIT_FABRIC_NARROW
            assign chunks[gk*2*(L+1) +: 2*(L+1)] = {ca, cb};
`endif
            wire unused_m = &{1'b0, mw[P_W+2*L+1:P_W]};
        end
    endgenerate

    wire [NP*P_W-1:0] stage [0:NS];

    generate
        for (gs = 0; gs <= NS; gs = gs + 1) begin : g_stage
            wire [NP*P_W-1:0] q;
            for (gk = 0; gk < NP; gk = gk + 1) begin : g_term
                localparam integer LO = term_lo(gs, gk);
                localparam integer HI = term_hi(gs, gk);
`ifdef FRINGE_SPLIT_FABRIC_NARROW
                // ECP5, iCE40: the live bits of the two chunks (a chunk below the top: L; the top chunk of a signed
                // operand: its bits with the sign; of an unsigned one: without its zero sign bit). A product
                // of two factors of 2 bits or more, one of them 6 or more, takes a MULT18X18D (ECP5; on iCE40
                // Yosys maps g_live's product to an SB_MAC16); a narrower one
                // (a factor of 1 to 3 bits) is added up in the fabric from shifted copies of the wide factor,
                // keeping DSPs free (Yosys would put a 2-bit signed factor in a DSP of its own)
                localparam integer I  = gk / NB;
                localparam integer J  = gk % NB;
                localparam integer LA = (I < NA - 1) ? L : AS_W - L * (NA - 1) - ((A_SIGNED != 0) ? 0 : 1);
                localparam integer LB = (J < NB - 1) ? L : BS_W - L * (NB - 1) - ((B_SIGNED != 0) ? 0 : 1);
                localparam integer NSIG = (LA <= LB) ? ((I == NA - 1 && A_SIGNED != 0) ? 1 : 0)
                                                     : ((J == NB - 1 && B_SIGNED != 0) ? 1 : 0);
                localparam integer NW = (LA <= LB) ? LA : LB;   // the narrow factor's live bits
`ifdef FRINGE_TECH_ECP5
                localparam integer WW = (LA <= LB) ? LB : LA;
                if (LO < P_W && gs == 0 && L + 1 <= 18 && NW >= 2 && WW >= 6) begin : g_dsp
                    // the bare partial product registered in the MULT18X18D's output register, then
                    // placed at its weight as g_live's stage 0 does (shaped() keeps the value)
                    wire [2*L+1:0]     m;
                    fringe_mul_ecp5 #(.A_W(L + 1), .B_W(L + 1)) u_mul (
                        .clk(clk), .ce(ce),
                        .a(chunks[gk*2*(L+1)+L+1 +: L+1]), .b(chunks[gk*2*(L+1) +: L+1]), .p(m)
                    );
                    wire [P_W+2*L+1:0] mw = {{P_W{m[2*L+1]}}, m} << (L * (I + J));
                    assign q[gk*P_W +: P_W] = mw[P_W-1:0];
                    wire unused_m = &{1'b0, mw[P_W+2*L+1:P_W]};
                end else
`endif
                if (LO < P_W && gs == 0 && NW <= 3) begin : g_narrow
                    // the wide factor times each live bit of the narrow one (the top bit negative if it
                    // is a sign), summed: NW - 1 adders at most, no multiplier
                    wire signed [L:0] cn = (LA <= LB) ? chunks[gk*2*(L+1)+L+1 +: L+1] : chunks[gk*2*(L+1) +: L+1];
                    wire signed [L:0] cw = (LA <= LB) ? chunks[gk*2*(L+1) +: L+1] : chunks[gk*2*(L+1)+L+1 +: L+1];
                    reg signed [2*L+1:0] mn;
                    reg        [P_W+2*L+1:0] mw;
                    reg        [P_W-1:0] r;
                    integer c;
                    always @* begin
                        mn = {(2*L+2){1'b0}};
                        for (c = 0; c < NW; c = c + 1) begin
                            if (cn[c]) begin
                                if (c == NW - 1 && NSIG != 0) mn = mn - ({{(L+1){cw[L]}}, cw} <<< c);
                                else                          mn = mn + ({{(L+1){cw[L]}}, cw} <<< c);
                            end
                        end
                        mw = {{P_W{mn[2*L+1]}}, mn} << (L * (I + J));
                    end
                    always @(posedge clk) begin
                        if (ce) begin
                            r <= shaped(mw[P_W-1:0], LO, HI);
                        end
                    end
                    assign q[gk*P_W +: P_W] = r;
                    wire unused_m = &{1'b0, mw[P_W+2*L+1:P_W]};
                end else
`endif
                if (LO < P_W) begin : g_live
                    // stage 0: the product; after it, the sum of terms G k .. G k + G - 1 of the stage before
                    reg [P_W-1:0] sum;
                    reg [P_W-1:0] r;
                    integer c;
                    always @* begin
                        if (gs == 0) begin
                            sum = prod[gk*P_W +: P_W];
                        end else begin
                            sum = {P_W{1'b0}};
                            for (c = 0; c < G; c = c + 1) begin
                                if (G * gk + c < NP) begin
                                    sum = sum + stage[(gs > 0) ? gs - 1 : 0][(G*gk+c)*P_W +: P_W];
                                end
                            end
                        end
                    end
                    always @(posedge clk) begin
                        if (ce) begin
                            r <= shaped(sum, LO, HI);
                        end
                    end
                    assign q[gk*P_W +: P_W] = r;
                end else begin : g_empty
                    assign q[gk*P_W +: P_W] = {P_W{1'b0}};
                end
            end
            assign stage[gs] = q;
        end
    endgenerate

    generate
        if (NS == 0) begin : g_sum_out
            // LATENCY = 1: the registered partial products added without a register
            reg [P_W-1:0] sum;
            integer c;
            always @* begin
                sum = {P_W{1'b0}};
                for (c = 0; c < NP; c = c + 1) sum = sum + stage[0][c*P_W +: P_W];
            end
            assign p = sum;
        end else begin : g_reg_out
            assign p = stage[NS][P_W-1:0];
        end
    endgenerate

    // Bits that carry nothing: the operands' extension above the top chunk, terms past the last.
    wire unused = &{1'b0, a_ext, b_ext, stage[NS]};
`ifdef FRINGE_TECH_ICE40
    // each term reads either its product or its chunks
    wire unused_fabric = &{1'b0, prod, chunks};
`endif

endmodule

`ifdef FRINGE_SPLIT_FABRIC_NARROW
`undef FRINGE_SPLIT_FABRIC_NARROW
`endif
`default_nettype wire
