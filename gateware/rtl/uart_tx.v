// The transmitter: dp_phy::uart::UartTx's twin (crates/dp-phy/src/uart.rs), as the transceiver
// uses it. PROFIBUS characters (start 0, 8 data bits LSB first, even parity, stop 1) back to
// back, the driver enabled only while they go out.
//
// Timing is the model's phase accumulator (BitTiming), ph_q the model's ph at every clock. The
// transceiver's own timing is whole clocks (BitTiming::whole_clocks): inc_i 1 and modulo_i the
// clocks of a bit, PhaseWidth bits wide.
//
// start_i is the model's send(0, bytes) and the tick of the same clock (the transceiver sends
// then ticks). The transceiver waits min TSDR before it starts, so the model's leading idle
// bits (a master station's TSYN) are not built here, nor its fault injection (tests only).
//
// Lengths are 8 bits: a telegram has at most 255 characters (the model's MAX_TELEGRAM_LEN).
//
// The bytes come from a synchronous-read buffer (block RAM): rd_addr_o names the next
// character's byte while one goes out (the first one's while idle), so byte_q takes it at the
// character boundary where the model reads buf[index].
`default_nettype none

module uart_tx #(
  // A test build's deliberate fault (rtl-check proves it finds it): the output one clock late.
  parameter int LateByOne = 0,
  // Holds the widest rate's modulo (the clocks of a 9.6k bit: 13 bits).
  parameter int PhaseWidth = 13
) (
  input  wire        clk_i,
  input  wire        rst_ni,
  input  wire [PhaseWidth-1:0] inc_i,
  input  wire [PhaseWidth-1:0] modulo_i,
  // A new transmitter (the model's UartTx::new at a change of rate): what was under way
  // stops, and a start on the same clock is dropped (the transceiver drops the response a
  // change of rate finds waiting). Only the sending flag takes it: the rest is read only
  // while sending, and a start sets it all, so the clear (late in the top's clock) does not
  // reach their enables.
  input  wire        clear_i,
  input  wire        start_i,
  input  wire [7:0]  len_i,
  output wire [7:0]  rd_addr_o,
  input  wire [7:0]  rd_data_i,
  output wire        tx_o,
  output wire        de_o,
  output wire        busy_o
);
  // TX_RESET.
  logic [7:0]  index_q, index_d;
  logic [3:0]  bit_q, bit_d;
  logic [PhaseWidth-1:0] ph_q, ph_d;
  logic        sending_q, sending_d;
  logic [7:0]  len_q, len_d;
  logic [7:0]  byte_q, byte_d;
  logic [PhaseWidth:0] ph_next;

  always_comb begin
    index_d   = index_q;
    bit_d     = bit_q;
    ph_d      = ph_q;
    sending_d = sending_q;
    len_d     = len_q;
    byte_d    = byte_q;
    ph_next   = {1'b0, ph_q} + {1'b0, inc_i};
    if (start_i) begin
      // send(): the first character's start bit; then this clock's tick, which cannot cross a
      // boundary (a bit lasts at least 3 clocks).
      index_d   = '0;
      bit_d     = '0;
      ph_d      = inc_i;
      sending_d = len_i != 0;
      len_d     = len_i;
      byte_d    = rd_data_i;
    end else if (sending_q) begin
      if (ph_next < {1'b0, modulo_i}) begin
        ph_d = ph_next[PhaseWidth-1:0];
      end else begin
        ph_d = PhaseWidth'(ph_next - {1'b0, modulo_i});
        if (bit_q < 4'd10) begin
          bit_d = bit_q + 1'b1;
        end else begin
          bit_d     = '0;
          index_d   = index_q + 1'b1;
          sending_d = {1'b0, index_q} + 9'd1 < {1'b0, len_q};
          byte_d    = rd_data_i;
        end
      end
    end
    if (clear_i) sending_d = 1'b0;
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      index_q   <= '0;
      bit_q     <= '0;
      ph_q      <= '0;
      sending_q <= 1'b0;
      len_q     <= '0;
      byte_q    <= '0;
    end else begin
      index_q   <= index_d;
      bit_q     <= bit_d;
      ph_q      <= ph_d;
      sending_q <= sending_d;
      len_q     <= len_d;
      byte_q    <= byte_d;
    end
  end

  // The next character's byte while one goes out, the first one's while idle.
  assign rd_addr_o = sending_q ? index_q + 1'b1 : 8'd0;

  // char_bit: the line level of bit bit_q of byte_q.
  logic       level;
  logic [2:0] data_bit;
  assign data_bit = bit_q[2:0] - 3'd1;
  always_comb begin
    case (bit_q)
      4'd0:    level = 1'b0;
      4'd9:    level = ^byte_q;
      4'd10:   level = 1'b1;
      default: level = byte_q[data_bit];
    endcase
  end

  logic tx, de;
  assign tx = sending_q ? level : 1'b1;
  assign de = sending_q;

  generate
    if (LateByOne != 0) begin : g_late
      logic tx_late_q, de_late_q;
      always_ff @(posedge clk_i or negedge rst_ni) begin
        if (!rst_ni) begin
          tx_late_q <= 1'b1;
          de_late_q <= 1'b0;
        end else begin
          tx_late_q <= tx;
          de_late_q <= de;
        end
      end
      assign tx_o = tx_late_q;
      assign de_o = de_late_q;
    end else begin : g_on_time
      assign tx_o = tx;
      assign de_o = de;
    end
  endgenerate
  assign busy_o = sending_q;
endmodule

`default_nettype wire
