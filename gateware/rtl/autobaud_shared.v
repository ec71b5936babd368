// The search's slower channels taking turns in one datapath: the clocks of a frame of Slots
// are each one channel's turn or free (autobaud_slots.svh's turn table, from the model's
// dp_phy::autobaud::OVERSAMPLED: a channel whose period divides the frame has a turn every
// period, one whose period is whole frames has one a frame), and a channel samples the line on
// every Frames-th of its turns. Each is then exactly an autobaud_channel with that period and
// phase, and the model's AutoBaud::sampled on that schedule. Channel c is the rate of index c.
//
// The channels' registers live in block RAM, one word a channel (autobaud_channel_step.v's
// packed state and the turns left before its next sample). The word of a turn is read from
// the RAM two clocks ahead and kept in flip-flops (word_q) from the clock before its turn, so
// the step starts from a flip-flop rather than the RAM's slow read (in the RTL only: the
// model has no RAM); the word the step makes is kept in flip-flops too (written_q) and written
// back a clock after its turn. A channel whose last turn was two clocks before (1.5M's) has
// its word from written_q, which the RAM has not yet taken when that read is made; no channel
// has two turns in a row, nor turns three clocks apart (a read would meet the write of its own
// word; crates/rtl-check refuses such a table). A channel whose word has not been written
// since reset takes its reset value instead (fresh_q), as block RAM cannot be reset. The
// figures of the channel in turn come from a table written from the model
// (autobaud_slots.svh, by crates/rtl-check).
//
// At most one channel decides on a clock: detect_o and reject_o are one-hot, and the decision's
// byte, code and start age are that channel's. measuring_o keeps each channel's flag in
// flip-flops, for the search's own use and for rtl-check.
`default_nettype none

module autobaud_shared #(
  // Clocks in the frame of turns, and the channels that take them.
  parameter int Slots         = 24,
  parameter int Channels      = 8,
  // Widths: the widest of the channels' (their figures are zero-extended to these).
  parameter int PhaseWidth    = 7,
  parameter int IdleWidth     = 10,
  parameter int PendWidth     = 4,
  parameter int TimeWidth     = 8,
  parameter int AltWidth      = 5,
  parameter int FrameWidth    = 6,
  // Wide enough for the longest sample period in clocks.
  parameter int PeriodWidth   = 8,
  parameter int ClocksWidth   = 24,
  parameter int PendOutWidth  = 12
) (
  input  wire                     clk_i,
  input  wire                     rst_ni,
  input  wire                     level_i,
  input  wire [Channels-1:0]      heard_i,
  input  wire                     heard_any_i,
  output wire [Channels-1:0]      detect_o,
  output wire [Channels-1:0]      reject_o,
  output wire [1:0]               reject_code_o,
  output wire [7:0]               byte_o,
  // The deciding channel's clocks since its character's start edge.
  output wire [ClocksWidth-1:0]   start_clocks_o,
  // The deciding channel's samples within which a next edge cancels its idle line's last one.
  output wire [PendOutWidth-1:0]  cancel_left_o,
  // The deciding channel's idle line rose after its character's end.
  output wire                     rose_after_end_o,
  // Each channel samples the line on this clock (only the one in turn can).
  output wire [Channels-1:0]      samples_o,
  output wire [Channels-1:0]      measuring_o
);
  localparam int SlotWidth   = $clog2(Slots);
  localparam int ChanWidth   = $clog2(Channels);
  localparam int ReaderWidth = 4 * PhaseWidth + 21;
  // What a decision reads of a reader, made a clock ahead (autobaud_channel_step.v's
  // read_ahead), and its value for a reader at reset: framed but for the stop bit (a zero
  // byte has even parity, and its stop bit would be the balance's sign), both balances zero.
  localparam int AheadWidth  = 8;
  localparam logic [AheadWidth-1:0] AheadReset = 8'b0010_0101;
  localparam int StateWidth  = 2 * PendWidth + 2 * IdleWidth + 2 * TimeWidth + AltWidth + 8
                               + 2 * ReaderWidth + 2 * AheadWidth;
  localparam int WordWidth   = StateWidth + FrameWidth;
  localparam logic [ReaderWidth-1:0] ReaderReset = {4'd11, (ReaderWidth - 4)'(0)};

  // The clock of the frame, and the channel in turn on it (turn_q: a channel's turn, not a
  // free slot); the turn of the next clock is looked up a clock ahead (turn_valid,
  // turn_channel: turn_of(slot_d), the table's), so that the RAM reads its word.
  logic [SlotWidth-1:0] slot_q, slot_d;
  logic                 turn_q, turn_valid;
  logic [ChanWidth-1:0] channel_q, turn_channel;
  logic [Channels-1:0]  fresh_q, fresh_d;
  // Whether this clock's turn samples (samples_q's one bit set), kept in a register of its
  // own, set a clock ahead from the next turn: the step reads it with no multiplexer by
  // channel before it.
  logic                 sample_q;
  logic [Channels-1:0]  measuring_q, measuring_d;
  // Whether each channel samples on its next turn (its word's frames left are 0 then), kept
  // beside the RAM: the sample strobe, which the whole receive path waits on, comes from a
  // register, not through the RAM's word.
  logic [Channels-1:0]  sample_next_q, sample_next_d;
  // Each channel's sample strobe, registered (the receive path's step and line at its rate
  // come from a flip-flop, not through the turn's multiplexers): the next clock's turn is
  // never this clock's channel (no two turns in a row), so its sample_next_q bit is already
  // the one its turn reads.
  logic [Channels-1:0]  samples_q, samples_d, samples_reset;
  // A read (for the turn after next) never meets the write of its own word on the same edge:
  // that write is of the turn three clocks before the read's (crates/rtl-check refuses a
  // table with turns three clocks apart; before a free slot nothing is read). no_rw_check
  // keeps yosys from adding the flip-flops and multiplexers that would give a read colliding
  // with a write the old word (about 330 DFF).
  (* ram_style = "block", no_rw_check *)
  logic [WordWidth-1:0] words [Channels];
  // The RAM's read (the turn after next's word), the word of this clock's turn, and the word
  // the last clock's turn made, with its channel, which the RAM takes on this clock's edge.
  logic [WordWidth-1:0] read_q;
  logic [WordWidth-1:0] word_q, word_d;
  logic [WordWidth-1:0] written_q;
  logic                 written_valid_q;
  logic [ChanWidth-1:0] written_channel_q;
  logic [SlotWidth-1:0] slot_after_next;
  logic                 turn_after_next_valid;
  logic [ChanWidth-1:0] turn_after_next_channel;
  assign {turn_valid, turn_channel} = turn_of(slot_d);
  assign slot_after_next = slot_d == SlotWidth'(Slots - 1) ? '0 : slot_d + 1'b1;
  assign {turn_after_next_valid, turn_after_next_channel} = turn_of(slot_after_next);

  // The channel's figures (autobaud_slots.svh).
  logic [PhaseWidth-1:0] inc, modulo, quarter, three_quarters, half_less_inc;
  logic [PhaseWidth:0]   two_inc;
  logic [PhaseWidth-1:0] modulo_less_inc, modulo_less_two_inc;
  logic [PendWidth-1:0]  glitch;
  logic [IdleWidth-1:0]  tsyn_less_one;
  logic [TimeWidth-1:0]  to_middle, middle_to_end, start_bit;
  logic [FrameWidth-1:0] frames_less_one;
  // TSYN less one and the stop bit's end, added: the idle line's high plus the start's age
  // passes it when the line rose after the character's end (autobaud_channel.v).
  localparam int EndWidth = (IdleWidth > TimeWidth ? IdleWidth : TimeWidth) + 1;
  logic [EndWidth-1:0]   tsyn_past_end;
  logic [PeriodWidth-1:0] sample_period;

  // The table's widths.
  localparam int P = PhaseWidth;
  localparam int G = PendWidth;
  localparam int I = IdleWidth;
  localparam int T = TimeWidth;
  localparam int F = FrameWidth;
  localparam int E = EndWidth;
  localparam int Q = PeriodWidth;
  localparam int C = ChanWidth;

`include "autobaud_slots.svh"

  logic [StateWidth-1:0] state, state_next;
  logic [FrameWidth-1:0] frames_left, frames_next;
  logic                  sample, heard;
  logic                  detect, reject, measuring_next;
  logic [PendWidth-1:0]  cancel_left;
  assign cancel_left_o = PendOutWidth'(cancel_left);

  // The start age in clocks: the channel in turn samples every sample_period clocks (the
  // table's); both candidates come from its word (early in the clock), each with its own
  // multiplier and its own comparison for the rise, and the step's choice, late in the clock,
  // only picks one (one multiplier after the choice was the clock's longest path).
  logic [TimeWidth-1:0]   since_t0;
  logic [AltWidth-1:0]    alt;
  logic                   from_alt;
  logic [TimeWidth-1:0]   since_alt;
  assign since_alt      = since_t0 - TimeWidth'(alt);
  assign start_clocks_o = from_alt ? ClocksWidth'(since_alt) * ClocksWidth'(sample_period)
                                   : ClocksWidth'(since_t0) * ClocksWidth'(sample_period);
  logic [IdleWidth-1:0]   high_left;
  assign rose_after_end_o = from_alt
      ? EndWidth'(high_left) + EndWidth'(since_alt) > tsyn_past_end
      : EndWidth'(high_left) + EndWidth'(since_t0) > tsyn_past_end;

  // A channel's word as reset: its idle line's figures (idle_reset_of, the table's) and the
  // rest constant; the word of the first turn after reset is word_q's reset value.
  function automatic logic [WordWidth-1:0] reset_word(input logic [PendWidth+IdleWidth-1:0] idle);
    logic [PendWidth-1:0] edge_left;
    logic [IdleWidth-1:0] tsyn_left;
    edge_left = idle[IdleWidth+:PendWidth];
    tsyn_left = idle[0+:IdleWidth];
    reset_word = {FrameWidth'(0), 1'b1, edge_left, PendWidth'(0), tsyn_left, tsyn_left, 1'b0,
                  TimeWidth'(0), TimeWidth'(0), 5'd0, AltWidth'(0), 1'b0, ReaderReset,
                  ReaderReset, AheadReset, AheadReset};
  endfunction
  localparam logic [ChanWidth:0]   FirstTurn = turn_of('0);
  localparam logic [WordWidth-1:0] FirstWord =
    reset_word(idle_reset_of(FirstTurn[ChanWidth-1:0]));
  assign {frames_left, state} = word_q;
  assign sample      = sample_q;
  assign frames_next = sample ? frames_less_one : frames_left - 1'b1;
  assign heard       = heard_i[channel_q];

  always_comb begin
    slot_d = slot_q == SlotWidth'(Slots - 1) ? '0 : slot_q + 1'b1;
    fresh_d = fresh_q;
    measuring_d = measuring_q;
    sample_next_d = sample_next_q;
    if (turn_q) begin
      fresh_d[channel_q] = 1'b0;
      measuring_d[channel_q] = measuring_next;
      sample_next_d[channel_q] = frames_next == '0;
    end
    // The next turn's word: its channel is never this clock's (no two turns in a row), so its
    // fresh flag is already the one its turn reads; a turn two clocks before it made the word
    // the RAM takes on this clock's edge, too late for the read.
    if (fresh_q[turn_channel]) begin
      word_d = reset_word(idle_reset_of(turn_channel));
    end else if (written_valid_q && written_channel_q == turn_channel) begin
      word_d = written_q;
    end else begin
      word_d = read_q;
    end
  end

  // The step's other view of the measuring flag is for the other caller.
  /* verilator lint_off PINCONNECTEMPTY */
  autobaud_channel_step #(
    .PhaseWidth(PhaseWidth), .IdleWidth(IdleWidth), .PendWidth(PendWidth),
    .TimeWidth(TimeWidth), .AltWidth(AltWidth)
  ) u_step (
    .inc_i                (inc),
    .modulo_i             (modulo),
    .quarter_i            (quarter),
    .three_quarters_i     (three_quarters),
    .half_less_inc_i      (half_less_inc),
    .two_inc_i            (two_inc),
    .modulo_less_inc_i    (modulo_less_inc),
    .modulo_less_two_inc_i(modulo_less_two_inc),
    .glitch_i             (glitch),
    .tsyn_less_one_i      (tsyn_less_one),
    .to_middle_i          (to_middle),
    .middle_to_end_i      (middle_to_end),
    .start_bit_i          (start_bit),
    .sample_i             (sample),
    .level_i,
    .heard_i              (heard),
    .heard_any_i,
    .state_i              (state),
    .state_o              (state_next),
    .detect_o             (detect),
    .reject_o             (reject),
    .reject_code_o,
    .byte_o,
    .since_t0_o           (since_t0),
    .alt_o                (alt),
    .from_alt_o           (from_alt),
    .cancel_left_o        (cancel_left),
    .high_left_o          (high_left),
    .measuring_o          (),
    .measuring_next_o     (measuring_next)
  );
  /* verilator lint_on PINCONNECTEMPTY */

  logic                 reset_turn;
  logic [ChanWidth-1:0] reset_channel;
  assign {reset_turn, reset_channel} = turn_of('0);
  for (genvar c = 0; c < Channels; c++) begin : g_decisions
    assign detect_o[c] = turn_q && detect && channel_q == ChanWidth'(c);
    assign reject_o[c] = turn_q && reject && channel_q == ChanWidth'(c);
    assign samples_d[c] = turn_valid && turn_channel == ChanWidth'(c) && sample_next_q[c];
    assign samples_reset[c] = reset_turn && reset_channel == ChanWidth'(c);
  end
  assign samples_o = samples_q;
  assign measuring_o = measuring_q;

  // The RAM: written a clock after each turn and read every clock, never at the same word.
  always_ff @(posedge clk_i) begin
    if (written_valid_q) words[written_channel_q] <= written_q;
    if (turn_after_next_valid) read_q <= words[turn_after_next_channel];
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      slot_q      <= '0;
      {turn_q, channel_q} <= turn_of('0);
      fresh_q     <= '1;
      measuring_q <= '0;
      sample_next_q <= '1;
      samples_q   <= samples_reset;
      sample_q    <= |samples_reset;
      word_q      <= FirstWord;
      written_q   <= '0;
      written_valid_q <= 1'b0;
      written_channel_q <= '0;
    end else begin
      slot_q      <= slot_d;
      turn_q      <= turn_valid;
      channel_q   <= turn_channel;
      fresh_q     <= fresh_d;
      measuring_q <= measuring_d;
      sample_next_q <= sample_next_d;
      samples_q   <= samples_d;
      sample_q    <= |samples_d;
      word_q      <= word_d;
      written_q   <= {frames_next, state_next};
      written_valid_q <= turn_q;
      written_channel_q <= channel_q;
    end
  end
endmodule
