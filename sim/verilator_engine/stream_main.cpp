// Verilator harness of the fast RTL engine (fringe.hardware.rtlsim, `fringe correct --engine verilog`):
// streams a file of samples through fringe_top with no Python per sample.
//
//   fringe_stream IN.bin OUT.bin ADC_W ADC_LANE COARSE_W [verilator plusargs]
//
// IN.bin:  n records of three little-endian int32: sin code, cos code, coarse code (ignored when
//          COARSE_W = 0); the codes are masked to their lanes here, as rtlsim.pack_inputs does.
// OUT.bin: n little-endian uint64, every m_axis_tdata word in order.
// stdout:  one JSON line {"samples", "latency", "cycles"}.
// The protocol is model/fringe/hardware/rtl_stream.py's (the cocotb path): rst high for 3 clocks, then one sample
// per clock (each when s_axis_tready = 1: COMPACT = 1 takes one per CORDIC_STAGES, DRIFT_HOLD = 1 waits at
// each tracker block boundary) with m_axis_tready = 1; the ROM images and registers come from the init-file
// parameters the binary was built with (read by $readmemh when the model starts).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "Vfringe_top.h"
#include "verilated.h"

namespace {

using u128 = unsigned __int128;

// Assign a packed word to a port of any width: Verilator holds <= 64 bits in an integer,
// wider ports in VlWide (32-bit words, least significant first).
template <typename T>
void assign_word(T& port, u128 w) { port = static_cast<T>(w); }

template <std::size_t N>
void assign_word(VlWide<N>& port, u128 w) {
    for (std::size_t i = 0; i < N; ++i) port[i] = static_cast<uint32_t>(i < 4 ? (w >> (32 * i)) : 0);
}

int fail(const char* what) {
    std::fprintf(stderr, "fringe_stream: %s\n", what);
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 6) return fail("usage: fringe_stream IN.bin OUT.bin ADC_W ADC_LANE COARSE_W [+plusargs]");
    const int adc_w = std::atoi(argv[3]), adc_lane = std::atoi(argv[4]), coarse_w = std::atoi(argv[5]);
    if (adc_w < 1 || adc_w > 32 || adc_lane < adc_w || coarse_w < 0 || coarse_w > 32 || 2 * adc_lane + coarse_w > 128)
        return fail("bad lane widths");

    std::FILE* fi = std::fopen(argv[1], "rb");
    if (!fi) return fail("cannot open the input file");
    std::vector<int32_t> rec;
    {
        int32_t buf[3 * 4096];
        size_t got;
        while ((got = std::fread(buf, sizeof(int32_t), 3 * 4096, fi)) > 0) rec.insert(rec.end(), buf, buf + got);
        std::fclose(fi);
    }
    if (rec.size() % 3) return fail("input file is not a whole number of records");
    const size_t n = rec.size() / 3;

    const u128 adc_mask = (u128(1) << adc_w) - 1, coarse_mask = (u128(1) << coarse_w) - 1;
    std::vector<uint64_t> out;
    out.reserve(n);

    auto ctx = std::make_unique<VerilatedContext>();
    ctx->commandArgs(argc - 5, argv + 5);   // the plusargs (random initial values, seed)
    auto top = std::make_unique<Vfringe_top>(ctx.get());

    auto tick = [&] {   // one rising and one falling edge
        top->clk = 1;
        top->eval();
        top->clk = 0;
        top->eval();
    };
    top->clk = 0;
    top->rst = 1;
    top->s_axis_tvalid = 0;
    assign_word(top->s_axis_tdata, 0);
    top->m_axis_tready = 1;
    top->cfg_wr_en = 0;
    top->cfg_wr_addr = 0;
    top->cfg_wr_data = 0;
    top->eval();
    for (int i = 0; i < 3; ++i) tick();
    top->rst = 0;

    // Between edges (clock low): present the next sample and take the output shown now; the
    // next rising edge consumes both. latency = the clock at which the first output is consumed.
    long long latency = -1;
    size_t cyc = 0;
    size_t k = 0;   // next sample to present; taken at an edge with s_axis_tready = 1 (COMPACT = 1: 0 between)
    const size_t limit = (n + 1000) * 64;   // clocks per sample <= CORDIC_STAGES <= 32
    while (out.size() < n) {
        if (k < n) {
            const int32_t* r = &rec[3 * k];
            u128 w = (u128(uint32_t(r[0])) & adc_mask) | ((u128(uint32_t(r[1])) & adc_mask) << adc_lane);
            if (coarse_w) w |= (u128(uint32_t(r[2])) & coarse_mask) << (2 * adc_lane);
            assign_word(top->s_axis_tdata, w);
            top->s_axis_tvalid = 1;
        } else {
            top->s_axis_tvalid = 0;
        }
        top->eval();
        const bool taken = k < n && top->s_axis_tready;
        if (top->m_axis_tvalid) {
            out.push_back(static_cast<uint64_t>(top->m_axis_tdata));
            if (latency < 0) latency = static_cast<long long>(cyc);
        }
        tick();
        if (taken) ++k;
        if (++cyc > limit) {
            std::fprintf(stderr, "fringe_stream: %zu of %zu outputs after %zu clocks\n", out.size(), n, cyc);
            return 3;
        }
    }
    top->final();

    std::FILE* fo = std::fopen(argv[2], "wb");
    if (!fo) return fail("cannot write the output file");
    if (std::fwrite(out.data(), sizeof(uint64_t), out.size(), fo) != out.size() || std::fclose(fo) != 0)
        return fail("cannot write the output file");
    std::printf("{\"samples\": %zu, \"latency\": %lld, \"cycles\": %zu}\n", n, latency, cyc);
    return 0;
}
