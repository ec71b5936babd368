// watchdog under the stimulus of crates/rtl-check (`rtl_check::blocks::watchdog`).
//
// Records, each u8 check (check_i on its clocks) first: 'R' check, u32 n (n clocks with no
// command); 'S' check, u32 clocks (one clock with start_i); 'I' check, u32 clocks (one clock
// with start_if_stopped_i); 'P' check (one clock with stop_i). Outputs each clock: bit 0
// expired_o (this clock's, before its edge), bit 1 running_o (after it). An event on each
// clock with a command or an expiry: left_o after the edge (u64).
#include <memory>

#include "Vwatchdog.h"
#include "harness.h"
#include "verilated.h"

int main(int argc, char** argv) {
  if (argc != 4) harness::fail("usage: check <stimulus> <outputs> <events>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  harness::Events events(argv[3]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vwatchdog>(ctx.get());
  uint32_t clock_n = 0;
  auto clock = [&](bool command) {
    top->eval();
    uint8_t expired = top->expired_o;
    top->clk_i = 1;
    top->eval();
    top->clk_i = 0;
    top->eval();
    out.clock(static_cast<uint8_t>(expired | (top->running_o << 1)));
    if (command || expired) {
      std::vector<uint8_t> payload;
      uint64_t left = top->left_o;
      for (int i = 0; i < 8; i++) payload.push_back((left >> (8 * i)) & 0xFF);
      events.record(clock_n, payload);
    }
    top->start_i = 0;
    top->start_if_stopped_i = 0;
    top->stop_i = 0;
    clock_n++;
  };
  top->clk_i = 0;
  top->start_i = 0;
  top->start_if_stopped_i = 0;
  top->stop_i = 0;
  top->check_i = 0;
  top->clocks_i = 0;
  harness::reset(*top);
  for (int op; (op = in.op()) >= 0;) {
    top->check_i = in.u8();
    switch (op) {
      case 'R':
        for (uint32_t n = in.u32(); n > 0; n--) clock(false);
        break;
      case 'S':
        top->clocks_i = in.u32();
        top->start_i = 1;
        clock(true);
        break;
      case 'I':
        top->clocks_i = in.u32();
        top->start_if_stopped_i = 1;
        clock(true);
        break;
      case 'P':
        top->stop_i = 1;
        clock(true);
        break;
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
