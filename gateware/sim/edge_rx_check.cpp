// edge_rx under the stimulus of crates/rtl-check (`rtl_check::blocks::edge_rx`).
//
// Records: 'T' u32 inc, modulo, quarter, three_quarters, half_less_inc, two_inc,
// modulo_less_inc, modulo_less_two_inc, start_end, stop_middle, stop_end (the rate's figures,
// held), period, wait (the receiver samples the line every period clocks, the first wait
// clocks from the next one: step_i, counted here as the top's sample counter will); 'N' u32
// (now_i of the next clock; it counts up a clock at a time); 'L' u8 level, u32 n (n clocks,
// the line held at level: no edge); 'K' u8 flags (bit 0 the line's level as sampled, an edge
// if it changed, on a sample tick only; bit 1 hand_over_i; bit 2 clear_i; bit 3
// hand_over_fell_last_i: the hand-over is the last clock's, with a fall there), u32
// idle_before, u32 hand_over_idle (the idle clocks before the hand-over's fall; one clock).
// Outputs each clock after its edge: bit 0 active_o, bit 1 char_o (out on that clock, decided
// on the one before), bits 2-3 stage_o, bit 4 next_active_o, bit 5 next_from_valid_o. An event
// on each clock with a character or a change of the current lane's deadline or next_from: the
// character (u8 byte, u8 error, u32 start, end, idle before; zeros with none), the deadline
// and next_from (u32 each, the RTL's TickWidth bits; all ones with none).
#include <memory>

#include "Vedge_rx.h"
#include "harness.h"
#include "verilated.h"

namespace {
using harness::put;
}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) harness::fail("usage: check <stimulus> <outputs> <events>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  harness::Events events(argv[3]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vedge_rx>(ctx.get());
  uint32_t clock_n = 0;
  uint8_t line = 1;
  harness::Samples samples;
  std::vector<uint8_t> last_lanes;
  auto clock = [&](uint8_t level, bool hand_over, bool clear, bool fell_last, uint32_t idle,
                   uint32_t hand_over_idle) {
    bool step = samples.clock();
    if (level != line && !step) harness::fail("an edge off the sample ticks");
    top->step_i = step;
    top->level_i = level;
    top->edge_i = level != line;
    top->hand_over_i = hand_over;
    top->clear_i = clear;
    top->idle_before_i = idle;
    top->hand_over_idle_i = hand_over_idle;
    // The hand-over at the step's own rate (the transceiver's check covers another).
    top->hand_over_fell_i = level != line && !level;
    top->hand_over_fell_last_i = fell_last;
    top->hand_over_step_i = step;
    top->hand_over_level_i = level;
    top->hand_over_edge_i = level != line;
    line = level;
    // The character out on this clock (decided on the last): read it before the edge.
    top->clk_i = 0;
    top->eval();
    bool got = top->char_o;
    std::vector<uint8_t> character;
    character.push_back(got ? top->char_byte_o : 0);
    character.push_back(got ? top->char_error_o : 0);
    put(character, got ? top->char_start_o : 0, 4);
    put(character, got ? top->char_end_o : 0, 4);
    put(character, got ? top->char_idle_before_o : 0, 4);
    top->clk_i = 1;
    top->eval();
    top->now_i = top->now_i + 1;
    top->clk_i = 0;
    top->eval();
    out.clock(static_cast<uint8_t>(top->active_o | (got << 1) | (top->stage_o << 2) |
                                   (top->next_active_o << 4) | (top->next_from_valid_o << 5)));
    std::vector<uint8_t> lanes;
    put(lanes, top->active_o ? top->deadline_o : 0xFFFFFFFFu, 4);
    put(lanes, top->next_from_valid_o ? top->next_from_o : 0xFFFFFFFFu, 4);
    if (got || lanes != last_lanes) {
      std::vector<uint8_t> payload = character;
      payload.insert(payload.end(), lanes.begin(), lanes.end());
      events.record(clock_n, payload);
      last_lanes = lanes;
    }
    clock_n++;
  };
  top->clk_i = 0;
  top->now_i = 0;
  top->level_i = 1;
  top->edge_i = 0;
  top->step_i = 0;
  top->hand_over_i = 0;
  top->hand_over_fell_i = 0;
  top->hand_over_fell_last_i = 0;
  top->clear_i = 0;
  harness::reset(*top);
  // The lanes as reset leaves them: what the first clock is compared with.
  put(last_lanes, 0xFFFFFFFFu, 4);
  put(last_lanes, 0xFFFFFFFFu, 4);
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
        top->start_end_i = in.u32();
        top->hand_over_inc_i = top->inc_i;
        top->hand_over_two_inc_i = top->two_inc_i;
        top->hand_over_quarter_i = top->quarter_i;
        top->hand_over_three_quarters_i = top->three_quarters_i;
        top->hand_over_half_less_inc_i = top->half_less_inc_i;
        top->hand_over_modulo_i = top->modulo_i;
        top->hand_over_modulo_less_inc_i = top->modulo_less_inc_i;
        top->hand_over_modulo_less_two_inc_i = top->modulo_less_two_inc_i;
        top->hand_over_start_end_i = top->start_end_i;
        top->stop_middle_i = in.u32();
        top->stop_end_i = in.u32();
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
        for (uint32_t n = in.u32(); n > 0; n--) clock(level, false, false, false, 0, 0);
        break;
      }
      case 'K': {
        uint8_t flags = in.u8();
        uint32_t idle = in.u32();
        uint32_t hand_over_idle = in.u32();
        clock(flags & 1, flags & 2, flags & 4, flags & 8, idle, hand_over_idle);
        break;
      }
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
