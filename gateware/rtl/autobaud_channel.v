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
// line's last edge as its age (the search's, shared). The detection's start is since_t0_o less
// offset_o, worked out once in autobaud.v for the channel that goes out.
// What the decision reads is the reader's registers with this clock's line lasting (the
// model clocks the reader through this clock first: the same bits, and this clock's edge
// counts in the glitches, char_reader's glitches_next_o).
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
  // Clocks between the channel's samples of the line (AutoBaud::sampled); every figure above
  // is in samples.
  parameter int Period           = 1,
  // The rate's own widths: the idle line's clocks past Tsyn, the pending edge's age past
  // Glitch, a measurement's clocks (a start bit and a character), a start bit's clocks.
  parameter int IdleWidth        = 18,
  parameter int PendWidth        = 12,
  parameter int TimeWidth        = 16,
  parameter int AltWidth         = 13,
  // The search's: the start age and offset it puts out.
  parameter int StartAgeWidth    = 16,
  parameter int AltOutWidth      = 13
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
  // Clocks since the detected character's start edge.
  output wire [StartAgeWidth-1:0] since_t0_o,
  output wire [AltOutWidth-1:0]   offset_o,
  output wire                 measuring_o
);
  localparam int MaxEdges = 16;
  localparam int BalanceWidth = PhaseWidth + 1;

  localparam int PhaseBits = Period > 1 ? $clog2(Period) : 1;
  logic [PhaseBits-1:0] phase_q, phase_d;
  logic                 held_q, held_d;
  logic [PendWidth-1:0] edge_left_q, edge_left_d;
  logic [PendWidth-1:0] cancel_left_q, cancel_left_d;
  logic [IdleWidth-1:0] high_left_q, high_left_d;
  logic [IdleWidth-1:0] before_left_q, before_left_d;
  logic                 measuring_q, measuring_d;
  logic [TimeWidth-1:0] since_t0_q, since_t0_d;
  logic [TimeWidth-1:0] decide_in_q, decide_in_d;
  logic [4:0]           n_edges_q, n_edges_d;
  logic [AltWidth-1:0]  alt_q, alt_d;
  logic                 deferred_q, deferred_d;

  logic                 sample, fell, rose;
  logic                 edge_now, cancels, after_glitch, starts, second, overflow, due;
  logic                 start1;
  logic [IdleWidth-1:0] high_next, before_next;
  logic                 idle_long;

  // The two readers: from the start edge, and from the second candidate start.
  logic [3:0]              bit0, bit1;
  logic [10:0]             shift0, shift1;
  logic                    tie0, tie1;
  logic [1:0]              glitches0, glitches1;
  logic [BalanceWidth-1:0] lead0, lead1, lag0, lag1;

  function automatic logic [IdleWidth-1:0] idle_dec(input logic [IdleWidth-1:0] v);
    idle_dec = v == '0 ? v : v - 1'b1;
  endfunction

  // A reading as dp_phy::autobaud::delimiter_read judges it: {ok, code, byte}. At a decision
  // the stop bit is under way (bit_n 10: it is the sign of this clock's balance) or over
  // (11): the model asserts it (AutoBaud::decide), and nothing else is built.
  function automatic logic [10:0] judge(
      input logic [3:0] bit_n, input logic [10:0] shift, input logic tie,
      input logic [1:0] glitches, input logic [BalanceWidth-1:0] lead,
      input logic [BalanceWidth-1:0] lag, input logic level);
    logic [BalanceWidth-1:0] total;
    logic [10:0] bits;
    logic        over, tied;
    logic [7:0]  data;
    total = level ? lead : lag;
    over  = bit_n == 4'd11;
    bits  = over ? shift : {!total[BalanceWidth-1] && total != '0, shift[10:1]};
    tied  = tie || (!over && total == '0);
    data  = bits[8:1];
    if (tied || glitches > 2'd1) judge = {1'b0, 2'd0, 8'd0};
    else if (bits[0] || !bits[10] || bits[9] != ^data) judge = {1'b0, 2'd1, 8'd0};
    else if (data != 8'h10 && data != 8'h68 && data != 8'hA2 && data != 8'hDC)
      judge = {1'b0, 2'd2, 8'd0};
    else judge = {1'b1, 2'd0, data};
  endfunction

  logic [10:0]          from_start, from_alt;
  logic                 ok;
  logic [1:0]           code;
  logic [7:0]           data;
  logic [AltWidth-1:0]  offset;

  always_comb begin
    // The channel's samples: every Period clocks, from tick 0. Between them it holds.
    sample        = phase_q == '0;
    phase_d       = Period > 1 ? (sample ? PhaseBits'(Period - 1) : phase_q - 1'b1) : '0;
    held_d        = sample ? level_i : held_q;
    fell          = sample && held_q && !level_i;
    rose          = sample && !held_q && level_i;
    edge_left_d   = edge_left_q == '0 || !sample ? edge_left_q : edge_left_q - 1'b1;
    cancel_left_d = cancel_left_q == '0 || !sample ? cancel_left_q : cancel_left_q - 1'b1;
    high_next     = sample ? idle_dec(high_left_q) : high_left_q;
    before_next   = sample ? idle_dec(before_left_q) : before_left_q;
    high_left_d   = high_next;
    before_left_d = before_next;
    measuring_d  = measuring_q;
    since_t0_d   = sample ? since_t0_q + 1'b1 : since_t0_q;
    decide_in_d  = sample ? decide_in_q - 1'b1 : decide_in_q;
    n_edges_d    = n_edges_q;
    alt_d        = alt_q;
    deferred_d   = deferred_q;
    edge_now     = fell || rose;
    cancels      = cancel_left_q != '0;
    idle_long    = high_left_q == '0;
    after_glitch = edge_left_q != '0;
    starts       = fell && !after_glitch && idle_long;
    overflow     = !starts && measuring_q && edge_now && n_edges_q == 5'(MaxEdges);
    second       = !starts && measuring_q && fell && !overflow && after_glitch
                   && since_t0_q < TimeWidth'(StartBitClocks);
    start1       = second;
    due          = sample && measuring_q && !starts && !second && !overflow
                   && decide_in_q == '0;
    from_start   = judge(bit0, shift0, tie0, glitches0, lead0, lag0, level_i);
    from_alt     = judge(bit1, shift1, tie1, glitches1, lead1, lag1, level_i);
    ok           = 1'b0;
    code         = 2'd0;
    data         = 8'd0;
    offset       = '0;

    // The idle line, with the rate's glitches removed.
    if (edge_now) begin
      edge_left_d   = PendWidth'(Glitch);
      cancel_left_d = cancels ? '0 : PendWidth'(Glitch);
      if (rose && !cancels) begin
        high_left_d   = IdleWidth'(Tsyn - 1);
        before_left_d = high_next;
      end else if (fell && cancels) begin
        high_left_d   = before_next;
        before_left_d = before_next;
      end
    end

    // The measurement.
    if (starts) begin
      measuring_d = 1'b1;
      since_t0_d  = TimeWidth'(1);
      decide_in_d = TimeWidth'(StopMiddle - 1);
      n_edges_d   = '0;
      alt_d       = '0;
      deferred_d  = 1'b0;
    end else if (overflow) begin
      measuring_d = 1'b0;
    end else if (measuring_q && edge_now) begin
      n_edges_d = n_edges_q + 5'd1;
      if (second) begin
        alt_d       = AltWidth'(since_t0_q);
        decide_in_d = TimeWidth'(StopMiddle - 1);
        deferred_d  = 1'b0;
      end
    end

    // The decision: from the start, or from the second candidate too.
    if (alt_q == '0) begin
      {ok, code, data} = from_start;
    end else if (from_start[10] && from_alt[10] && from_start[7:0] != from_alt[7:0]) begin
      {ok, code, data} = {1'b0, 2'd0, 8'd0};
    end else if (from_start[10]) begin
      {ok, code, data} = from_start;
    end else if (from_alt[10]) begin
      {ok, code, data} = from_alt;
      offset = alt_q;
    end else begin
      {ok, code, data} = from_start;
    end
    if (due) begin
      if (!level_i && !deferred_q) begin
        // Low at the stop bit's middle: the whole stop bit tells.
        deferred_d  = 1'b1;
        decide_in_d = TimeWidth'(StopEnd - StopMiddle - 1);
      end else begin
        measuring_d = 1'b0;
      end
    end
  end

  logic decides;
  assign decides       = due && (level_i || deferred_q) && !heard_i;
  assign detect_o      = decides && ok;
  assign reject_o      = decides && !ok && !heard_any_i;
  assign reject_code_o = code;
  assign byte_o        = data;
  assign since_t0_o    = StartAgeWidth'(since_t0_q);
  assign offset_o      = AltOutWidth'(offset);
  assign measuring_o   = measuring_q;

  // The readers' other outputs are for their own check (rtl-check's char_reader cases).
  /* verilator lint_off PINCONNECTEMPTY */
  char_reader #(.PhaseWidth(PhaseWidth)) u_from_start (
    .clk_i, .rst_ni,
    .inc_i                (PhaseWidth'(Inc)),
    .modulo_i             (PhaseWidth'(Modulo)),
    .quarter_i            (PhaseWidth'(Quarter)),
    .three_quarters_i     (PhaseWidth'(ThreeQuarters)),
    .half_less_inc_i      (PhaseWidth'(HalfLessInc)),
    .two_inc_i            ((PhaseWidth + 1)'(TwoInc)),
    .modulo_less_inc_i    (PhaseWidth'(ModuloLessInc)),
    .modulo_less_two_inc_i(PhaseWidth'(ModuloLessTwoInc)),
    .step_i               (sample),
    .start_i              (starts),
    .level_i,
    .edge_i               (edge_now),
    .bit_o                (bit0),
    .shift_o              (shift0),
    .tie_o                (tie0),
    .glitches_o           (),
    .glitches_next_o      (glitches0),
    .pair_open_o          (),
    .rem_o                (),
    .lead_o               (lead0),
    .lag_o                (lag0),
    .pair_left_o          ()
  );

  char_reader #(.PhaseWidth(PhaseWidth)) u_from_alt (
    .clk_i, .rst_ni,
    .inc_i                (PhaseWidth'(Inc)),
    .modulo_i             (PhaseWidth'(Modulo)),
    .quarter_i            (PhaseWidth'(Quarter)),
    .three_quarters_i     (PhaseWidth'(ThreeQuarters)),
    .half_less_inc_i      (PhaseWidth'(HalfLessInc)),
    .two_inc_i            ((PhaseWidth + 1)'(TwoInc)),
    .modulo_less_inc_i    (PhaseWidth'(ModuloLessInc)),
    .modulo_less_two_inc_i(PhaseWidth'(ModuloLessTwoInc)),
    .step_i               (sample),
    .start_i              (start1),
    .level_i,
    .edge_i               (edge_now),
    .bit_o                (bit1),
    .shift_o              (shift1),
    .tie_o                (tie1),
    .glitches_o           (),
    .glitches_next_o      (glitches1),
    .pair_open_o          (),
    .rem_o                (),
    .lead_o               (lead1),
    .lag_o                (lag1),
    .pair_left_o          ()
  );
  /* verilator lint_on PINCONNECTEMPTY */

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      // Reset is tick 0, a sample, with the line high since then: TSYN is all to come, and
      // the line's last edge is taken as at tick 0 (within a glitch of it until Glitch + 1
      // samples have passed).
      phase_q       <= '0;
      held_q        <= 1'b1;
      edge_left_q   <= PendWidth'(Glitch + 1);
      cancel_left_q <= '0;
      high_left_q   <= IdleWidth'(Tsyn);
      before_left_q <= IdleWidth'(Tsyn);
      measuring_q  <= 1'b0;
      since_t0_q   <= '0;
      decide_in_q  <= '0;
      n_edges_q    <= '0;
      alt_q        <= '0;
      deferred_q   <= 1'b0;
    end else begin
      phase_q       <= phase_d;
      held_q        <= held_d;
      edge_left_q   <= edge_left_d;
      cancel_left_q <= cancel_left_d;
      high_left_q   <= high_left_d;
      before_left_q <= before_left_d;
      measuring_q  <= measuring_d;
      since_t0_q   <= since_t0_d;
      decide_in_q  <= decide_in_d;
      n_edges_q    <= n_edges_d;
      alt_q        <= alt_d;
      deferred_q   <= deferred_d;
    end
  end
endmodule
