// uart_tx under the stimulus of crates/rtl-check (`rtl_check::uart_tx`): its buffer is a
// synchronous-read RAM here, as the block RAM it reads on the board.
//
// Records: 'T' u32 inc, u32 modulo (the timing inputs, held); 'W' u8 addr, u8 data (a buffer
// write, between clocks); 'S' u8 len (one clock with start_i); 'R' u32 n (n clocks without);
// 'X' (reset). Outputs each clock after its edge: bit 0 tx_o, bit 1 de_o.
#include <memory>

#include "Vuart_tx.h"
#include "harness.h"
#include "verilated.h"

int main(int argc, char** argv) {
  if (argc != 3) harness::fail("usage: check <stimulus> <outputs>");
  harness::Stimulus in(argv[1]);
  harness::Outputs out(argv[2]);
  auto ctx = std::make_unique<VerilatedContext>();
  auto top = std::make_unique<Vuart_tx>(ctx.get());
  uint8_t ram[256] = {};
  auto reset = [&] {
    top->clk_i = 0;
    harness::reset(*top);
  };
  auto clock = [&] {
    uint8_t addr = top->rd_addr_o;
    top->clk_i = 1;
    top->eval();
    // The RAM's output register takes the address presented before the edge.
    top->rd_data_i = ram[addr];
    top->clk_i = 0;
    top->eval();
    out.clock(static_cast<uint8_t>(top->tx_o | (top->de_o << 1)));
  };
  top->start_i = 0;
  top->clear_i = 0;
  top->len_i = 0;
  reset();
  for (int op; (op = in.op()) >= 0;) {
    switch (op) {
      case 'T':
        top->inc_i = in.u32();
        top->modulo_i = in.u32();
        break;
      case 'W': {
        uint8_t addr = in.u8();
        ram[addr] = in.u8();
        break;
      }
      case 'S':
        top->len_i = in.u8();
        top->start_i = 1;
        clock();
        top->start_i = 0;
        break;
      case 'R':
        for (uint32_t n = in.u32(); n > 0; n--) clock();
        break;
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
