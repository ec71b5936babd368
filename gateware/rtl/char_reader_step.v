// One clock of a character reader: dp_phy::char_reader::CharReader::clock's twin, the logic of
// char_reader.v without its registers. The reader's registers come in packed (state_i) and go
// out as they become at this clock's edge (state_o), so one step can serve readers whose
// registers are kept elsewhere (autobaud_shared.v keeps seven channels' in block RAM).
//
// The packed state, most significant first: bit (4), rem (PhaseWidth), lead and lag
// (PhaseWidth + 1 each), shift (11), tie, glitches (2), pair_open, pair_left (PhaseWidth).
// Reset (CHAR_READER_RESET): bit 11, the rest 0.
`default_nettype none

module char_reader_step #(
  parameter int PhaseWidth = 19,
  // Derived; not to be set.
  parameter int StateWidth = 4 * PhaseWidth + 21
) (
  input  wire [PhaseWidth-1:0] inc_i,
  input  wire [PhaseWidth-1:0] modulo_i,
  input  wire [PhaseWidth-1:0] quarter_i,
  input  wire [PhaseWidth-1:0] three_quarters_i,
  input  wire [PhaseWidth-1:0] half_less_inc_i,
  input  wire [PhaseWidth:0]   two_inc_i,
  input  wire [PhaseWidth-1:0] modulo_less_inc_i,
  input  wire [PhaseWidth-1:0] modulo_less_two_inc_i,
  input  wire                  step_i,
  input  wire                  start_i,
  input  wire                  level_i,
  input  wire                  edge_i,
  input  wire [StateWidth-1:0] state_i,
  output logic [StateWidth-1:0] state_o
);
  localparam int CharBits = 11;
  localparam int GlitchesMax = 3;
  // lead and lag: signed, PhaseWidth + 1 bits (a bit's balance is within +-modulo).
  localparam int BalanceWidth = PhaseWidth + 1;

  logic [3:0]              bit_q, bit_d;
  logic [PhaseWidth-1:0]   rem_q, rem_d;
  logic [BalanceWidth-1:0] lead_q, lead_d;
  logic [BalanceWidth-1:0] lag_q, lag_d;
  logic [10:0]             shift_q, shift_d;
  logic                    tie_q, tie_d;
  logic [1:0]              glitches_q, glitches_d;
  logic                    pair_open_q, pair_open_d;
  logic [PhaseWidth-1:0]   pair_left_q, pair_left_d;

  assign {bit_q, rem_q, lead_q, lag_q, shift_q, tie_q, glitches_q, pair_open_q, pair_left_q} =
      state_i;
  assign state_o =
      {bit_d, rem_d, lead_d, lag_d, shift_d, tie_d, glitches_d, pair_open_d, pair_left_d};

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

endmodule
