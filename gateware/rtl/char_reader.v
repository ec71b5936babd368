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
  localparam int CharBits = 11;
  localparam int GlitchesMax = 3;
  // lead and lag: signed, PhaseWidth + 1 bits (a bit's balance is within +-modulo).
  localparam int BalanceWidth = PhaseWidth + 1;

  // CHAR_READER_RESET.
  logic [3:0]              bit_q, bit_d;
  logic [PhaseWidth-1:0]   rem_q, rem_d;
  logic [BalanceWidth-1:0] lead_q, lead_d;
  logic [BalanceWidth-1:0] lag_q, lag_d;
  logic [10:0]             shift_q, shift_d;
  logic                    tie_q, tie_d;
  logic [1:0]              glitches_q, glitches_d;
  logic                    pair_open_q, pair_open_d;
  logic [PhaseWidth-1:0]   pair_left_q, pair_left_d;

  logic                    active, ends, off_grid, pair_runs;
  logic [BalanceWidth-1:0] total, twice_rem, modulo_s, modulo_less_two_inc_s;
  logic [PhaseWidth:0]     pair_less;

  always_comb begin
    bit_d       = bit_q;
    rem_d       = rem_q;
    lead_d      = lead_q;
    lag_d       = lag_q;
    shift_d     = shift_q;
    tie_d       = tie_q;
    glitches_d  = glitches_q;
    pair_open_d = pair_open_q;
    pair_left_d = pair_left_q;
    active      = bit_q < 4'(CharBits);
    // Every comparison and sum below reads registers and configuration only: one adder deep.
    ends        = rem_q <= inc_i;
    off_grid    = rem_q > quarter_i && rem_q < three_quarters_i;
    pair_runs   = pair_open_q && !edge_i;
    pair_less   = {1'b0, pair_left_q} - {1'b0, inc_i};
    total       = level_i ? lead_q : lag_q;
    twice_rem   = {rem_q, 1'b0};
    modulo_s    = {1'b0, modulo_i};
    modulo_less_two_inc_s = {1'b0, modulo_less_two_inc_i};
    if (start_i) begin
      // The start edge's clock: the line low on it.
      bit_d       = '0;
      rem_d       = modulo_less_inc_i;
      lead_d      = modulo_less_two_inc_s;
      lag_d       = -modulo_s;
      shift_d     = '0;
      tie_d       = 1'b0;
      glitches_d  = '0;
      pair_open_d = 1'b0;
      pair_left_d = '0;
    end else if (active && step_i) begin
      if (edge_i) begin
        if (!off_grid || pair_open_q) begin
          // On the grid, or the second edge of a glitch inside a bit.
          pair_open_d = 1'b0;
          pair_left_d = '0;
        end else begin
          glitches_d  = glitches_q == 2'(GlitchesMax) ? glitches_q : glitches_q + 2'd1;
          pair_open_d = 1'b1;
          pair_left_d = half_less_inc_i;
        end
      end else if (pair_runs) begin
        if (!pair_less[PhaseWidth]) begin
          pair_left_d = pair_less[PhaseWidth-1:0];
        end else begin
          pair_open_d = 1'b0;
          pair_left_d = '0;
        end
      end
      if (!ends) begin
        // Both always summed (a zero added to the one that stays): a register kept only on
        // some branches becomes a clock enable behind the comparison, a slower path.
        rem_d  = rem_q - inc_i;
        lead_d = lead_q - (level_i ? '0 : two_inc_i);
        lag_d  = lag_q + (level_i ? two_inc_i : '0);
      end else begin
        // The bit is the sign of its balance; the units past its end open the next one.
        bit_d   = bit_q + 4'd1;
        shift_d = {!total[BalanceWidth-1] && total != '0, shift_q[10:1]};
        tie_d   = tie_q || total == '0;
        rem_d   = rem_q + modulo_less_inc_i;
        if (level_i) begin
          lead_d = modulo_s;
          lag_d  = -modulo_less_two_inc_s - twice_rem;
        end else begin
          lead_d = modulo_less_two_inc_s + twice_rem;
          lag_d  = -modulo_s;
        end
      end
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      bit_q       <= 4'(CharBits);
      rem_q       <= '0;
      lead_q      <= '0;
      lag_q       <= '0;
      shift_q     <= '0;
      tie_q       <= 1'b0;
      glitches_q  <= '0;
      pair_open_q <= 1'b0;
      pair_left_q <= '0;
    end else begin
      bit_q       <= bit_d;
      rem_q       <= rem_d;
      lead_q      <= lead_d;
      lag_q       <= lag_d;
      shift_q     <= shift_d;
      tie_q       <= tie_d;
      glitches_q  <= glitches_d;
      pair_open_q <= pair_open_d;
      pair_left_q <= pair_left_d;
    end
  end

  assign bit_o       = bit_q;
  assign shift_o     = shift_q;
  assign tie_o       = tie_q;
  assign glitches_o  = glitches_q;
  assign glitches_next_o = glitches_d;
  assign pair_open_o = pair_open_q;
  assign rem_o       = rem_q;
  assign lead_o      = lead_q;
  assign lag_o       = lag_q;
  assign pair_left_o = pair_left_q;
endmodule
