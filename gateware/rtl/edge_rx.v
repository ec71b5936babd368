// The receiver at a known rate: dp_phy::edge_rx::EdgeRx's twin (crates/dp-phy/src/edge_rx.rs),
// register for register but for read_until (the readers here take every sample as it comes;
// the model passes the samples between its events at once) and the registers that do work a
// clock ahead (ahead_q, good_ahead_q, due_q, idle_pending_q; below).
//
// The line comes sampled, as the search's channel of the rate samples it (EdgeRx::sampled):
// step_i marks the sample ticks, level_i is the level last sampled, and edge_i (only with
// step_i) says it changed there. The readers step on the samples only, in sample units, so
// their phase is as narrow as the rate's samples need (7 bits on the transceiver's schedule),
// and stand still between them; starts, deadlines and the character's times stay ticks.
//
// Each clock does what the transceiver's tick does with the model, in its order: on_edge (a
// fall after idle_before_i idle clocks opens a candidate), then act when the character under
// way falls due (its deadline reached), which may decide a character. The character goes out
// on the next clock, from registers (char_o and its fields): the transceiver's register
// between the receiver's decision and the delimiter (Transceiver's `decided`). hand_over_i is
// a hand-over instead of this clock's act (EdgeRx::hand_over: the receiver starts afresh, with
// a fall at its own rate, hand_over_fell_i, hand_over_idle_i the idle clocks before it: after
// the detected character's end, or the line's at a lock taken back; its first candidate's
// reader starts from the hand-over's figures, which may be another rate's than the step's).
// The search's detection is acted on a clock after it (Transceiver's `detection`): its
// hand-over is of the last clock, then this clock's step at its rate (hand_over_fell_last_i,
// a fall there; hand_over_fell_i, one on this clock). clear_i is the transceiver's reset of
// it after everything else (a rate dropped or changed). A hand-over without a fall is the
// transceiver's receiver reset before this clock (a new rate, or none).
//
// Two lanes of two slots: the lane cur_q the character under way, the other the next one, whose
// candidates the falls from next_from on open while the current one's decision is pending; at
// the decision they swap roles. A slot holds a candidate's start tick, its character reader
// (char_reader_step, its phase wide enough for the rate chosen at run time, its figures as
// inputs) and its start bit as the reader decided it; live_q marks the slots under way and
// first_q the earlier one. Nothing moves between slots or lanes: a reader is started in a free
// slot and left there.
//
// What changed for hardware: ticks are TickWidth bits (the model's u64 truncated to 18: every
// tick kept is within two characters of now at 9.6k, so a signed difference orders them; the
// character's start and end go out as 32-bit ticks, now_i's); the idle clocks are 24 bits (the
// transceiver saturates the ones it gives; TSYN at 9.6k is 165,000 clocks); a lane's deadline
// is valid while it has candidates (the model's Tick::MAX otherwise); a free slot's reader runs
// on, its registers no one's until a start (the model holds them).
`default_nettype none

module edge_rx #(
  parameter int PhaseWidth  = 7,
  parameter int TickWidth   = 18,
  parameter int IdleWidth   = 24,
  parameter int OffsetWidth = 16
) (
  input  wire                   clk_i,
  input  wire                   rst_ni,
  input  wire [31:0]            now_i,
  // The rate's CharReader figures in samples (char_reader.v's), and the clocks from a start
  // edge to the end of its start bit, the middle of its stop bit and its end (whole samples).
  input  wire [PhaseWidth-1:0]  inc_i,
  input  wire [PhaseWidth:0]    two_inc_i,
  input  wire [PhaseWidth-1:0]  modulo_i,
  input  wire [PhaseWidth-1:0]  quarter_i,
  input  wire [PhaseWidth-1:0]  three_quarters_i,
  input  wire [PhaseWidth-1:0]  half_less_inc_i,
  input  wire [PhaseWidth-1:0]  modulo_less_inc_i,
  input  wire [PhaseWidth-1:0]  modulo_less_two_inc_i,
  input  wire [OffsetWidth-1:0] start_end_i,
  input  wire [OffsetWidth-1:0] stop_middle_i,
  input  wire [OffsetWidth-1:0] stop_end_i,
  input  wire                   step_i,
  input  wire                   level_i,
  input  wire                   edge_i,
  input  wire [IdleWidth-1:0]   idle_before_i,
  input  wire                   hand_over_i,
  input  wire [IdleWidth-1:0]   hand_over_idle_i,
  // The hand-over's own rate, which may not be the step's: its fall on this clock, or, for a
  // hand-over of the last clock, on that one (hand_over_fell_last_i: the candidate started
  // there, and its reader takes this clock's sample at the hand-over's rate, *_step, *_level
  // and *_edge); the figures its first candidate's reader and start bit's end are made of.
  input  wire                   hand_over_fell_i,
  input  wire                   hand_over_fell_last_i,
  input  wire                   hand_over_step_i,
  input  wire                   hand_over_level_i,
  input  wire                   hand_over_edge_i,
  input  wire [PhaseWidth-1:0]  hand_over_inc_i,
  input  wire [PhaseWidth:0]    hand_over_two_inc_i,
  input  wire [PhaseWidth-1:0]  hand_over_modulo_i,
  input  wire [PhaseWidth-1:0]  hand_over_quarter_i,
  input  wire [PhaseWidth-1:0]  hand_over_three_quarters_i,
  input  wire [PhaseWidth-1:0]  hand_over_half_less_inc_i,
  input  wire [PhaseWidth-1:0]  hand_over_modulo_less_inc_i,
  input  wire [PhaseWidth-1:0]  hand_over_modulo_less_two_inc_i,
  input  wire [OffsetWidth-1:0] hand_over_start_end_i,
  input  wire                   clear_i,
  // A character decided on the last clock: its byte, error (0 none, 1 parity, 2 framing, 3
  // break, 4 noise: delimiter.v's code), start and end ticks, and the idle clocks before it.
  output logic                  char_o,
  output logic [7:0]            char_byte_o,
  output logic [2:0]            char_error_o,
  output logic [31:0]           char_start_o,
  output logic [31:0]           char_end_o,
  output logic [IdleWidth-1:0]  char_idle_before_o,
  // A character under way (EdgeRxQ::active), as the last clock left it.
  output wire                   active_o,
  // For the checker: the current lane's deadline and stage, the next lane under way,
  // next_from (ticks of TickWidth bits).
  output wire [TickWidth-1:0]   deadline_o,
  output wire [1:0]             stage_o,
  output wire                   next_active_o,
  output wire                   next_from_valid_o,
  output wire [TickWidth-1:0]   next_from_o
);
  localparam int PW = PhaseWidth;
  localparam int TW = TickWidth;
  localparam int IW = IdleWidth;
  // char_reader_step's packed state, and its fields' places (most significant first: bit,
  // rem, lead, lag, shift, tie, glitches, pair_open, pair_left).
  localparam int RW         = 4 * PW + 21;
  localparam int GlitchesAt = PW + 1;
  localparam int TieAt      = PW + 3;
  localparam int ShiftAt    = PW + 4;
  localparam int LagAt      = PW + 15;
  localparam int LeadAt     = 2 * PW + 16;
  localparam int RemAt      = 3 * PW + 17;
  localparam int BitAt      = 4 * PW + 17;
  localparam logic [RW-1:0] ReaderReset = {4'd11, (RW - 4)'(0)};
  localparam logic [1:0] StartBit = 2'd0, StopMiddle = 2'd1, StopEnd = 2'd2;

  // Per lane l, flat: the lane's field at [l * width +: width], slot s of lane l at
  // [(2 * l + s) * width +: width].
  logic [3:0]      live_q, live_d;
  logic [1:0]      first_q, first_d;
  logic [4*TW-1:0] starts_q, starts_d;
  logic [4*RW-1:0] readers_q, readers_d;
  logic [3:0]      start_low_q, start_low_d;
  logic [2*TW-1:0] opened_q, opened_d;
  logic [2*IW-1:0] idle_q, idle_d;
  logic [3:0]      stage_q, stage_d;
  logic [2*TW-1:0] deadline_q, deadline_d;
  logic            cur_q, cur_d;
  logic [TW-1:0]   next_from_q, next_from_d;
  logic            next_from_valid_q, next_from_valid_d;

  logic [TW-1:0] now;
  assign now = now_i[TW-1:0];

  // The idle clocks from `from` to `to`: 0 if `to` comes first (TickWidth bits fit IdleWidth).
  function automatic logic [IW-1:0] idle_between(input logic [TW-1:0] from, to);
    logic [TW-1:0] diff;
    diff = to - from;
    if (diff[TW-1]) idle_between = {IW{1'b0}};
    else idle_between = IW'(diff);
  endfunction

  // `at` is now or before it.
  function automatic logic reached(input logic [TW-1:0] at);
    logic [TW-1:0] diff;
    diff = now - at;
    reached = !diff[TW-1];
  endfunction

  // `at` is the next clock or before it.
  function automatic logic reached_next(input logic [TW-1:0] at);
    logic [TW-1:0] diff;
    diff = now + TW'(1) - at;
    reached_next = !diff[TW-1];
  endfunction

  // Every index below is a constant: "the current lane" and "the first slot" are small
  // multiplexers of registers, where a part-select at a variable offset would be a shifter
  // across the whole vector.
  function automatic logic [TW-1:0] start_of(input logic [2*TW-1:0] lane_starts, input logic slot);
    start_of = slot ? lane_starts[TW +: TW] : lane_starts[0 +: TW];
  endfunction

  // Per slot, from the registers: its reader's start bit still under way.
  logic [3:0] in_start_bit;
  for (genvar k = 0; k < 4; k++) begin : g_in_start_bit
    assign in_start_bit[k] = readers_q[k*RW + BitAt +: 4] == 4'd0;
  end

  // ---- on_edge: the fall's lane drops its false starts and opens a candidate in a free
  // slot; every reader takes the clock. ----
  logic       fell, fall_next;
  logic [1:0] fall_here;
  logic [1:0] keep;
  logic       first_slot, last_slot;
  logic [3:0]      live_b;
  logic [1:0]      first_b;
  logic [4*TW-1:0] starts_b;
  logic [3:0]      start_low_b;
  logic [2*TW-1:0] opened_b;
  logic [2*IW-1:0] idle_b;
  logic [3:0]      stage_b;
  logic [2*TW-1:0] deadline_b;
  logic [3:0]      start_reader;
  logic [4*RW-1:0] readers_c;
  logic [3:0]      start_low_c, start_ends, start_over;

  // Each slot's start bit's end from the registers: a fall's choice of a candidate only
  // picks one.
  logic [4*TW-1:0] start_ends_at;
  for (genvar k = 0; k < 4; k++) begin : g_slot_ticks
    assign start_ends_at[k*TW +: TW] = starts_q[k*TW +: TW] + TW'(start_end_i);
  end

  always_comb begin
    fell         = edge_i && !level_i;
    // From the middle of the current first candidate's stop bit on, falls open the next one.
    fall_next    = next_from_valid_q && reached(next_from_q);
    // The lane the fall goes to: the current one, or the other from next_from on.
    fall_here[0] = fell && (cur_q == fall_next);
    fall_here[1] = fell && (cur_q != fall_next);
    live_b       = live_q;
    first_b      = first_q;
    starts_b     = starts_q;
    start_low_b  = start_low_q;
    opened_b     = opened_q;
    idle_b       = idle_q;
    stage_b      = stage_q;
    deadline_b   = deadline_q;
    start_reader = '0;
    keep         = '0;
    first_slot   = 1'b0;
    last_slot    = 1'b0;
    for (int l = 0; l < 2; l++) begin
      if (fall_here[l]) begin
        first_slot = first_q[l];
        if (stage_q[2*l +: 2] == StartBit) begin
          // The false starts: start bit decided on an earlier clock, and not low.
          keep = live_q[2*l +: 2] & (in_start_bit[2*l +: 2] | start_low_q[2*l +: 2]);
          live_b[2*l +: 2] = keep;
          if (first_slot ? !keep[1] && keep[0] : !keep[0] && keep[1]) first_slot = !first_slot;
          first_b[l] = first_slot;
          // The last candidate kept, at the end of its start bit.
          last_slot = keep == 2'b11 ? !first_slot : first_slot;
          deadline_b[l*TW +: TW] = start_of(start_ends_at[2*l*TW +: 2*TW], last_slot);
        end
        if (live_b[2*l +: 2] == 2'b00) begin
          // The first candidate of a character, in slot 0.
          live_b[2*l +: 2]         = 2'b01;
          first_b[l]               = 1'b0;
          starts_b[2*l*TW +: TW]   = now;
          start_low_b[2*l]         = 1'b0;
          opened_b[l*TW +: TW]     = now;
          idle_b[l*IW +: IW]       = idle_before_i;
          stage_b[2*l +: 2]        = StartBit;
          deadline_b[l*TW +: TW]   = now + TW'(start_end_i);
          start_reader[2*l]        = 1'b1;
        end else if (first_slot ? in_start_bit[2*l+1] : in_start_bit[2*l]) begin
          // Inside the first candidate's start bit: a second candidate in the other slot (a
          // later one replaces it).
          for (int s = 0; s < 2; s++) begin
            if (first_slot != s[0]) begin
              live_b[2*l+s]                 = 1'b1;
              starts_b[(2*l+s)*TW +: TW]    = now;
              start_low_b[2*l+s]            = 1'b0;
              start_reader[2*l+s]           = 1'b1;
            end
          end
          stage_b[2*l +: 2]      = StartBit;
          deadline_b[l*TW +: TW] = now + TW'(start_end_i);
        end
      end
    end
  end

  for (genvar k = 0; k < 4; k++) begin : g_reader
    // A free slot's reader runs on: it is started before its slot is live again.
    char_reader_step #(.PhaseWidth(PW)) u_step (
      .inc_i, .modulo_i, .quarter_i, .three_quarters_i, .half_less_inc_i,
      .two_inc_i, .modulo_less_inc_i, .modulo_less_two_inc_i,
      .step_i,
      .start_i(start_reader[k]),
      .level_i,
      .edge_i,
      .state_i(readers_q[k*RW +: RW]),
      .state_o(readers_c[k*RW +: RW])
    );
    // From the registers, not through the step's adders: the start bit ends on this sample
    // (its phase left is one sample's), and how it is decided (the sign of its balance with
    // this sample's level: low, and no tie, when negative).
    assign start_ends[k] = step_i && !start_reader[k] && in_start_bit[k]
                         && readers_q[k*RW + RemAt +: PW] <= inc_i;
    assign start_over[k] = !start_reader[k] && (!in_start_bit[k] || start_ends[k]);
    assign start_low_c[k] = start_ends[k]
        ? (level_i ? readers_q[k*RW + LeadAt + PW] : readers_q[k*RW + LagAt + PW])
        : start_low_b[k];
  end

  // The hand-over's first reader: started (char_reader_step's start, at the hand-over's
  // rate), and that start stepped on this clock's sample, for a fall on the last clock. A
  // start bit is longer than one sample, so the step decides no start bit (start_low stays).
  // Both starts' ticks and start bits' ends are worked out, and the fall's clock only chooses.
  logic [TW-1:0] hand_over_start, hand_over_start_end_now, hand_over_start_end_last;
  logic [RW-1:0] hand_over_started, hand_over_stepped;
  assign hand_over_start          = hand_over_fell_last_i ? now - TW'(1) : now;
  assign hand_over_start_end_now  = now + TW'(hand_over_start_end_i);
  assign hand_over_start_end_last = now + TW'(hand_over_start_end_i) - TW'(1);
  assign hand_over_started = {4'd0, hand_over_modulo_less_inc_i,
                              {1'b0, hand_over_modulo_less_two_inc_i},
                              -{1'b0, hand_over_modulo_i}, 11'd0, 1'b0, 2'd0, 1'b0, PW'(0)};
  char_reader_step #(.PhaseWidth(PW)) u_hand_over_step (
    .inc_i(hand_over_inc_i), .modulo_i(hand_over_modulo_i), .quarter_i(hand_over_quarter_i),
    .three_quarters_i(hand_over_three_quarters_i), .half_less_inc_i(hand_over_half_less_inc_i),
    .two_inc_i(hand_over_two_inc_i), .modulo_less_inc_i(hand_over_modulo_less_inc_i),
    .modulo_less_two_inc_i(hand_over_modulo_less_two_inc_i),
    .step_i(hand_over_step_i), .start_i(1'b0), .level_i(hand_over_level_i),
    .edge_i(hand_over_edge_i), .state_i(hand_over_started), .state_o(hand_over_stepped)
  );

  // ---- act: the current lane at its deadline. ----
  // What a candidate reads, the line lasting at a level, from its reader's bit count, shift
  // register, tie and balances (`f`, ReadFields bits): its 11 bits (the stop bit under way,
  // bit 10, or decided) and a tie, then (EdgeRx::read_char, but for the glitches) {tie, false
  // start, byte, error: 0 none, 1 parity, 2 framing, 3 break}.
  localparam int ReadFields = 4 + 11 + 1 + 2 * (PW + 1);
  function automatic logic [ReadFields-1:0] read_fields(input logic [RW-1:0] r);
    read_fields = {r[BitAt +: 4], r[ShiftAt +: 11], r[TieAt], r[LeadAt +: PW + 1],
                   r[LagAt +: PW + 1]};
  endfunction

  function automatic logic [12:0] read_ahead(input logic [ReadFields-1:0] f, input logic level);
    logic [3:0]   bits_done;
    logic [10:0]  shift;
    logic         tie;
    logic [PW:0]  lead, lag, total;
    logic [11:0]  tb;
    logic [7:0]   byte_;
    logic [2:0]   error;
    {bits_done, shift, tie, lead, lag} = f;
    total = level ? lead : lag;
    if (bits_done == 4'd11) tb = {tie, shift};
    else tb = {tie || total == {(PW + 1){1'b0}},
               !total[PW] && total != {(PW + 1){1'b0}}, shift[10:1]};
    byte_ = tb[8:1];
    if (tb[10:0] == 11'd0) error = 3'd3;
    else if (!tb[10]) error = 3'd2;
    else if (tb[9] != ^byte_) error = 3'd1;
    else error = 3'd0;
    read_ahead = {tb[11], tb[0], byte_, error};
  endfunction

  // The reading with this clock's glitch count: {false start, byte, error} (4: noise).
  function automatic logic [11:0] read_char(input logic [12:0] ahead, input logic [1:0] glitches);
    if (ahead[12]) read_char = {1'b0, 8'd0, 3'd4};
    else if (ahead[11]) read_char = {1'b1, ahead[10:3], 3'd0};
    else if (glitches == 2'd3) read_char = {1'b0, ahead[10:3], 3'd4};
    else read_char = {1'b0, ahead[10:3], ahead[2:0]};
  endfunction

  // The current lane's readings a clock ahead: each slot's registers as this clock leaves
  // them, read with the line lasting at either level. On the next clock, the registers they
  // were read from are the readers' and its level picks one: the decision reads them (and the
  // glitch count as that clock leaves it), so no reader's logic is on the way to it. (A
  // decision that makes the other lane current is followed by none for a while.)
  logic [4*13-1:0] ahead_q, ahead_d;
  // Whether each of those is a good character but for its glitches: no tie, no false start,
  // no error.
  logic [3:0]      good_ahead_q, good_ahead_d;
  logic [ReadFields-1:0] cur_fields;
  always_comb begin
    for (int s = 0; s < 2; s++) begin
      cur_fields = cur_q ? read_fields(readers_c[(2+s)*RW +: RW])
                         : read_fields(readers_c[s*RW +: RW]);
      for (int lvl = 0; lvl < 2; lvl++) begin
        ahead_d[(2*s + lvl)*13 +: 13] = read_ahead(cur_fields, lvl[0]);
        good_ahead_d[2*s + lvl] = ahead_d[(2*s + lvl)*13 + 11 +: 2] == 2'b00
                               && ahead_d[(2*s + lvl)*13 +: 3] == 3'd0;
      end
    end
  end
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      ahead_q      <= '0;
      good_ahead_q <= '0;
    end else begin
      ahead_q      <= ahead_d;
      good_ahead_q <= good_ahead_d;
    end
  end

  logic          due, deciding, chose_last, both_good, c_first, c_last, d_first, d_last;
  logic          first_good, last_good;
  logic          chosen_slot;
  logic [1:0]    due_q, due_d;
  logic [1:0]    c_live, d_live, c_stage, c_over, c_low;
  logic [2*TW-1:0] c_starts, c_stop_middles;
  logic [IW-1:0] c_idle;
  logic [3:0]    c_glitches;
  logic [63:0]   start32, end32;
  logic [TW-1:0] end_first, end_last, first_start;
  logic [31-TW:0] upper_less_one;
  logic          idle_pending_q, idle_pending_d;
  logic [TW-1:0] idle_from_q, idle_from_d;
  assign upper_less_one = now_i[31:TW] - 1'b1;
  logic [11:0]   first_read, last_read, chosen;
  logic          char_d;
  logic [7:0]    char_byte_d;
  logic [2:0]    char_error_d;
  logic [31:0]   char_start_d, char_end_d;
  logic [IW-1:0] char_idle_before_d;
  logic [TW-1:0] end_for_idle;

  always_comb begin
    live_d            = live_b;
    first_d           = first_b;
    starts_d          = starts_b;
    readers_d         = readers_c;
    start_low_d       = start_low_c;
    opened_d          = opened_b;
    idle_d            = idle_b;
    stage_d           = stage_b;
    deadline_d        = deadline_b;
    cur_d             = cur_q;
    next_from_d       = next_from_q;
    next_from_valid_d = next_from_valid_q;
    char_d            = 1'b0;
    deciding          = 1'b0;
    idle_pending_d    = 1'b0;
    idle_from_d       = idle_from_q;
    // The current lane as the last clock left it. When it is due, a fall on this clock has
    // started nothing in it (below) and dropped only candidates the drop at the end of the
    // start bits drops too; in the stop bit it changes nothing: so the act reads registers,
    // and nothing of on_edge's is on the way to the decision.
    c_live     = cur_q ? live_q[3:2] : live_q[1:0];
    c_first    = cur_q ? first_q[1] : first_q[0];
    c_last     = c_live == 2'b11 ? !c_first : c_first;
    c_stage    = cur_q ? stage_q[3:2] : stage_q[1:0];
    c_starts   = cur_q ? starts_q[2*TW +: 2*TW] : starts_q[0 +: 2*TW];
    // The middles of the current lane's candidates' stop bits, from the registers: the act's
    // choice of a candidate only picks one.
    c_stop_middles = {c_starts[TW +: TW] + TW'(stop_middle_i), c_starts[0 +: TW] + TW'(stop_middle_i)};
    c_idle     = cur_q ? idle_q[IW +: IW] : idle_q[0 +: IW];
    c_over     = cur_q ? start_over[3:2] : start_over[1:0];
    c_low      = cur_q ? start_low_c[3:2] : start_low_c[1:0];
    c_glitches = cur_q ? {readers_c[3*RW + GlitchesAt +: 2], readers_c[2*RW + GlitchesAt +: 2]}
                       : {readers_c[RW + GlitchesAt +: 2], readers_c[GlitchesAt +: 2]};
    // The idle time of the lane a decision made current on the last clock (EdgeRx::decide
    // writes it there and then): from the decided character's end, or its first start with
    // none, to the lane's first fall. A lane still empty then gets its own at its first fall.
    for (int l = 0; l < 2; l++) begin
      if (idle_pending_q && cur_q == l[0] && live_q[2*l +: 2] != 2'b00) begin
        idle_d[l*IW +: IW] = idle_between(idle_from_q, opened_q[l*TW +: TW]);
      end
    end
    // Due by the deadline the last clock left, compared with this clock on the last one
    // (due_q): a fall on this clock that changes it (a candidate opened, its deadline ahead;
    // a dropped one, only when it was due already) does not change whether it is due.
    due = (cur_q ? live_b[3:2] != 2'b00 && start_reader[3:2] == 2'b00 && due_q[1]
                 : live_b[1:0] != 2'b00 && start_reader[1:0] == 2'b00 && due_q[0]);
    // Each lane's deadline against the next clock. A deadline written on this clock is ahead
    // of it (a start bit from now, the stop bit's middle or end of a candidate whose start bit
    // is over); one a drop wrote is no later than the one before, which was reached if it is.
    for (int l = 0; l < 2; l++) begin
      due_d[l] = reached_next(deadline_q[l*TW +: TW]) && start_reader[2*l +: 2] == 2'b00;
    end
    // Its candidates dropped at the end of their start bits (by the readers through now).
    d_live  = c_live & (~c_over | c_low);
    d_first = (c_first ? !d_live[1] && d_live[0] : !d_live[0] && d_live[1]) ? !c_first : c_first;
    d_last  = d_live == 2'b11 ? !d_first : d_first;
    first_read = read_char(c_first ? ahead_q[(2 + int'(level_i))*13 +: 13]
                                   : ahead_q[int'(level_i)*13 +: 13],
                           c_first ? c_glitches[3:2] : c_glitches[1:0]);
    last_read  = read_char(c_last ? ahead_q[(2 + int'(level_i))*13 +: 13]
                                  : ahead_q[int'(level_i)*13 +: 13],
                           c_last ? c_glitches[3:2] : c_glitches[1:0]);
    // EdgeRx::decide's choice between the two candidates (the first when it is alone).
    // A good reading: no false start, no error, no tie (made a clock ahead: `good_ahead`), and
    // no more glitches than the receiver takes.
    first_good = (c_first ? good_ahead_q[2 + int'(level_i)] : good_ahead_q[int'(level_i)])
              && (c_first ? c_glitches[3:2] : c_glitches[1:0]) != 2'd3;
    last_good  = (c_last ? good_ahead_q[2 + int'(level_i)] : good_ahead_q[int'(level_i)])
              && (c_last ? c_glitches[3:2] : c_glitches[1:0]) != 2'd3;
    both_good  = first_good && last_good;
    if (c_live != 2'b11) chose_last = 1'b0;
    else if (last_good) chose_last = 1'b1;
    else if (first_good) chose_last = 1'b0;
    else chose_last = first_read[11];
    chosen = chose_last ? last_read : first_read;
    // Two different good characters: the line does not say which it was.
    if (c_live == 2'b11 && both_good && first_read[10:3] != last_read[10:3]) chosen[2:0] = 3'd4;
    chosen_slot  = chose_last ? c_last : c_first;
    // The ends of both candidates from registers, the read only choosing.
    first_start  = start_of(c_starts, c_first);
    end_first    = first_start + TW'(stop_end_i);
    end_last     = start_of(c_starts, c_last) + TW'(stop_end_i);
    end_for_idle = chosen[11] ? first_start : chose_last ? end_last : end_first;
    // Each slot's start and end as 32-bit ticks: now_i's upper bits, less one if the start's
    // low bits are past now's (it came before they wrapped); the read only chooses. A start
    // read here is less than half the TickWidth range before now (a character: 12 bits at
    // 9.6k, 60,000 clocks), so its low bits are past now's exactly when its top bit is set
    // and now's is not: one LUT where a comparison was a carry chain before the adder.
    for (int s = 0; s < 2; s++) begin
      start32[s*32 +: 32] = {c_starts[s*TW + TW - 1] && !now[TW-1] ? upper_less_one
                                                                    : now_i[31:TW],
                             c_starts[s*TW +: TW]};
      end32[s*32 +: 32]   = start32[s*32 +: 32] + 32'(stop_end_i);
    end
    for (int l = 0; l < 2; l++) begin
      if (due && cur_q == l[0]) begin
        case (c_stage)
          StartBit: begin
            // Every candidate's start bit is over by now.
            live_d[2*l +: 2] = d_live;
            first_d[l]       = d_first;
            if (d_live != 2'b00) begin
              stage_d[2*l +: 2]      = StopMiddle;
              deadline_d[l*TW +: TW] = start_of(c_stop_middles, d_last);
              next_from_d            = start_of(c_stop_middles, d_first);
              next_from_valid_d      = 1'b1;
              due_d[l]               = 1'b0;
            end
          end
          StopMiddle: begin
            if (!level_i) begin
              due_d[l]               = 1'b0;
              stage_d[2*l +: 2]      = StopEnd;
              deadline_d[l*TW +: TW] = start_of(c_starts, c_last) + TW'(stop_end_i);
            end else begin
              deciding = 1'b1;
            end
          end
          default: deciding = 1'b1;
        endcase
      end
    end
    // The character's fields are loaded on every clock, and read only with char_o.
    char_byte_d        = chosen[10:3];
    char_error_d       = chosen[2:0];
    char_start_d       = chosen_slot ? start32[32 +: 32] : start32[0 +: 32];
    char_end_d         = chosen_slot ? end32[32 +: 32] : end32[0 +: 32];
    char_idle_before_d = c_idle;
    if (deciding) begin
      char_d             = !chosen[11];
      // This lane is closed; the other goes on as the character under way. Its idle time
      // from this character's end is written on the next clock (idle_pending_q), before its
      // own decision can read it.
      for (int l = 0; l < 2; l++) begin
        if (cur_q == l[0]) begin
          live_d[2*l +: 2]  = 2'b00;
          first_d[l]        = 1'b0;
          stage_d[2*l +: 2] = StartBit;
        end
      end
      cur_d             = !cur_q;
      next_from_valid_d = 1'b0;
      idle_pending_d    = 1'b1;
      idle_from_d       = end_for_idle;
    end
    if (hand_over_i || clear_i) begin
      // Afresh: both lanes free, lane 0 the current one. A hand-over is this clock's instead
      // of the act, so it decides nothing; a clear comes after the act.
      if (hand_over_i) char_d = 1'b0;
      live_d            = '0;
      first_d           = '0;
      stage_d           = {StartBit, StartBit};
      cur_d             = 1'b0;
      next_from_valid_d = 1'b0;
      idle_pending_d    = 1'b0;
      due_d             = '0;
      if (hand_over_i && !clear_i && (hand_over_fell_i || hand_over_fell_last_i)) begin
        // The fall opens the character after the one the search decided, in slot 0 of lane
        // 0, its reader started at the hand-over's rate (and stepped on this clock's sample
        // when the fall was on the last clock).
        live_d[1:0]         = 2'b01;
        starts_d[0 +: TW]   = hand_over_start;
        start_low_d[0]      = 1'b0;
        opened_d[0 +: TW]   = hand_over_start;
        idle_d[0 +: IW]     = hand_over_idle_i;
        deadline_d[0 +: TW] = hand_over_fell_last_i ? hand_over_start_end_last
                                                    : hand_over_start_end_now;
        readers_d[0 +: RW]  = hand_over_fell_last_i ? hand_over_stepped : hand_over_started;
      end
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      live_q            <= '0;
      first_q           <= '0;
      starts_q          <= '0;
      readers_q         <= {4{ReaderReset}};
      start_low_q       <= '0;
      opened_q          <= '0;
      idle_q            <= '0;
      stage_q           <= {StartBit, StartBit};
      deadline_q        <= '0;
      cur_q             <= 1'b0;
      next_from_q       <= '0;
      next_from_valid_q <= 1'b0;
      idle_pending_q    <= 1'b0;
      idle_from_q       <= '0;
      due_q             <= '0;
      char_o            <= 1'b0;
      char_byte_o       <= '0;
      char_error_o      <= '0;
      char_start_o      <= '0;
      char_end_o        <= '0;
      char_idle_before_o <= '0;
    end else begin
      live_q            <= live_d;
      first_q           <= first_d;
      starts_q          <= starts_d;
      readers_q         <= readers_d;
      start_low_q       <= start_low_d;
      opened_q          <= opened_d;
      idle_q            <= idle_d;
      stage_q           <= stage_d;
      deadline_q        <= deadline_d;
      cur_q             <= cur_d;
      next_from_q       <= next_from_d;
      next_from_valid_q <= next_from_valid_d;
      idle_pending_q    <= idle_pending_d;
      idle_from_q       <= idle_from_d;
      due_q             <= due_d;
      char_o            <= char_d;
      char_byte_o       <= char_byte_d;
      char_error_o      <= char_error_d;
      char_start_o      <= char_start_d;
      char_end_o        <= char_end_d;
      char_idle_before_o <= char_idle_before_d;
    end
  end

  assign active_o          = cur_q ? live_q[3:2] != 2'b00 : live_q[1:0] != 2'b00;
  assign deadline_o        = cur_q ? deadline_q[TW +: TW] : deadline_q[0 +: TW];
  assign stage_o           = cur_q ? stage_q[3:2] : stage_q[1:0];
  assign next_active_o     = cur_q ? live_q[1:0] != 2'b00 : live_q[3:2] != 2'b00;
  assign next_from_valid_o = next_from_valid_q;
  assign next_from_o       = next_from_q;
endmodule
