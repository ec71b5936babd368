// delimiter under the stimulus of crates/rtl-check (`rtl_check::blocks::delimiter_cases`).
//
// Records, one clock each unless they say: 'C' u32 tsyn, u32 gap (config_i); 'Z' (reset_i);
// 'K' u8 flags (bit 0 a character, bit 1 the idle check), u8 byte, u8 error, u32 idle before,
// u32 end, u32 idle, u32 now; 'I' u32 n, u32 idle, u32 now (n clocks of idle checks, idle and now
// counting up); 'N' u32 n (n clocks with nothing). Outputs each clock, read before its edge:
// bit 0 deliver_o, bit 1 not_synced_o, bits 2-5 status_o when delivering. Events: for each
// delivery, the payload u8 status, u8 len, u32 end, then the telegram's bytes from the RAM.
#include <memory>

#include "Vdelimiter.h"
#include "harness.h"
#include "verilated.h"

int main(int argc, char** argv) {
  if (argc != 4) harness::fail("usage: check <stimulus> <outputs> <events>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  harness::Events events(argv[3]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vdelimiter>(ctx.get());
  uint8_t ram[256] = {};
  uint32_t clock_index = 0;
  auto idle_inputs = [&] {
    top->config_i = 0;
    top->reset_i = 0;
    top->char_i = 0;
    top->idle_check_i = 0;
  };
  auto clock = [&] {
    top->eval();
    bool deliver = top->deliver_o;
    out.clock(static_cast<uint8_t>(deliver | (top->not_synced_o << 1) |
                                   (deliver ? top->status_o << 2 : 0)));
    uint8_t status = top->status_o, len = top->len_o;
    uint32_t end = top->end_o;
    if (top->wr_o) ram[top->wr_addr_o] = top->wr_data_o;
    top->clk_i = 1;
    top->eval();
    top->clk_i = 0;
    top->eval();
    if (deliver) {
      std::vector<uint8_t> payload = {status, len};
      for (int i = 0; i < 4; i++) payload.push_back((end >> (8 * i)) & 0xFF);
      payload.insert(payload.end(), ram, ram + len);
      events.record(clock_index, payload);
    }
    clock_index++;
    idle_inputs();
  };
  idle_inputs();
  top->clk_i = 0;
  harness::reset(*top);
  for (int op; (op = in.op()) >= 0;) {
    switch (op) {
      case 'C':
        top->tsyn_clocks_i = in.u32();
        top->gap_clocks_i = in.u32();
        top->config_i = 1;
        clock();
        break;
      case 'Z':
        top->reset_i = 1;
        clock();
        break;
      case 'K': {
        uint8_t flags = in.u8();
        top->char_byte_i = in.u8();
        top->char_error_i = in.u8();
        top->char_idle_before_i = in.u32();
        top->char_end_i = in.u32();
        uint32_t idle = in.u32();
        top->idle_over_gap_i = idle > top->gap_clocks_o;
        top->now_i = in.u32();
        top->char_i = flags & 1;
        top->idle_check_i = (flags >> 1) & 1;
        clock();
        break;
      }
      case 'I': {
        uint32_t n = in.u32(), idle = in.u32(), now = in.u32();
        for (uint32_t i = 0; i < n; i++) {
          top->idle_check_i = 1;
          top->idle_over_gap_i = idle + i > top->gap_clocks_o;
          top->now_i = now + i;
          clock();
        }
        break;
      }
      case 'N':
        for (uint32_t n = in.u32(); n > 0; n--) clock();
        break;
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
