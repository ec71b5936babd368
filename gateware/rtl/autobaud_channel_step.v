// One sample of one rate's channel of the baud-rate search: the logic of autobaud_channel.v
// without its registers (a ChannelQ of dp_phy::autobaud::AutoBaud with the rate's idle line).
// The channel's registers come in packed (state_i) and go out as they become at this clock's
// edge (state_o); its figures come in as inputs. autobaud_channel.v keeps one channel's
// registers in flip-flops with its figures fixed; autobaud_shared.v keeps seven channels' in
// block RAM and serves them in turn through one step, their figures from a table.
//
// What the registers count is in autobaud_channel.v. The packed state, most significant first:
// held, edge_left (PendWidth), cancel_left (PendWidth), high_left and before_left (IdleWidth
// each), measuring, since_t0 and decide_in (TimeWidth each), n_edges (5), alt (AltWidth),
// deferred, then the second candidate's reader and the start's (char_reader_step.v's state
// each), then what the decision reads of each of them, made a clock ahead (AheadWidth each:
// read_ahead below; in the RTL only).
//
// sample_i: this clock is one of the channel's samples of the line; between them only the
// readers' step enable is low and nothing else moves, so a caller that steps the channel on its
// samples alone may leave state_o unwritten at the others.
`default_nettype none

module autobaud_channel_step #(
  parameter int PhaseWidth    = 13,
  parameter int IdleWidth     = 18,
  parameter int PendWidth     = 12,
  parameter int TimeWidth     = 16,
  parameter int AltWidth      = 13,
  // Derived; not to be set.
  parameter int ReaderWidth   = 4 * PhaseWidth + 21,
  parameter int AheadWidth    = 8,
  parameter int StateWidth    = 2 * PendWidth + 2 * IdleWidth + 2 * TimeWidth + AltWidth + 8
                                + 2 * ReaderWidth + 2 * AheadWidth
) (
  // The rate's reader figures (CharReader::new, reduced).
  input  wire [PhaseWidth-1:0] inc_i,
  input  wire [PhaseWidth-1:0] modulo_i,
  input  wire [PhaseWidth-1:0] quarter_i,
  input  wire [PhaseWidth-1:0] three_quarters_i,
  input  wire [PhaseWidth-1:0] half_less_inc_i,
  input  wire [PhaseWidth:0]   two_inc_i,
  input  wire [PhaseWidth-1:0] modulo_less_inc_i,
  input  wire [PhaseWidth-1:0] modulo_less_two_inc_i,
  // The rate's search figures, in samples: a glitch, TSYN less one, the stop bit's middle
  // less one, its end less its middle less one, a start bit.
  input  wire [PendWidth-1:0]  glitch_i,
  input  wire [IdleWidth-1:0]  tsyn_less_one_i,
  input  wire [TimeWidth-1:0]  to_middle_i,
  input  wire [TimeWidth-1:0]  middle_to_end_i,
  input  wire [TimeWidth-1:0]  start_bit_i,
  input  wire                  sample_i,
  input  wire                  level_i,
  // The receiver is on this rate; on any rate.
  input  wire                  heard_i,
  input  wire                  heard_any_i,
  input  wire [StateWidth-1:0] state_i,
  output logic [StateWidth-1:0] state_o,
  output wire                  detect_o,
  output wire                  reject_o,
  // Reject: 0 off the grid, 1 no character, 2 no delimiter.
  output wire [1:0]            reject_code_o,
  output wire [7:0]            byte_o,
  // Samples since the first start edge, the second start's offset from it (both registers,
  // early in the clock), and whether the decision reads from the second (late): the detected
  // character's start is since_t0_o, less alt_o when from_alt_o.
  output wire [TimeWidth-1:0]  since_t0_o,
  output wire [AltWidth-1:0]   alt_o,
  output wire                  from_alt_o,
  // The samples within which a next edge cancels the idle line's last one, as this clock
  // leaves them (0: none can): the detecting channel's goes to the transceiver's own copy of
  // the rate's idle line (Detection::pending).
  output wire [PendWidth-1:0]  cancel_left_o,
  // The samples the idle line's high still lacks of TSYN, as this clock leaves them: with
  // since_t0_o, alt_o and from_alt_o, whether it rose after the detected character's end
  // (Detection::rose_after_end).
  output wire [IdleWidth-1:0]  high_left_o,
  // A measurement under way, in state_i and in state_o: the packed layout stays known here.
  output wire                  measuring_o,
  output wire                  measuring_next_o
);
  localparam int MaxEdges = 16;
  localparam int BalanceWidth = PhaseWidth + 1;

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
  logic [ReaderWidth-1:0] reader0_q, reader0_d, reader1_q, reader1_d;
  logic [AheadWidth-1:0]  ahead1_q, ahead0_q;

  assign {held_q, edge_left_q, cancel_left_q, high_left_q, before_left_q, measuring_q,
          since_t0_q, decide_in_q, n_edges_q, alt_q, deferred_q, reader1_q, reader0_q,
          ahead1_q, ahead0_q} = state_i;

  logic                 sample, fell, rose;
  logic                 edge_now, cancels, after_glitch, starts, second, overflow, due;
  logic [IdleWidth-1:0] high_next, before_next;
  logic                 idle_long;

  // What the decision reads of each reader: its registers with this clock's line lasting (the
  // model clocks the reader through this clock first: the same bits, and this clock's edge
  // counts in the glitches).
  logic [3:0]              bit0, bit1;
  // The bits shifted in but the first and the last: the byte with its neighbours.
  logic [9:1]              shift0, shift1;
  logic                    tie0, tie1;
  logic [1:0]              glitches0, glitches1;
  // The reader's state: bit, rem, lead, lag, shift, tie, glitches, pair_open, pair_left.
  assign bit0      = reader0_q[ReaderWidth-1 -: 4];
  assign shift0    = reader0_q[PhaseWidth+13 -: 9];
  assign tie0      = reader0_q[PhaseWidth+3];
  assign glitches0 = reader0_d[PhaseWidth+1 +: 2];
  assign bit1      = reader1_q[ReaderWidth-1 -: 4];
  assign shift1    = reader1_q[PhaseWidth+13 -: 9];
  assign tie1      = reader1_q[PhaseWidth+3];
  assign glitches1 = reader1_d[PhaseWidth+1 +: 2];

  function automatic logic is_delimiter(input logic [7:0] b);
    is_delimiter = b == 8'h10 || b == 8'h68 || b == 8'hA2 || b == 8'hDC;
  endfunction

  // In the RTL only: what a reading needs of a reader but the line's level and this clock's
  // glitches, from its registers as the step leaves them, for the decision on the next step
  // (the registers do not move between steps): the character framed (start bit low, stop bit
  // high, parity) and a delimiter's byte, both with the stop bit over (its bits as shifted in)
  // and under way (the bits before it: the stop bit is the sign of its balance, the decision's
  // level's); each balance positive, and zero. So the decision waits on no parity, byte
  // comparison or zero test, only on choices by the level and the glitches.
  /* verilator lint_off UNUSEDSIGNAL */
  function automatic logic [AheadWidth-1:0] read_ahead(input logic [ReaderWidth-1:0] r);
    logic [10:0]             shift;
    logic [BalanceWidth-1:0] lead, lag;
    shift = r[PhaseWidth+14 -: 11];
    lead  = r[ReaderWidth-5-PhaseWidth -: BalanceWidth];
    lag   = r[ReaderWidth-5-PhaseWidth-BalanceWidth -: BalanceWidth];
    read_ahead = {!shift[0] && shift[10] && shift[9] == ^shift[8:1], is_delimiter(shift[8:1]),
                  !shift[1] && shift[10] == ^shift[9:2], is_delimiter(shift[9:2]),
                  !lead[BalanceWidth-1] && lead != '0, lead == '0,
                  !lag[BalanceWidth-1] && lag != '0, lag == '0};
  endfunction
  /* verilator lint_on UNUSEDSIGNAL */

  function automatic logic [IdleWidth-1:0] idle_dec(input logic [IdleWidth-1:0] v);
    idle_dec = v == '0 ? v : v - 1'b1;
  endfunction

  // A reading as dp_phy::autobaud::delimiter_read judges it: {ok, code, byte}. At a decision
  // the stop bit is under way (bit_n 10: it is the sign of this clock's balance, and the byte
  // the bits before it) or over (11: the bits as shifted in): the model asserts it
  // (AutoBaud::decide), and nothing else is built. The tests on the bits and the balances come
  // made a clock ahead (`ahead`: read_ahead's).
  function automatic logic [10:0] judge(
      input logic [3:0] bit_n, input logic [9:1] shift, input logic tie,
      input logic [1:0] glitches, input logic [AheadWidth-1:0] ahead, input logic level);
    logic       over, tied, framed, delimiter;
    logic       framed_over, delimiter_over, framed_under, delimiter_under;
    logic       lead_positive, lead_zero, lag_positive, lag_zero;
    logic [7:0] data;
    {framed_over, delimiter_over, framed_under, delimiter_under,
     lead_positive, lead_zero, lag_positive, lag_zero} = ahead;
    over      = bit_n == 4'd11;
    tied      = tie || (!over && (level ? lead_zero : lag_zero));
    framed    = over ? framed_over : framed_under && (level ? lead_positive : lag_positive);
    delimiter = over ? delimiter_over : delimiter_under;
    data      = over ? shift[8:1] : shift[9:2];
    if (tied || glitches > 2'd1) judge = {1'b0, 2'd0, 8'd0};
    else if (!framed) judge = {1'b0, 2'd1, 8'd0};
    else if (!delimiter) judge = {1'b0, 2'd2, 8'd0};
    else judge = {1'b1, 2'd0, data};
  endfunction

  assign state_o = {held_d, edge_left_d, cancel_left_d, high_left_d, before_left_d, measuring_d,
                    since_t0_d, decide_in_d, n_edges_d, alt_d, deferred_d, reader1_d, reader0_d,
                    read_ahead(reader1_d), read_ahead(reader0_d)};

  logic [10:0]          from_start, from_alt;
  logic                 ok;
  logic [1:0]           code;
  logic [7:0]           data;
  logic                 from_alt_chosen;

  always_comb begin
    sample        = sample_i;
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
                   && since_t0_q < start_bit_i;
    due          = sample && measuring_q && !starts && !second && !overflow
                   && decide_in_q == '0;
    from_start   = judge(bit0, shift0, tie0, glitches0, ahead0_q, level_i);
    from_alt     = judge(bit1, shift1, tie1, glitches1, ahead1_q, level_i);
    ok           = 1'b0;
    code         = 2'd0;
    data         = 8'd0;
    from_alt_chosen = 1'b0;

    // The idle line, with the rate's glitches removed.
    if (edge_now) begin
      edge_left_d   = glitch_i;
      cancel_left_d = cancels ? '0 : glitch_i;
      if (rose && !cancels) begin
        high_left_d   = tsyn_less_one_i;
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
      decide_in_d = to_middle_i;
      n_edges_d   = '0;
      alt_d       = '0;
      deferred_d  = 1'b0;
    end else if (overflow) begin
      measuring_d = 1'b0;
    end else if (measuring_q && edge_now) begin
      n_edges_d = n_edges_q + 5'd1;
      if (second) begin
        alt_d       = AltWidth'(since_t0_q);
        decide_in_d = to_middle_i;
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
      from_alt_chosen = 1'b1;
    end else begin
      {ok, code, data} = from_start;
    end
    if (due) begin
      if (!level_i && !deferred_q) begin
        // Low at the stop bit's middle: the whole stop bit tells.
        deferred_d  = 1'b1;
        decide_in_d = middle_to_end_i;
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
  assign since_t0_o    = since_t0_q;
  assign alt_o         = alt_q;
  assign from_alt_o    = from_alt_chosen;
  assign cancel_left_o = cancel_left_d;
  assign high_left_o   = high_left_d;
  assign measuring_o   = measuring_q;
  assign measuring_next_o = measuring_d;

  // The readers: from the start edge, and from the second candidate start.
  char_reader_step #(.PhaseWidth(PhaseWidth)) u_from_start (
    .inc_i, .modulo_i, .quarter_i, .three_quarters_i, .half_less_inc_i, .two_inc_i,
    .modulo_less_inc_i, .modulo_less_two_inc_i,
    .step_i (sample),
    .start_i(starts),
    .level_i,
    .edge_i (edge_now),
    .state_i(reader0_q),
    .state_o(reader0_d)
  );

  char_reader_step #(.PhaseWidth(PhaseWidth)) u_from_alt (
    .inc_i, .modulo_i, .quarter_i, .three_quarters_i, .half_less_inc_i, .two_inc_i,
    .modulo_less_inc_i, .modulo_less_two_inc_i,
    .step_i (sample),
    .start_i(second),
    .level_i,
    .edge_i (edge_now),
    .state_i(reader1_q),
    .state_o(reader1_d)
  );
endmodule
