// char_reader under the stimulus of crates/rtl-check (`rtl_check::blocks::char_reader`).
//
// Records: 'T' u32 inc, modulo, quarter, three_quarters, half_less_inc, two_inc,
// modulo_less_inc, modulo_less_two_inc (CharReader's figures, held); 'S' (one clock with start_i, the
// line falling); 'L' u8 level, u32 n (n clocks with the line at level: edge_i on the first if
// the level changed). Outputs each clock after its edge: bits 0-3 bit_o, bit 4 tie_o, bits 5-6
// glitches_o, bit 7 pair_open_o. An event on each clock with an edge or a bit decided: shift_o
// (u16), rem_o, lead_o, lag_o (sign-extended), pair_left_o (u32 each).
#include <memory>

#include "Vchar_reader.h"
#include "harness.h"
#include "verilated.h"

namespace {
constexpr int kPhaseWidth = PARAM_PhaseWidth;

using harness::put;

// lead_o or lag_o, PhaseWidth + 1 bits of two's complement, as 32.
uint32_t balance(uint32_t raw) {
  const int width = kPhaseWidth + 1;
  uint32_t sign = 1u << (width - 1);
  return (raw ^ sign) - sign;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) harness::fail("usage: check <stimulus> <outputs> <events>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  harness::Events events(argv[3]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vchar_reader>(ctx.get());
  uint32_t clock_n = 0;
  uint8_t line = 1;
  auto clock = [&](uint8_t level, bool start) {
    top->level_i = level;
    top->edge_i = level != line;
    top->start_i = start;
    line = level;
    uint8_t bit_before = top->bit_o;
    // The start is the line's fall, whatever the line was.
    bool edge = top->edge_i || start;
    top->clk_i = 1;
    top->eval();
    top->clk_i = 0;
    top->eval();
    out.clock(static_cast<uint8_t>(top->bit_o | (top->tie_o << 4) | (top->glitches_o << 5) |
                                   (top->pair_open_o << 7)));
    if (edge || top->bit_o != bit_before) {
      std::vector<uint8_t> payload;
      put(payload, top->shift_o, 2);
      put(payload, top->rem_o, 4);
      put(payload, balance(top->lead_o), 4);
      put(payload, balance(top->lag_o), 4);
      put(payload, top->pair_left_o, 4);
      events.record(clock_n, payload);
    }
    clock_n++;
  };
  top->clk_i = 0;
  top->step_i = 1;
  top->start_i = 0;
  top->level_i = 1;
  top->edge_i = 0;
  harness::reset(*top);
  for (int op; (op = in.op()) >= 0;) {
    switch (op) {
      case 'T':
        top->inc_i = in.u32();
        top->modulo_i = in.u32();
        top->quarter_i = in.u32();
        top->three_quarters_i = in.u32();
        top->half_less_inc_i = in.u32();
        top->two_inc_i = in.u32();
        top->modulo_less_inc_i = in.u32();
        top->modulo_less_two_inc_i = in.u32();
        break;
      case 'S':
        clock(0, true);
        break;
      case 'L': {
        uint8_t level = in.u8();
        for (uint32_t n = in.u32(); n > 0; n--) clock(level, false);
        break;
      }
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
