// rate_idle under the stimulus of crates/rtl-check (`rtl_check::blocks::rate_idle`).
//
// Records: 'T' u32 glitch (samples), period, wait (the rate's samples every period clocks,
// the first wait clocks from the next one: sample_i, counted here as the top's strobe will
// come); 'N' u32 (now_i of the next clock; it counts up a clock at a time); 'L' u8 level, u32 n
// (n clocks, the line held at level); 'K' u8 flags (bit 0 the line's level as sampled, an edge
// if it changed, on a sample only; bit 1 load_i, bit 2 restore_i: the values go to either),
// u32 cancel_left, high_since, high_before (one clock). Outputs each clock after its edge: bit 0 an edge still cancels
// (cancel_left_o not 0). An event on each clock that changes high_since_o or high_before_o:
// both (u32 each).
#include <memory>

#include "Vrate_idle.h"
#include "harness.h"
#include "verilated.h"

using harness::put;

int main(int argc, char** argv) {
  if (argc != 4) harness::fail("usage: check <stimulus> <outputs> <events>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  harness::Events events(argv[3]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vrate_idle>(ctx.get());
  uint32_t clock_n = 0;
  uint8_t line = 1;
  harness::Samples samples;
  uint32_t since = 0, before = 0;
  auto clock = [&](uint8_t level, bool load, bool restore, uint32_t left, uint32_t high,
                   uint32_t prior) {
    bool sample = samples.clock();
    if (level != line && !sample) harness::fail("an edge off the sample ticks");
    top->sample_i = sample;
    top->edge_i = level != line;
    top->level_i = level;
    top->load_i = load;
    top->load_cancel_left_i = left;
    top->load_high_since_i = high;
    top->load_high_before_i = prior;
    top->restore_i = restore;
    top->restore_cancel_left_i = left;
    top->restore_high_since_i = high;
    top->restore_high_before_i = prior;
    line = level;
    top->clk_i = 1;
    top->eval();
    top->now_i = top->now_i + 1;
    top->clk_i = 0;
    top->eval();
    out.clock(static_cast<uint8_t>(top->cancel_left_o != 0));
    if (top->high_since_o != since || top->high_before_o != before) {
      since = top->high_since_o;
      before = top->high_before_o;
      std::vector<uint8_t> payload;
      put(payload, since, 4);
      put(payload, before, 4);
      events.record(clock_n, payload);
    }
    clock_n++;
  };
  top->clk_i = 0;
  top->now_i = 0;
  top->level_i = 1;
  top->edge_i = 0;
  top->sample_i = 0;
  top->load_i = 0;
  top->restore_i = 0;
  harness::reset(*top);
  for (int op; (op = in.op()) >= 0;) {
    switch (op) {
      case 'T':
        top->glitch_i = in.u32();
        {
          uint32_t period = in.u32();
          samples.set(period, in.u32());
        }
        break;
      case 'N':
        top->now_i = in.u32();
        break;
      case 'L': {
        uint8_t level = in.u8();
        for (uint32_t n = in.u32(); n > 0; n--) clock(level, false, false, 0, 0, 0);
        break;
      }
      case 'K': {
        uint8_t flags = in.u8();
        uint32_t left = in.u32();
        uint32_t high = in.u32();
        uint32_t prior = in.u32();
        clock(flags & 1, flags & 2, flags & 4, left, high, prior);
        break;
      }
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
