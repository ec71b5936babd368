// One character read as it arrives: dp_phy::char_reader::CharReader's twin
// (crates/dp-phy/src/char_reader.rs), register for register.
//
// Started at a start edge (start_i, the fall's clock), it takes the line each clock (level_i,
// edge_i: it changed on this clock) and keeps the bits decided, each by the level the line held
// longer within it (tie_q: both equally long), and the glitches it takes to explain the edges
// off the bit grid (more than a quarter bit from a boundary; two within half a bit are one).
// After 11 bits it holds still. The search and the receiver read a character from it at their
// decision; what it gives is the model's replay of the edges, exactly (its property tests).
//
// Phase units are the rate's BitTiming reduced by gcd(inc, modulo) (BitTiming::reduced):
// PhaseWidth holds the modulo. A bit lasts at least 3 clocks, so at most one bit ends a clock.
// Every register is one adder's update from registers: the phase left in the bit counts down,
// the bit's balance (units high less units low) is kept as it would end with the line high
// (lead_q) and low (lag_q), so the bit that ends is a register's sign; the fractions and sums
// of a bit come in worked out, as CharReader::new works them out.
`default_nettype none

module char_reader #(
  parameter int PhaseWidth = 19
) (
  input  wire                  clk_i,
  input  wire                  rst_ni,
  input  wire [PhaseWidth-1:0] inc_i,
  input  wire [PhaseWidth-1:0] modulo_i,
  input  wire [PhaseWidth-1:0] quarter_i,
  input  wire [PhaseWidth-1:0] three_quarters_i,
  input  wire [PhaseWidth-1:0] half_less_inc_i,
  input  wire [PhaseWidth:0]   two_inc_i,
  input  wire [PhaseWidth-1:0] modulo_less_inc_i,
  input  wire [PhaseWidth-1:0] modulo_less_two_inc_i,
  // This clock is one of the reader's samples of the line (always, for a reader that samples
  // every clock); between samples it holds.
  input  wire                  step_i,
  input  wire                  start_i,
  input  wire                  level_i,
  input  wire                  edge_i,
  output wire [3:0]            bit_o,
  output wire [10:0]           shift_o,
  output wire                  tie_o,
  output wire [1:0]            glitches_o,
  // What glitches_o becomes at this clock's edge: the search decides on the reading through
  // this clock, this clock's line edge included.
  output wire [1:0]            glitches_next_o,
  output wire                  pair_open_o,
  output wire [PhaseWidth-1:0] rem_o,
  output wire [PhaseWidth:0]   lead_o,
  output wire [PhaseWidth:0]   lag_o,
  output wire [PhaseWidth-1:0] pair_left_o
);
  localparam int StateWidth = 4 * PhaseWidth + 21;
  // CHAR_READER_RESET: bit 11 (holding still), the rest 0.
  localparam logic [StateWidth-1:0] Reset = {4'd11, (StateWidth - 4)'(0)};

  logic [StateWidth-1:0] state_q, state_d;

  char_reader_step #(.PhaseWidth(PhaseWidth)) u_step (
    .inc_i, .modulo_i, .quarter_i, .three_quarters_i, .half_less_inc_i, .two_inc_i,
    .modulo_less_inc_i, .modulo_less_two_inc_i, .step_i, .start_i, .level_i, .edge_i,
    .state_i(state_q),
    .state_o(state_d)
  );

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) state_q <= Reset;
    else state_q <= state_d;
  end

  assign {bit_o, rem_o, lead_o, lag_o, shift_o, tie_o, glitches_o, pair_open_o, pair_left_o} =
      state_q;
  // The glitches field of the state to come: above pair_open and pair_left.
  assign glitches_next_o = state_d[PhaseWidth + 1 +: 2];
endmodule
