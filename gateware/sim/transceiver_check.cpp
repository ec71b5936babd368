// transceiver (the top) under the stimulus of crates/rtl-check
// (`rtl_check::blocks::transceiver`): the line of a case, clock by clock, and the responses
// handed to its transmitter.
//
// Records: 'L' u8 level, u32 n (n clocks with the line at level, before the synchroniser);
// 'M' u8 bits (min TSDR, held); 'B' u8 addr, u8 data (a byte into the response buffer, between
// clocks: a synchronous-read RAM here, as the responder's block RAM on the board; its output
// register shows it as it would a clock after the write); 'P' u8 len, u32 not_before
// (respond_i on the next clock).
// Outputs each clock: bit 0 a telegram delivered on it (read before its edge), then after the
// edge bit 1 a trial, bit 2 locked, bit 3 a telegram under way, bit 4 a character under way,
// bit 5 tx_o, bit 6 de_o.
// Events: for each delivery, u8 1, u8 status, u8 len, u32 end, then the telegram's bytes from
// the RAM; after it, for each change of the baud state, u8 2, u8 state, u8 rate, u8 fallback
// (0xFF with none); after it, for each change of the idle line at the rate heard, u8 3, u8
// idle, u32 idle_since (0 while not idle); for each respond_i, u8 4, u8 taken.
#include <array>
#include <memory>

#include "Vtransceiver.h"
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
  auto top = std::make_unique<Vtransceiver>(ctx.get());
  uint8_t ram[256] = {};
  uint8_t response[256] = {};
  uint8_t tx_addr = 0;
  uint32_t clock_n = 0;
  // The state and the idle line as last recorded (arrays: a clock allocates nothing).
  std::array<uint8_t, 3> last_state = {0, 0, 0xFF};
  std::array<uint8_t, 2> last_idle_flag = {3, 0};
  uint32_t last_idle_since = 0;
  auto clock = [&](uint8_t level) {
    top->rx_i = level;
    top->clk_i = 0;
    top->eval();
    bool deliver = top->deliver_o;
    uint8_t status = top->status_o, len = top->len_o;
    uint32_t end = top->end_o;
    if (top->wr_o) ram[top->wr_addr_o] = top->wr_data_o;
    if (top->respond_i) events.record(clock_n, {4, static_cast<uint8_t>(top->respond_ok_o)});
    tx_addr = top->tx_rd_addr_o;
    top->clk_i = 1;
    top->eval();
    // The RAM's output register takes the address presented before the edge.
    top->tx_rd_data_i = response[tx_addr];
    top->respond_i = 0;
    uint8_t state = top->state_o;
    out.clock(static_cast<uint8_t>(deliver | ((state == 1) << 1) | ((state == 2) << 2) |
                                   (top->in_telegram_o << 3) | (top->rx_active_o << 4) |
                                   (top->tx_o << 5) | (top->de_o << 6)));
    if (deliver) {
      std::vector<uint8_t> payload = {1, status, len};
      put(payload, end, 4);
      payload.insert(payload.end(), ram, ram + len);
      events.record(clock_n, payload);
    }
    std::array<uint8_t, 3> now = {state, static_cast<uint8_t>(top->rate_o),
                                  static_cast<uint8_t>(top->fallback_valid_o ? top->fallback_o
                                                                             : 0xFF)};
    if (now != last_state) {
      std::vector<uint8_t> payload = {2};
      payload.insert(payload.end(), now.begin(), now.end());
      events.record(clock_n, payload);
      last_state = now;
    }
    std::array<uint8_t, 2> idle_flag = {3, static_cast<uint8_t>(top->idle_o)};
    uint32_t idle_since = top->idle_o ? top->idle_since_o : 0;
    if (idle_flag != last_idle_flag || idle_since != last_idle_since) {
      std::vector<uint8_t> payload(idle_flag.begin(), idle_flag.end());
      put(payload, idle_since, 4);
      events.record(clock_n, payload);
      last_idle_flag = idle_flag;
      last_idle_since = idle_since;
    }
    clock_n++;
  };
  top->clk_i = 0;
  top->rx_i = 1;
  top->min_tsdr_bits_i = 11;
  top->respond_i = 0;
  harness::reset(*top);
  for (int op; (op = in.op()) >= 0;) {
    switch (op) {
      case 'L': {
        uint8_t level = in.u8();
        for (uint32_t n = in.u32(); n > 0; n--) clock(level);
        break;
      }
      case 'M':
        top->min_tsdr_bits_i = in.u8();
        break;
      case 'B': {
        uint8_t addr = in.u8();
        response[addr] = in.u8();
        if (addr == tx_addr) top->tx_rd_data_i = response[addr];
        break;
      }
      case 'P':
        top->respond_i = 1;
        top->respond_len_i = in.u8();
        top->respond_not_before_i = in.u32();
        break;
      default:
        harness::fail("unknown record");
    }
  }
  top->final();
  return 0;
}
