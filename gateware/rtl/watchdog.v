// A watchdog as the transceiver counts it: dp_phy::watchdog::Watchdog's twin
// (crates/dp-phy/src/watchdog.rs). The baud-control watchdog and the DP watchdog are each one.
//
// The model keeps the deadline, a tick; this counts the clocks left to it instead (left_q:
// deadline - now at the start of each clock, saturating at 0), the same register seen from
// the clock, and no tick counter. Per clock: the commands first (start_i, start_if_stopped_i
// with clocks_i; stop_i), then, where check_i lets it, expired_o says it ran out on this clock,
// and it stops. Width holds the longest run (the baud watchdog's 200 ms at 48 MHz: 24 bits).
`default_nettype none

module watchdog #(
  parameter int Width = 24
) (
  input  wire             clk_i,
  input  wire             rst_ni,
  input  wire [Width-1:0] clocks_i,
  input  wire             start_i,
  input  wire             start_if_stopped_i,
  input  wire             stop_i,
  input  wire             check_i,
  output wire             expired_o,
  output wire             running_o,
  output wire [Width-1:0] left_o
);
  // Watchdog::STOPPED.
  logic             running_q, running_d;
  logic [Width-1:0] left_q, left_d;

  // The commands come late in the transceiver's clock: what a start and the registers each
  // give is worked out apart, and the commands only choose (one LUT level after them).
  logic             starts, due, expired;
  logic [Width-1:0] left_after_start, left_after_clock;

  always_comb begin
    starts           = start_i || (start_if_stopped_i && !running_q);
    due              = running_q && left_q == '0;
    left_after_start = clocks_i != '0 ? clocks_i - 1'b1 : '0;
    left_after_clock = left_q != '0 ? left_q - 1'b1 : '0;
    expired   = check_i && !stop_i && (starts ? clocks_i == '0 : due);
    running_d = !stop_i && (starts || running_q) && !expired;
    // Stopped, or due: 0 (the model's left() is None, or 0).
    left_d    = !running_d ? '0 : starts ? left_after_start : left_after_clock;
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      running_q <= 1'b0;
      left_q    <= '0;
    end else begin
      running_q <= running_d;
      left_q    <= left_d;
    end
  end

  assign expired_o = expired;
  assign running_o = running_q;
  assign left_o    = left_q;
endmodule
