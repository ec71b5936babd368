// line_sync under the stimulus of crates/rtl-check (`rtl_check::line_sync`).
//
// Records: 'L' u8 level, u32 n (n clocks with line_i at level); 'X' (reset). Outputs each
// clock, the model's FilterOut of that clock: bit 0 level_o, bit 1 fell_o, bit 2 rose_o.
#include <memory>

#include "Vline_sync.h"
#include "harness.h"
#include "verilated.h"

int main(int argc, char** argv) {
  if (argc != 3) harness::fail("usage: check <stimulus> <outputs>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vline_sync>(ctx.get());
  auto reset = [&] {
    top->clk_i = 0;
    top->line_i = 1;
    harness::reset(*top);
  };
  reset();
  for (int op; (op = in.op()) >= 0;) {
    switch (op) {
      case 'L': {
        top->line_i = in.u8();
        for (uint32_t n = in.u32(); n > 0; n--) {
          // The outputs of this clock are the next state's: read before the edge.
          top->eval();
          out.clock(static_cast<uint8_t>(top->level_o | (top->fell_o << 1) | (top->rose_o << 2)));
          top->clk_i = 1;
          top->eval();
          top->clk_i = 0;
          top->eval();
        }
        break;
      }
      case 'X':
        reset();
        break;
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
