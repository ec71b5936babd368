// One rate's channel of the baud-rate search: a ChannelQ of dp_phy::autobaud::AutoBaud
// (crates/dp-phy/src/autobaud.rs) with that rate's idle line (its pending, high_since and
// high_before), register for register.
//
// It follows the idle line with the rate's glitches removed (an edge within Glitch clocks of
// the last one it kept cancels both), starts a measurement at a fall after Tsyn clocks of that
// line and a high longer than a glitch, reads the character from the start and from a second
// candidate start inside the start bit (two char_readers at the rate's constant figures), and
// decides at the middle of the last candidate's stop bit (at its end with the line low there):
// a start delimiter (detect_o), or why not (reject_o), both for this clock only.
//
// The model keeps ticks; this keeps what it compares them for, as clocks left (counting down to
// 0 and holding there, so a comparison is a zero test): the idle line's high_since and
// high_before as the clocks they still lack of Tsyn (high_left_q, before_left_q), the pending
// edge as the clocks a next edge would still cancel it within (cancel_left_q: 0 for none), the
// decision as the clocks to it; the measurement's start as the clocks since it (since_t0_q,
// wide enough for a start bit and a character, free-running between measurements), and the
// line's last edge as its age (the search's, shared). The detection's age goes out in clocks
// (start_clocks_o: the samples since the start the step chose, times the period), so the top
// compares it with its count of the trial's clocks and multiplies nothing.
// The logic is autobaud_channel_step.v's; this keeps its registers and its sample enable.
`default_nettype none

module autobaud_channel #(
  parameter int PhaseWidth       = 13,
  parameter int Inc              = 1,
  parameter int Modulo           = 5000,
  parameter int Quarter          = 1250,
  parameter int ThreeQuarters    = 3750,
  parameter int HalfLessInc      = 2499,
  parameter int TwoInc           = 2,
  parameter int ModuloLessInc    = 4999,
  parameter int ModuloLessTwoInc = 4998,
  parameter int Glitch           = 2499,
  parameter int Tsyn             = 162500,
  parameter int StopMiddle       = 52500,
  parameter int StopEnd          = 55000,
  parameter int StartBitClocks   = 5000,
  // Clocks between the channel's samples of the line, and the first of them after reset
  // (AutoBaud::sampled on a Schedule); every figure above is in samples.
  parameter int Period           = 1,
  parameter int Phase            = 0,
  // The rate's own widths: the idle line's clocks past Tsyn, the pending edge's age past
  // Glitch, a measurement's clocks (a start bit and a character), a start bit's clocks.
  parameter int IdleWidth        = 18,
  parameter int PendWidth        = 12,
  parameter int TimeWidth        = 16,
  parameter int AltWidth         = 13,
  // The search's: the start age in clocks it puts out, the pending edge.
  parameter int ClocksWidth      = 24,
  parameter int PendOutWidth     = 12
) (
  input  wire                 clk_i,
  input  wire                 rst_ni,
  input  wire                 level_i,
  // The receiver is on this rate; on any rate.
  input  wire                 heard_i,
  input  wire                 heard_any_i,
  output wire                 detect_o,
  output wire                 reject_o,
  // Reject: 0 off the grid, 1 no character, 2 no delimiter.
  output wire [1:0]           reject_code_o,
  output wire [7:0]           byte_o,
  // Clocks since the detected character's start edge: its samples since the start the step
  // chose, times the period (a constant, so shifts and adds).
  output wire [ClocksWidth-1:0]   start_clocks_o,
  // With a detection: the samples within which a next edge cancels the idle line's last one.
  output wire [PendOutWidth-1:0]  cancel_left_o,
  // With a detection: the idle line rose after the character's end (Detection::rose_after_end).
  output wire                 rose_after_end_o,
  // The channel samples the line on this clock.
  output wire                 sample_o,
  output wire                 measuring_o
);
  localparam int ReaderWidth = 4 * PhaseWidth + 21;
  // What a decision reads of a reader, made a clock ahead (autobaud_channel_step.v's
  // read_ahead), and its value for a reader at reset: framed but for the stop bit (a zero
  // byte has even parity, and its stop bit would be the balance's sign), both balances zero.
  localparam int AheadWidth  = 8;
  localparam logic [AheadWidth-1:0] AheadReset = 8'b0010_0101;
  localparam int StateWidth  = 2 * PendWidth + 2 * IdleWidth + 2 * TimeWidth + AltWidth + 8
                               + 2 * ReaderWidth + 2 * AheadWidth;
  localparam logic [ReaderWidth-1:0] ReaderReset = {4'd11, (ReaderWidth - 4)'(0)};
  // Reset is tick 0, with the line high since then: TSYN is all to come, and the line's last
  // edge is taken as at tick 0, within a glitch of it until the sample Glitch + 1 samples past
  // tick 0 (the Glitch-th sample after a first one past tick 0).
  localparam logic [StateWidth-1:0] Reset = {
    1'b1, PendWidth'(Phase == 0 ? Glitch + 1 : Glitch), PendWidth'(0), IdleWidth'(Tsyn),
    IdleWidth'(Tsyn), 1'b0, TimeWidth'(0), TimeWidth'(0), 5'd0, AltWidth'(0), 1'b0,
    ReaderReset, ReaderReset, AheadReset, AheadReset};

  localparam int PhaseBits = Period > 1 ? $clog2(Period) : 1;
  logic [PhaseBits-1:0]  phase_q, phase_d;
  logic [StateWidth-1:0] state_q, state_d;
  logic                  sample;
  logic [TimeWidth-1:0]  since_t0;
  logic [AltWidth-1:0]   alt;
  logic                  from_alt;
  logic [TimeWidth-1:0]  since_alt;
  assign since_alt      = since_t0 - TimeWidth'(alt);
  // Both candidates' ages are worked out from the registers; the step's choice, late in the
  // clock, only picks one (in the RTL only).
  assign start_clocks_o = from_alt ? ClocksWidth'(since_alt) * ClocksWidth'(Period)
                                   : ClocksWidth'(since_t0) * ClocksWidth'(Period);

  // The idle line's high is Tsyn - 1 - high_left samples old, the character's end its start's
  // age (since_t0, or since_alt for the second candidate) less StopEnd: it rose after the end
  // when the first is the younger (a high TSYN old or older is before it).
  localparam int EndWidth = (IdleWidth > TimeWidth ? IdleWidth : TimeWidth) + 1;
  logic [IdleWidth-1:0] high_left;
  assign rose_after_end_o = from_alt
      ? EndWidth'(high_left) + EndWidth'(since_alt) > EndWidth'(Tsyn - 1 + StopEnd)
      : EndWidth'(high_left) + EndWidth'(since_t0) > EndWidth'(Tsyn - 1 + StopEnd);
  // The channel's samples: every Period clocks, from tick Phase. Between them it holds.
  assign sample  = phase_q == '0;
  assign sample_o = sample;
  logic [PendWidth-1:0] cancel_left;
  assign cancel_left_o = PendOutWidth'(cancel_left);
  assign phase_d = Period > 1 ? (sample ? PhaseBits'(Period - 1) : phase_q - 1'b1) : '0;

  // The step's other view of the measuring flag is for the other caller.
  /* verilator lint_off PINCONNECTEMPTY */
  autobaud_channel_step #(
    .PhaseWidth(PhaseWidth), .IdleWidth(IdleWidth), .PendWidth(PendWidth),
    .TimeWidth(TimeWidth), .AltWidth(AltWidth)
  ) u_step (
    .inc_i                (PhaseWidth'(Inc)),
    .modulo_i             (PhaseWidth'(Modulo)),
    .quarter_i            (PhaseWidth'(Quarter)),
    .three_quarters_i     (PhaseWidth'(ThreeQuarters)),
    .half_less_inc_i      (PhaseWidth'(HalfLessInc)),
    .two_inc_i            ((PhaseWidth + 1)'(TwoInc)),
    .modulo_less_inc_i    (PhaseWidth'(ModuloLessInc)),
    .modulo_less_two_inc_i(PhaseWidth'(ModuloLessTwoInc)),
    .glitch_i             (PendWidth'(Glitch)),
    .tsyn_less_one_i      (IdleWidth'(Tsyn - 1)),
    .to_middle_i          (TimeWidth'(StopMiddle - 1)),
    .middle_to_end_i      (TimeWidth'(StopEnd - StopMiddle - 1)),
    .start_bit_i          (TimeWidth'(StartBitClocks)),
    .sample_i             (sample),
    .level_i,
    .heard_i,
    .heard_any_i,
    .state_i              (state_q),
    .state_o              (state_d),
    .detect_o,
    .reject_o,
    .reject_code_o,
    .byte_o,
    .since_t0_o           (since_t0),
    .alt_o                (alt),
    .from_alt_o           (from_alt),
    .cancel_left_o        (cancel_left),
    .high_left_o          (high_left),
    .measuring_o,
    .measuring_next_o     ()
  );
  /* verilator lint_on PINCONNECTEMPTY */

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      phase_q <= PhaseBits'(Phase);
      state_q <= Reset;
    end else begin
      phase_q <= phase_d;
      state_q <= state_d;
    end
  end
endmodule
