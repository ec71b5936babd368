// autobaud under the stimulus of crates/rtl-check (`rtl_check::blocks::autobaud`).
//
// Records: 'L' u8 level, u8 heard (an index into Baud::ALL, 0xFF none), u32 n: n clocks with
// the synchronised line at level and that rate heard. Outputs each clock, read before its edge (the search's decision is that clock's):
// bit 0 valid_o, bit 1 detect_o, bit 2 any channel measuring after the edge, bit 3 the heard
// rate's channel samples on this clock (samples_o). An event on each clock with a decision or
// a change of the channels measuring: measuring_o (u16), then the decision: kind (0 none, 1
// detection, 2 rejection), rate, byte (a rejection: its code), start_clocks_o (u32, the
// clocks since the character's start; 0 for a rejection, which names no rate or start in the model),
// pending_left_o (u32, the samples within which a next edge cancels the detecting channel's
// idle line's last one; 0 for a rejection), rose_after_end_o (u8; 0 for a rejection).
#include <memory>

#include "Vautobaud.h"
#include "harness.h"
#include "verilated.h"

using harness::put;

int main(int argc, char** argv) {
  if (argc != 4) harness::fail("usage: check <stimulus> <outputs> <events>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  harness::Events events(argv[3]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vautobaud>(ctx.get());
  uint32_t clock_n = 0;
  uint16_t mask = 0;
  auto clock = [&](uint8_t level, uint8_t heard) {
    top->level_i = level;
    top->heard_valid_i = heard != 0xFF;
    top->heard_i = heard == 0xFF ? 0 : heard;
    top->eval();
    std::vector<uint8_t> decision;
    uint8_t value = 0;
    if (top->valid_o) {
      value = top->detect_o ? 0b11 : 0b01;
      if (top->detect_o) {
        decision = {1, top->rate_o, top->byte_o};
        put(decision, top->start_clocks_o, 4);
        put(decision, top->pending_left_o, 4);
        decision.push_back(top->rose_after_end_o);
      } else {
        decision = {2, 0, top->reject_code_o};
        put(decision, 0, 4);
        put(decision, 0, 4);
        decision.push_back(0);
      }
    } else {
      decision = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    }
    if (heard != 0xFF && (top->samples_o >> heard & 1)) value |= 0b1000;
    top->clk_i = 1;
    top->eval();
    top->clk_i = 0;
    top->eval();
    uint16_t now_mask = top->measuring_o;
    value |= (now_mask != 0) << 2;
    out.clock(value);
    if ((value & 1) || now_mask != mask) {
      std::vector<uint8_t> payload;
      put(payload, now_mask, 2);
      payload.insert(payload.end(), decision.begin(), decision.end());
      events.record(clock_n, payload);
    }
    mask = now_mask;
    clock_n++;
  };
  top->clk_i = 0;
  top->level_i = 1;
  top->heard_valid_i = 0;
  top->heard_i = 0;
  harness::reset(*top);
  for (int op; (op = in.op()) >= 0;) {
    switch (op) {
      case 'L': {
        uint8_t level = in.u8();
        uint8_t heard = in.u8();
        for (uint32_t n = in.u32(); n > 0; n--) clock(level, heard);
        break;
      }
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
