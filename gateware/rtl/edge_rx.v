// The receiver at a known rate: dp_phy::edge_rx::EdgeRx's twin (crates/dp-phy/src/edge_rx.rs),
// register for register but for read_until (the readers here take every clock as it comes; the
// model passes the clocks between its events at once).
//
// Each clock takes the synchronised line (level_i, and edge_i: it changed on this clock) and
// does what the transceiver's tick does with the model, in its order: on_edge (a fall after
// idle_before_i idle clocks opens a candidate), then act when the character under way falls
// due (its deadline reached), which may decide a character (char_o and its fields, this
// clock). hand_over_i is the search's hand-over of this clock instead (EdgeRx::hand_over: the
// receiver starts afresh, with this clock's fall; hand_over_end_i is the detected character's
// end), clear_i the transceiver's reset of it after everything else (a rate dropped or changed).
//
// Two lanes of two candidates: lane 0 the character under way (the model's cur), lane 1 the next
// one (next), whose candidates the falls from next_from on open while lane 0's decision is
// pending. Each candidate has a character reader (char_reader_step, 13-bit phase at the rate
// chosen at run time, its figures as inputs) and its start bit as its reader decided it.
//
// What changed for hardware: ticks are 32 bits (the model's u64 truncated; every tick compared
// is within a character of now, so a signed difference orders them across the wrap); the idle
// clocks are 24 bits, saturating (TSYN at 9.6k is 165,000 clocks); a lane's deadline is valid
// while it has candidates (the model's Tick::MAX otherwise).
`default_nettype none

module edge_rx #(
  parameter int PhaseWidth  = 13,
  parameter int TickWidth   = 32,
  parameter int IdleWidth   = 24,
  parameter int OffsetWidth = 16
) (
  input  wire                   clk_i,
  input  wire                   rst_ni,
  input  wire [TickWidth-1:0]   now_i,
  // The rate's CharReader figures (char_reader.v's), and the clocks from a start edge to the
  // end of its start bit, the middle of its stop bit and its end.
  input  wire [PhaseWidth-1:0]  inc_i,
  input  wire [PhaseWidth-1:0]  modulo_i,
  input  wire [PhaseWidth-1:0]  quarter_i,
  input  wire [PhaseWidth-1:0]  three_quarters_i,
  input  wire [PhaseWidth-1:0]  half_less_inc_i,
  input  wire [PhaseWidth:0]    two_inc_i,
  input  wire [PhaseWidth-1:0]  modulo_less_inc_i,
  input  wire [PhaseWidth-1:0]  modulo_less_two_inc_i,
  input  wire [OffsetWidth-1:0] start_end_i,
  input  wire [OffsetWidth-1:0] stop_middle_i,
  input  wire [OffsetWidth-1:0] stop_end_i,
  input  wire                   level_i,
  input  wire                   edge_i,
  input  wire [IdleWidth-1:0]   idle_before_i,
  input  wire                   hand_over_i,
  input  wire [TickWidth-1:0]   hand_over_end_i,
  input  wire                   clear_i,
  // A character decided on this clock: its byte, error (0 none, 1 parity, 2 framing, 3 break,
  // 4 noise: delimiter.v's code), start and end ticks, and the idle clocks before it.
  output logic                  char_o,
  output logic [7:0]            char_byte_o,
  output logic [2:0]            char_error_o,
  output logic [TickWidth-1:0]  char_start_o,
  output logic [TickWidth-1:0]  char_end_o,
  output logic [IdleWidth-1:0]  char_idle_before_o,
  // A character under way (EdgeRxQ::active), after the last clock and as this clock leaves it.
  output wire                   active_o,
  output wire                   active_next_o,
  // For the checker: lane 0's deadline and stage, lane 1 under way, next_from.
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
  localparam int BitAt      = 4 * PW + 17;
  localparam logic [RW-1:0] ReaderReset = {4'd11, (RW - 4)'(0)};
  localparam logic [1:0] StartBit = 2'd0, StopMiddle = 2'd1, StopEnd = 2'd2;

  // The lanes' registers, flat: lane l's field at [l * width +: width], candidate s of lane l
  // at [(2 * l + s) * width +: width].
  logic [3:0]      n_q, n_d;            // candidates under way, 0..2
  logic [4*TW-1:0] starts_q, starts_d;
  logic [4*RW-1:0] readers_q, readers_d;
  logic [3:0]      start_low_q, start_low_d;
  logic [2*TW-1:0] opened_q, opened_d;
  logic [2*IW-1:0] idle_q, idle_d;
  logic [3:0]      stage_q, stage_d;
  logic [2*TW-1:0] deadline_q, deadline_d;
  logic [TW-1:0]   next_from_q, next_from_d;
  logic            next_from_valid_q, next_from_valid_d;

  // The idle clocks from `from` to `to`: 0 if `to` comes first, saturating at IdleWidth bits.
  function automatic logic [IW-1:0] idle_between(input logic [TW-1:0] from, to);
    logic [TW-1:0] diff;
    diff = to - from;
    if (diff[TW-1]) idle_between = {IW{1'b0}};
    else if (diff > TW'({IW{1'b1}})) idle_between = {IW{1'b1}};
    else idle_between = diff[IW-1:0];
  endfunction

  // `at` is now or before it.
  function automatic logic reached(input logic [TW-1:0] at);
    logic [TW-1:0] diff;
    diff = now_i - at;
    reached = !diff[TW-1];
  endfunction

  // ---- on_edge: the fall's lane drops its false starts and opens a candidate; every reader
  // under way takes the clock. ----
  logic       fell, fall_next;
  logic [1:0] fall_here;
  // Each lane after the fall's drop and its candidate opened.
  logic [3:0]      n_b;
  logic [4*TW-1:0] starts_b;
  logic [4*RW-1:0] readers_b;
  logic [3:0]      start_low_b;
  logic [2*TW-1:0] opened_b;
  logic [2*IW-1:0] idle_b;
  logic [3:0]      stage_b;
  logic [2*TW-1:0] deadline_b;
  logic [3:0]      start_reader, step_reader;
  // Each lane's drop as a fall finds it (the readers through the clock before).
  logic [3:0]      n_dropped;
  logic [4*TW-1:0] starts_dropped;
  logic [4*RW-1:0] readers_dropped;
  logic [3:0]      start_low_dropped;
  // The readers after this clock, and each candidate's start bit as it now stands.
  logic [4*RW-1:0] readers_c;
  logic [3:0]      start_low_c;

  for (genvar l = 0; l < 2; l++) begin : g_lane_drop
    edge_rx_drop #(.ReaderWidth(RW), .TickWidth(TW)) u_drop (
      .n_i(n_q[2*l +: 2]),
      .starts_i(starts_q[2*l*TW +: 2*TW]),
      .readers_i(readers_q[2*l*RW +: 2*RW]),
      .start_low_i(start_low_q[2*l +: 2]),
      .n_o(n_dropped[2*l +: 2]),
      .starts_o(starts_dropped[2*l*TW +: 2*TW]),
      .readers_o(readers_dropped[2*l*RW +: 2*RW]),
      .start_low_o(start_low_dropped[2*l +: 2])
    );
  end

  always_comb begin
    fell         = edge_i && !level_i;
    // From the middle of lane 0's first candidate's stop bit on, falls open the next character.
    fall_next    = next_from_valid_q && reached(next_from_q);
    fall_here[0] = fell && !fall_next;
    fall_here[1] = fell && fall_next;
    n_b          = n_q;
    starts_b     = starts_q;
    readers_b    = readers_q;
    start_low_b  = start_low_q;
    opened_b     = opened_q;
    idle_b       = idle_q;
    stage_b      = stage_q;
    deadline_b   = deadline_q;
    start_reader = '0;
    for (int l = 0; l < 2; l++) begin
      if (fall_here[l] && stage_q[2*l +: 2] == StartBit) begin
        n_b[2*l +: 2]              = n_dropped[2*l +: 2];
        starts_b[2*l*TW +: 2*TW]   = starts_dropped[2*l*TW +: 2*TW];
        readers_b[2*l*RW +: 2*RW]  = readers_dropped[2*l*RW +: 2*RW];
        start_low_b[2*l +: 2]      = start_low_dropped[2*l +: 2];
        // The last candidate kept, at the end of its start bit.
        deadline_b[l*TW +: TW] = (n_dropped[2*l +: 2] == 2'd2
            ? starts_dropped[(2*l+1)*TW +: TW] : starts_dropped[2*l*TW +: TW])
            + TW'(start_end_i);
      end
      if (fall_here[l]) begin
        if (n_b[2*l +: 2] == 2'd0) begin
          // The first candidate of a character (the model's lane from LANE_EMPTY).
          n_b[2*l +: 2]                  = 2'd1;
          starts_b[2*l*TW +: 2*TW]       = {now_i, now_i};
          readers_b[(2*l+1)*RW +: RW]    = ReaderReset;
          start_low_b[2*l +: 2]          = 2'b00;
          opened_b[l*TW +: TW]           = now_i;
          idle_b[l*IW +: IW]             = idle_before_i;
          stage_b[2*l +: 2]              = StartBit;
          deadline_b[l*TW +: TW]         = now_i + TW'(start_end_i);
          start_reader[2*l]              = 1'b1;
        end else if (readers_b[2*l*RW + BitAt +: 4] == 4'd0) begin
          // Inside the first candidate's start bit: a second candidate (a later one replaces it).
          n_b[2*l +: 2]                  = 2'd2;
          starts_b[(2*l+1)*TW +: TW]     = now_i;
          start_low_b[2*l+1]             = 1'b0;
          stage_b[2*l +: 2]              = StartBit;
          deadline_b[l*TW +: TW]         = now_i + TW'(start_end_i);
          start_reader[2*l+1]            = 1'b1;
        end
      end
      for (int s = 0; s < 2; s++) step_reader[2*l+s] = 2'(s) < n_b[2*l +: 2];
    end
  end

  for (genvar k = 0; k < 4; k++) begin : g_reader
    char_reader_step #(.PhaseWidth(PW)) u_step (
      .inc_i, .modulo_i, .quarter_i, .three_quarters_i, .half_less_inc_i, .two_inc_i,
      .modulo_less_inc_i, .modulo_less_two_inc_i,
      .step_i(step_reader[k]),
      .start_i(start_reader[k]),
      .level_i,
      .edge_i,
      .state_i(readers_b[k*RW +: RW]),
      .state_o(readers_c[k*RW +: RW])
    );
    // A start bit decided on this clock: low, and no tie.
    assign start_low_c[k] =
        !start_reader[k] && step_reader[k] && readers_b[k*RW + BitAt +: 4] == 4'd0
        && readers_c[k*RW + BitAt +: 4] == 4'd1
        ? !readers_c[k*RW + TieAt] && !readers_c[k*RW + ShiftAt + 10]
        : start_low_b[k];
  end

  // ---- act: lane 0 at its deadline. ----
  logic [1:0]      n_act;
  logic [2*TW-1:0] starts_act;
  logic [2*RW-1:0] readers_act;
  logic [1:0]      start_low_act;

  edge_rx_drop #(.ReaderWidth(RW), .TickWidth(TW)) u_drop_at_start_end (
    .n_i(n_b[1:0]),
    .starts_i(starts_b[0 +: 2*TW]),
    .readers_i(readers_c[0 +: 2*RW]),
    .start_low_i(start_low_c[1:0]),
    .n_o(n_act),
    .starts_o(starts_act),
    .readers_o(readers_act),
    .start_low_o(start_low_act)
  );

  // What a candidate reads, the line lasting at level_i: its 11 bits (the stop bit under way,
  // bit 10, or decided), a tie, and whether it is a false start or a character with its byte
  // and error (EdgeRx::read_char).
  function automatic logic [11:0] read_bits(input logic [RW-1:0] r);
    logic [PW:0] total;
    logic        positive;
    total    = level_i ? r[LeadAt +: PW + 1] : r[LagAt +: PW + 1];
    positive = !total[PW] && total != {(PW + 1){1'b0}};
    if (r[BitAt +: 4] == 4'd11) read_bits = {r[TieAt], r[ShiftAt +: 11]};
    else read_bits = {r[TieAt] || total == {(PW + 1){1'b0}}, positive, r[ShiftAt + 1 +: 10]};
  endfunction

  // {false start, byte, error}.
  function automatic logic [11:0] read_char(input logic [RW-1:0] r);
    logic [11:0] tb;
    logic [7:0]  byte_;
    tb    = read_bits(r);
    byte_ = tb[8:1];
    if (tb[11]) read_char = {1'b0, 8'd0, 3'd4};
    else if (tb[0]) read_char = {1'b1, byte_, 3'd0};
    else if (r[GlitchesAt +: 2] == 2'd3) read_char = {1'b0, byte_, 3'd4};
    else if (tb[10:0] == 11'd0) read_char = {1'b0, byte_, 3'd3};
    else if (!tb[10]) read_char = {1'b0, byte_, 3'd2};
    else if (tb[9] != ^byte_) read_char = {1'b0, byte_, 3'd1};
    else read_char = {1'b0, byte_, 3'd0};
  endfunction

  logic            due, deciding, chose_last;
  logic [11:0]     first_read, last_read, chosen;
  logic [TW-1:0]   end_for_idle;
  logic [RW-1:0]   last_reader;

  always_comb begin
    n_d               = n_b;
    starts_d          = starts_b;
    readers_d         = readers_c;
    start_low_d       = start_low_c;
    opened_d          = opened_b;
    idle_d            = idle_b;
    stage_d           = stage_b;
    deadline_d        = deadline_b;
    next_from_d       = next_from_q;
    next_from_valid_d = next_from_valid_q;
    char_o            = 1'b0;
    char_byte_o       = '0;
    char_error_o      = '0;
    char_start_o      = '0;
    char_end_o        = '0;
    char_idle_before_o = '0;
    deciding          = 1'b0;
    due = n_b[1:0] != 2'd0 && reached(deadline_b[0 +: TW]);
    last_reader = n_b[1:0] == 2'd2 ? readers_c[RW +: RW] : readers_c[0 +: RW];
    first_read  = read_char(readers_c[0 +: RW]);
    last_read   = read_char(last_reader);
    // EdgeRx::decide's choice between the two candidates (the last one read when it is alone).
    chose_last  = 1'b1;
    if (n_b[1:0] == 2'd2) begin
      if (!first_read[11] && first_read[2:0] == 3'd0 && !last_read[11] && last_read[2:0] == 3'd0
          && first_read[10:3] != last_read[10:3]) begin
        chose_last = 1'b1;
      end else if (!last_read[11] && last_read[2:0] == 3'd0) begin
        chose_last = 1'b1;
      end else if (!first_read[11] && first_read[2:0] == 3'd0) begin
        chose_last = 1'b0;
      end else begin
        chose_last = first_read[11];
      end
    end
    chosen = chose_last ? last_read : first_read;
    if (n_b[1:0] == 2'd2 && !first_read[11] && first_read[2:0] == 3'd0 && !last_read[11]
        && last_read[2:0] == 3'd0 && first_read[10:3] != last_read[10:3]) begin
      // Two different good characters: the line does not say which it was.
      chosen[2:0] = 3'd4;
    end
    if (due) begin
      case (stage_b[1:0])
        StartBit: begin
          // Every candidate's start bit is over by now.
          n_d[1:0]             = n_act;
          starts_d[0 +: 2*TW]  = starts_act;
          readers_d[0 +: 2*RW] = readers_act;
          start_low_d[1:0]     = start_low_act;
          if (n_act != 2'd0) begin
            stage_d[1:0]          = StopMiddle;
            deadline_d[0 +: TW]   = (n_act == 2'd2 ? starts_act[TW +: TW] : starts_act[0 +: TW])
                                  + TW'(stop_middle_i);
            next_from_d           = starts_act[0 +: TW] + TW'(stop_middle_i);
            next_from_valid_d     = 1'b1;
          end
        end
        StopMiddle: begin
          if (!level_i) begin
            stage_d[1:0]        = StopEnd;
            deadline_d[0 +: TW] = (n_b[1:0] == 2'd2 ? starts_b[TW +: TW] : starts_b[0 +: TW])
                                + TW'(stop_end_i);
          end else begin
            deciding = 1'b1;
          end
        end
        default: deciding = 1'b1;
      endcase
    end
    if (deciding) begin
      char_o             = !chosen[11];
      char_byte_o        = chosen[10:3];
      char_error_o       = chosen[2:0];
      char_start_o       = chose_last && n_b[1:0] == 2'd2 ? starts_b[TW +: TW] : starts_b[0 +: TW];
      char_end_o         = char_start_o + TW'(stop_end_i);
      char_idle_before_o = idle_b[0 +: IW];
      end_for_idle       = char_o ? char_end_o : starts_b[0 +: TW];
      // Lane 1 goes on as lane 0; lane 1 starts empty.
      n_d                  = {2'd0, n_b[3:2]};
      starts_d             = {{2*TW{1'b0}}, starts_b[2*TW +: 2*TW]};
      readers_d            = {{2{ReaderReset}}, readers_c[2*RW +: 2*RW]};
      start_low_d          = {2'b00, start_low_c[3:2]};
      opened_d             = {{TW{1'b0}}, opened_b[TW +: TW]};
      idle_d               = {{IW{1'b0}}, idle_between(end_for_idle, opened_b[TW +: TW])};
      stage_d              = {StartBit, stage_b[3:2]};
      deadline_d           = {{TW{1'b0}}, deadline_b[TW +: TW]};
      next_from_valid_d    = 1'b0;
      next_from_d          = '0;
    end else begin
      end_for_idle = '0;
    end
    if (hand_over_i) begin
      // The search's hand-over: afresh, with this clock's fall.
      char_o            = 1'b0;
      n_d               = '0;
      starts_d          = '0;
      readers_d         = {4{ReaderReset}};
      start_low_d       = '0;
      opened_d          = '0;
      idle_d            = '0;
      stage_d           = {StartBit, StartBit};
      deadline_d        = '0;
      next_from_d       = '0;
      next_from_valid_d = 1'b0;
      if (fell) begin
        n_d[1:0]            = 2'd1;
        starts_d[0 +: 2*TW] = {now_i, now_i};
        readers_d[0 +: RW]  = {4'd0, modulo_less_inc_i, 1'b0, modulo_less_two_inc_i,
                               -{1'b0, modulo_i}, (11 + 1 + 2 + 1 + PW)'(0)};
        opened_d[0 +: TW]   = now_i;
        idle_d[0 +: IW]     = idle_between(hand_over_end_i, now_i);
        deadline_d[0 +: TW] = now_i + TW'(start_end_i);
      end
    end
    if (clear_i) begin
      n_d               = '0;
      starts_d          = '0;
      readers_d         = {4{ReaderReset}};
      start_low_d       = '0;
      opened_d          = '0;
      idle_d            = '0;
      stage_d           = {StartBit, StartBit};
      deadline_d        = '0;
      next_from_d       = '0;
      next_from_valid_d = 1'b0;
    end
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      n_q               <= '0;
      starts_q          <= '0;
      readers_q         <= {4{ReaderReset}};
      start_low_q       <= '0;
      opened_q          <= '0;
      idle_q            <= '0;
      stage_q           <= {StartBit, StartBit};
      deadline_q        <= '0;
      next_from_q       <= '0;
      next_from_valid_q <= 1'b0;
    end else begin
      n_q               <= n_d;
      starts_q          <= starts_d;
      readers_q         <= readers_d;
      start_low_q       <= start_low_d;
      opened_q          <= opened_d;
      idle_q            <= idle_d;
      stage_q           <= stage_d;
      deadline_q        <= deadline_d;
      next_from_q       <= next_from_d;
      next_from_valid_q <= next_from_valid_d;
    end
  end

  assign active_o          = n_q[1:0] != 2'd0;
  assign active_next_o     = n_d[1:0] != 2'd0;
  assign deadline_o        = deadline_q[0 +: TW];
  assign stage_o           = stage_q[1:0];
  assign next_active_o     = n_q[3:2] != 2'd0;
  assign next_from_valid_o = next_from_valid_q;
  assign next_from_o       = next_from_q;
endmodule
