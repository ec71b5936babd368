// The transceiver: dp_phy::transceiver::Transceiver's twin (crates/dp-phy/src/transceiver.rs),
// its tick() clock for clock, and its respond() and set_min_tsdr() as ports.
//
// The line (rx_i) goes through the synchroniser to the search, which samples it at every rate;
// held_q keeps it as each rate last sampled it (the model's AutoBaudQ::held). The receiver, its
// idle line (rate_idle, a copy for the rate heard and one for the lock a trial falls back to),
// the delimiter and the baud watchdog work on the rate heard; the state registers are the
// model's: searching, trial or locked, the rate, the fallback, the trial's start (as the clocks
// since it), last_end, and the detection's character for the next clock (`detected`).
//
// One clock runs in the model's order, each stage's decisions taken from the one before it:
//   1. The verdict of the telegram delivered on the last clock (verdict_q, the model's
//      `verdict`): a good one confirms a trial (locked), a bad one fails it: the lock taken
//      back (the receiver and idle line of the lock from this clock on: edge_rx's hand-over
//      without a detection; the lock's idle-line copy, after this clock's change, loaded into
//      the first) or searching again. *_m: the state after it.
//      The character decided on the last clock (edge_rx's registers) or detected goes to the
//      delimiter.
//   2. The idle clocks before a fall at the rate heard.
//   3. The search, told the rate heard; its detection is registered (dp_*_q, the model's
//      `detection`) and acted on the next clock: one at another rate (not of the trial's own
//      delimiter) starts a trial there: the receiver handed over as of the detection's clock
//      (a fall then at its rate steps the reader it starts), the idle line loaded from the
//      detecting channel and taking this clock's change, the lock kept as the fallback.
//   4. Otherwise the receiver steps on the line at the rate heard; with no character under way
//      as the clock began, the delimiter's idle check. A telegram delivered (by its character
//      or a gap) leaves its verdict for the next clock, unless a trial or a search replaces
//      its receiver.
//   5. The baud watchdog, with no telegram or character under way as the clock began and
//      none delivered on it: its expiry searches again.
//   6. The transmitter: a response waiting starts when the line was idle for min TSDR as the
//      clock began, unless this clock changes the rate or searches again (which drop it and
//      stop what goes out). A character that started while the transmitter drove the line is
//      its own echo, not the delimiter's.
// A reset of the delimiter or a rate's figures for it (use_rate) takes effect after its
// character and its idle check, as the model's calls come; the watchdog's commands of the
// clock come in order, the last one standing.
//
// The rates' figures (the receiver's, the glitch, TSYN and the gap in clocks, the detection's
// sample period and stop bit's end) come from transceiver_rates.svh, written from the model.
//
// What changed for hardware: ticks are 32 bits (the model's u64 truncated; every tick compared
// is within 2^31 clocks of now: the baud watchdog bounds how old the idle line's are while
// they are read; the transmitter's last drive, which nothing bounds, is kept as its age
// instead), idle times 24 bits, saturating; a detection's start is its age
// in the detecting channel's samples times that rate's period. In the model too, so that the
// stages need not wait on each other in one clock: a telegram's verdict acts on the next
// clock, and the idle check and the watchdog look at the receiver and the delimiter as the
// clock began. In the RTL only: the idle copies take the clock's change at the rates they had
// as it began (a lock taken back is loaded from its copy after that), the receiver steps at
// the rate heard (a hand-over brings its own rate's start), the gap is compared as now less
// the gap against each tick. The search's detection is acted on one clock after it (model
// and RTL): the search's compare-all-rates and the trial it starts no longer share a clock
// (README "Gateware" has the clock rate step by step).

`default_nettype none

module transceiver #(
  // 0: the receive path alone, the transmitter's ports tied off (cargo xtask gateware places
  // it to follow the receive path's clock rate while the whole top does not fit the part).
  parameter int Transmitter = 1,
  parameter int PhaseWidth = 7,
  parameter int PendWidth  = 12,
  // The tick the top comes out of reset at (the model's Transceiver::reset_at): 0 on the
  // board; rtl-check starts a build just before 2^32, so that its ticks wrap mid-case.
  parameter logic [31:0] NowReset = 32'd0
) (
  input  wire        clk_i,
  input  wire        rst_ni,
  input  wire        rx_i,
  // The baud state (0 searching, 1 trial, 2 locked), its rate (an index into Baud::ALL, 9.6k
  // first; 0 while searching) and the lock a trial falls back to.
  output wire [1:0]  state_o,
  output wire [3:0]  rate_o,
  output wire        fallback_valid_o,
  output wire [3:0]  fallback_o,
  // A telegram delivered on this clock: its status (delimiter.v's code), length and end tick;
  // its bytes went out on wr_* as they came.
  output wire        deliver_o,
  output wire [3:0]  status_o,
  output wire [7:0]  len_o,
  output wire [31:0] end_o,
  output wire        wr_o,
  output wire [7:0]  wr_addr_o,
  output wire [7:0]  wr_data_o,
  // The model's probe: a telegram under way, a character under way at the receiver, and the
  // line idle at the rate heard since idle_since_o (what TSDR counts from).
  output wire        in_telegram_o,
  output wire        rx_active_o,
  output wire        idle_o,
  output wire [31:0] idle_since_o,
  // The transmitter. Min TSDR in bit times as set (Set_Prm; held, under 11 counts as 11).
  input  wire [7:0]  min_tsdr_bits_i,
  // A response (the model's respond()): respond_i for one clock, with its length and the tick
  // it may start at the earliest; respond_ok_o says it is taken. Its bytes are in a
  // synchronous-read buffer outside (the responder's block RAM), written at least a clock
  // before, read at tx_rd_addr_o.
  input  wire        respond_i,
  input  wire [7:0]  respond_len_i,
  input  wire [31:0] respond_not_before_i,
  output wire        respond_ok_o,
  output wire [7:0]  tx_rd_addr_o,
  input  wire [7:0]  tx_rd_data_i,
  // The line driven (the model's drive(): de_o with tx_o's level).
  output wire        tx_o,
  output wire        de_o
);
  localparam int PW = PhaseWidth;
  localparam int IW = 24;
  localparam logic [1:0] Searching = 2'd0, Trial = 2'd1, Locked = 2'd2;
  localparam logic [7:0] SC = 8'hE5;
  localparam logic [3:0] StGood = 4'd0;
  localparam logic [7:0] MinTsdrBits = 8'd11;
  // A character's age when it is delivered is under 2^17 clocks (11.5 bits at 9.6k, 57,500):
  // an age this wide compares it with the transmitter's last drive, which saturates.
  localparam int AgeWidth = 18;

`include "transceiver_rates.svh"

  // The idle clocks from `since` to `now`: 0 if `since` comes later, saturating at 24 bits.
  function automatic logic [IW-1:0] idle_since(input logic [31:0] now, since);
    logic [31:0] diff;
    diff = now - since;
    if (diff[31]) idle_since = '0;
    else if (diff[31:IW] != '0) idle_since = '1;
    else idle_since = diff[IW-1:0];
  endfunction

  // The later of two ticks (within 2^31 of each other).
  function automatic logic [31:0] later(input logic [31:0] a, b);
    later = $signed(a - b) < 0 ? b : a;
  endfunction

  // ---- Registers ----
  logic [31:0] now_q;
  logic [1:0]  state_q, state_d;
  logic [3:0]  rate_q, rate_d;
  logic        fb_valid_q, fb_valid_d;
  logic [3:0]  fb_rate_q, fb_rate_d;
  // The clocks since the trial started, less one, saturating (the model's trial_since seen from
  // the clock: now - 1 - trial_since); meaningful in a trial.
  logic [IW-1:0] since_trial_q, since_trial_d;
  logic [31:0] last_end_q, last_end_d;
  logic        det_q, det_d;
  // The search's detection on the last clock (the model's `detection`): acted on on this one.
  logic        dp_valid_q;
  logic [3:0]  dp_rate_q;
  logic [7:0]  dp_byte_q;
  // Its age in clocks.
  logic [IW-1:0] dp_age_q;
  logic [PendWidth-1:0] dp_left_q;
  // Its channel's idle line rose after the character's end: the copy counts from the decision.
  logic        dp_rose_q;
  logic [31:0] det_idle_from;
  logic        dp_fell_q;
  // Its clock, start and end (stage 3).
  logic [31:0] det_at, det_end;
  logic [IW-1:0] det_age;
  // The detected character's end seen from now: the clocks since it (negative: still to come),
  // IW + 1 bits, so that its tick takes one subtraction and the hand-over's idle time none of
  // 32 bits.
  logic signed [IW:0] det_end_ago, det_idle_ago;
  logic [7:0]  det_byte_q, det_byte_d;
  logic [31:0] det_end_q, det_end_d;
  logic        verdict_q, verdict_d, verdict_good_q, verdict_good_d;
  logic        verdict_confirms_q, verdict_confirms_d;
  logic [9:0]  held_q, held_d;
  // A response taken and not yet started: its length and its earliest tick.
  logic        pending_q, pending_d;
  logic [7:0]  resp_len_q, resp_len_d;
  logic [31:0] not_before_q, not_before_d;
  // Min TSDR in clocks and the transmitter's bit it is worked out from (the model's
  // tsdr_clocks, tx_bit_clocks): the product with the setting is shifted and added a bit of
  // the setting a clock, most significant first (tsdr_step_q: the bits still to add, 8 after
  // a change), where a one-clock multiply took about 200 LUT4. The setting as the last clock
  // began, and whether the rate moved on it: a change of either starts the multiply again,
  // and until it is done the registers are not yet the rate's and the setting's (the model's
  // tsdr_settled).
  logic [12:0] tx_bit_q;
  logic [20:0] tsdr_q, tsdr_d;
  logic [3:0]  tsdr_step_q, tsdr_step_d;
  logic [7:0]  min_tsdr_q;
  logic        rate_moved_q;
  logic        tsdr_restart;
  // Now less min TSDR in clocks (the registers' figure; worked out a clock ahead): the line
  // went quiet long enough when its last end and its idle line's high tick are both at or
  // before it. One comparison a tick, where the idle time's later(), its subtraction from now
  // and its comparison with min TSDR took three carry chains in a row.
  logic [31:0] tsdr_bound_q, tsdr_bound_d;
  // The clocks since the transmitter last drove the line, as this clock begins (the model's
  // drove_until seen from now, saturating; '1 also for never): a character that started by
  // then is the transceiver's own echo. An age, not a tick: a tick 2^31 clocks old (45 s
  // without an answer) would compare as one in the future, and every character since would
  // be taken for an echo. The comparison itself takes the drive's tick, AgeWidth bits of it
  // (drove_at_q), while the age is under 2^(AgeWidth-1): then the start, under 2^17 clocks
  // old, is within 2^17 of it, and one subtraction tells which came later (the age of the
  // start, then its comparison with the drive's, took two carry chains in a row).
  logic [AgeWidth-1:0] drove_age_q, drove_age, drove_age_d;
  logic [AgeWidth-1:0] drove_at_q, drove_at, start_less_drove;
  logic                drove_old;

  // ---- The synchroniser and the search ----
  logic level, fell_unused, rose_unused;
  line_sync #(.FilterLen(0)) u_sync (
    .clk_i, .rst_ni, .line_i(rx_i), .level_o(level), .fell_o(fell_unused), .rose_o(rose_unused)
  );

  logic        rx_on_m;
  logic [3:0]  rate_m;
  logic        s_valid, s_detect;
  logic [3:0]  s_rate_unused;
  logic [7:0]  s_byte;
  logic [1:0]  s_reject_unused;
  logic [IW-1:0] s_age;
  logic [PendWidth-1:0] s_pending_left;
  logic        s_rose_after_end;
  logic [9:0]  s_detect_rate;
  // The detection's rate, read only with a detection: its index from the one-hot (an OR a
  // bit), not the search's rate_o, which a priority encoder over the rejections too gives late.
  logic [3:0]  dp_rate_d;
  always_comb begin
    dp_rate_d = '0;
    for (int r = 0; r < 10; r++) dp_rate_d = dp_rate_d | (s_detect_rate[r] ? 4'(r) : 4'd0);
  end
  wire  [9:0]  samples, measuring_unused;
  autobaud #(.Oversampled(1), .PendWidth(PendWidth)) u_search (
    .clk_i, .rst_ni, .level_i(level), .heard_valid_i(rx_on_m), .heard_i(rate_m),
    .valid_o(s_valid), .detect_o(s_detect), .rate_o(s_rate_unused), .byte_o(s_byte),
    .reject_code_o(s_reject_unused), .start_clocks_o(s_age), .pending_left_o(s_pending_left),
    .rose_after_end_o(s_rose_after_end), .detect_rate_o(s_detect_rate),
    .samples_o(samples), .measuring_o(measuring_unused)
  );

  // Each rate's line as sampled on this clock, and its change there.
  logic [9:0] changed;
  always_comb begin
    for (int r = 0; r < 10; r++) begin
      held_d[r]  = samples[r] ? level : held_q[r];
      changed[r] = samples[r] && level != held_q[r];
    end
  end

  // ---- Blocks driven below ----
  // The receiver.
  logic        rx_hand_over;
  logic [IW-1:0] rx_hand_over_idle, idle_before;
  logic        rx_char;
  logic [7:0]  rx_byte;
  logic [2:0]  rx_error;
  logic [31:0] rx_start, rx_end;
  logic [IW-1:0] rx_char_idle;
  logic        rx_active;
  logic [17:0] rx_deadline_unused, rx_next_from_unused;
  logic [1:0]  rx_stage_unused;
  logic        rx_next_active_unused, rx_next_from_valid_unused;
  // The step at the rate as the clock began (a lock taken back on this clock is a hand-over,
  // which replaces what the step does); a hand-over starts its first candidate at its own
  // rate, the detection's or the rate heard's after the verdict, chosen last.
  logic [RateReaderWidth-1:0] reader;
  // The hand-over's figures: the detection's rate's while there is one (a detection not acted
  // on is of the rate heard, whose figures these are then), the rate heard's otherwise. Not
  // chosen by whether the detection is acted on: that comes late in the clock.
  /* verilator lint_off UNUSEDSIGNAL */
  logic [RateReaderWidth-1:0] ho_reader;
  /* verilator lint_on UNUSEDSIGNAL */
  logic        rx_hand_over_fell, rx_hand_over_fell_last;
  assign reader    = rate_reader(rate_q);
  assign ho_reader = rate_reader(dp_valid_q ? dp_rate_q : rate_m);
  edge_rx #(.PhaseWidth(PW)) u_rx (
    .clk_i, .rst_ni, .now_i(now_q),
    .inc_i(reader[RdInc +: PW]), .two_inc_i(reader[RdTwoInc +: PW + 1]),
    .modulo_i(reader[RdModulo +: PW]), .quarter_i(reader[RdQuarter +: PW]),
    .three_quarters_i(reader[RdThreeQuarters +: PW]),
    .half_less_inc_i(reader[RdHalfLessInc +: PW]),
    .modulo_less_inc_i(reader[RdModuloLessInc +: PW]),
    .modulo_less_two_inc_i(reader[RdModuloLessTwoInc +: PW]),
    .start_end_i(reader[RdStartEnd +: 16]), .stop_middle_i(reader[RdStopMiddle +: 16]),
    .stop_end_i(reader[RdStopEnd +: 16]),
    .step_i(samples[rate_q]), .level_i(held_d[rate_q]), .edge_i(changed[rate_q]),
    .idle_before_i(idle_before), .hand_over_i(rx_hand_over),
    .hand_over_idle_i(rx_hand_over_idle),
    .hand_over_fell_i(rx_hand_over_fell), .hand_over_fell_last_i(rx_hand_over_fell_last),
    // A fall on the last clock is the detection's: this clock's sample at its rate.
    .hand_over_step_i(samples[dp_rate_q]), .hand_over_level_i(held_d[dp_rate_q]),
    .hand_over_edge_i(changed[dp_rate_q]),
    .hand_over_inc_i(ho_reader[RdInc +: PW]), .hand_over_two_inc_i(ho_reader[RdTwoInc +: PW + 1]),
    .hand_over_quarter_i(ho_reader[RdQuarter +: PW]),
    .hand_over_three_quarters_i(ho_reader[RdThreeQuarters +: PW]),
    .hand_over_half_less_inc_i(ho_reader[RdHalfLessInc +: PW]),
    .hand_over_modulo_i(ho_reader[RdModulo +: PW]),
    .hand_over_modulo_less_inc_i(ho_reader[RdModuloLessInc +: PW]),
    .hand_over_modulo_less_two_inc_i(ho_reader[RdModuloLessTwoInc +: PW]),
    .hand_over_start_end_i(ho_reader[RdStartEnd +: 16]),
    .clear_i(1'b0),
    .char_o(rx_char), .char_byte_o(rx_byte), .char_error_o(rx_error),
    .char_start_o(rx_start), .char_end_o(rx_end), .char_idle_before_o(rx_char_idle),
    .active_o(rx_active),
    .deadline_o(rx_deadline_unused), .stage_o(rx_stage_unused),
    .next_active_o(rx_next_active_unused), .next_from_valid_o(rx_next_from_valid_unused),
    .next_from_o(rx_next_from_unused)
  );

  // The idle line at the rate heard, and at the lock during a trial from it.
  logic        idle_load, fb_load;
  logic [PendWidth-1:0] idle_load_left;
  logic [31:0] idle_load_since, idle_load_before;
  logic [PendWidth-1:0] idle_left_unused, idle_left_e, fb_left_unused, fb_left_e;
  logic [31:0] idle_since_q, idle_since_e, idle_before_unused, idle_before_e;
  logic [31:0] fb_since_q, fb_since_e, fb_before_unused, fb_before_e;
  // Both copies take this clock's change at the rate they had as the clock began: a lock taken
  // back on this clock is the fallback copy after its change (*_t, the rate heard's idle line
  // after this clock's change), loaded into the first.
  rate_idle #(.PendWidth(PendWidth)) u_idle (
    .clk_i, .rst_ni, .now_i(now_q), .glitch_i(rate_glitch(rate_q)),
    .sample_i(state_q != Searching && samples[rate_q]), .edge_i(changed[rate_q]),
    .level_i(level),
    .restore_i(1'b0), .restore_cancel_left_i('0), .restore_high_since_i('0),
    .restore_high_before_i('0),
    .load_i(idle_load), .load_cancel_left_i(idle_load_left),
    .load_high_since_i(idle_load_since), .load_high_before_i(idle_load_before),
    .cancel_left_o(idle_left_unused), .high_since_o(idle_since_q),
    .high_before_o(idle_before_unused),
    .cancel_left_e_o(idle_left_e), .high_since_e_o(idle_since_e),
    .high_before_e_o(idle_before_e)
  );
  logic fb_live;
  rate_idle #(.PendWidth(PendWidth)) u_fallback_idle (
    .clk_i, .rst_ni, .now_i(now_q), .glitch_i(rate_glitch(fb_rate_q)),
    .sample_i(fb_live && samples[fb_rate_q]), .edge_i(changed[fb_rate_q]), .level_i(level),
    .restore_i(1'b0), .restore_cancel_left_i('0), .restore_high_since_i('0),
    .restore_high_before_i('0),
    .load_i(fb_load), .load_cancel_left_i(idle_left_t), .load_high_since_i(idle_since_t),
    .load_high_before_i(idle_before_t),
    .cancel_left_o(fb_left_unused), .high_since_o(fb_since_q),
    .high_before_o(fb_before_unused),
    .cancel_left_e_o(fb_left_e), .high_since_e_o(fb_since_e), .high_before_e_o(fb_before_e)
  );
  // The detection's idle line: the detecting channel's as the last clock left it, through this
  // clock's change at its rate (only its values after the change are read).
  logic [PendWidth-1:0] det_left_unused, det_left_e;
  logic [31:0] det_since_unused, det_since_e, det_before_unused, det_before_e;
  rate_idle #(.PendWidth(PendWidth)) u_det_idle (
    .clk_i, .rst_ni, .now_i(now_q), .glitch_i(rate_glitch(dp_rate_q)),
    .sample_i(samples[dp_rate_q]), .edge_i(changed[dp_rate_q]), .level_i(level),
    .restore_i(1'b1), .restore_cancel_left_i(dp_left_q), .restore_high_since_i(det_idle_from),
    .restore_high_before_i(det_idle_from),
    .load_i(1'b0), .load_cancel_left_i('0), .load_high_since_i('0), .load_high_before_i('0),
    .cancel_left_o(det_left_unused), .high_since_o(det_since_unused),
    .high_before_o(det_before_unused),
    .cancel_left_e_o(det_left_e), .high_since_e_o(det_since_e), .high_before_e_o(det_before_e)
  );
  logic [PendWidth-1:0] idle_left_t;
  logic [31:0]          idle_since_t, idle_before_t;
  always_comb begin
    idle_left_t   = restore_m ? fb_left_e : idle_left_e;
    idle_since_t  = restore_m ? fb_since_e : idle_since_e;
    idle_before_t = restore_m ? fb_before_e : idle_before_e;
  end

  // The delimiter.
  logic        ch_valid, det_char;
  logic        dl_config, dl_reset, dl_idle_check;
  logic [3:0]  dl_config_rate;
  logic        idle_over_gap;
  logic [23:0] dl_gap;
  logic        dl_deliver, dl_not_synced_unused;
  logic [3:0]  dl_status;
  logic [7:0]  dl_first;
  delimiter u_delimiter (
    .clk_i, .rst_ni,
    .config_i(dl_config), .tsyn_clocks_i(rate_tsyn(dl_config_rate)),
    .gap_clocks_i(rate_gap(dl_config_rate)), .reset_i(dl_reset),
    .char_i(ch_kept), .char_byte_i(det_char ? det_byte_q : rx_byte),
    .char_error_i(det_char ? 3'd0 : rx_error),
    .char_idle_before_i(det_char ? {IW{1'b1}} : rx_char_idle),
    .char_end_i(det_char ? det_end_q : rx_end),
    .idle_check_i(dl_idle_check), .idle_over_gap_i(idle_over_gap), .now_i(now_q),
    .gap_clocks_o(dl_gap),
    .first_o(dl_first), .in_telegram_o,
    .deliver_o(dl_deliver), .not_synced_o(dl_not_synced_unused), .status_o(dl_status),
    .len_o, .end_o, .wr_o, .wr_addr_o, .wr_data_o
  );

  // The baud watchdog: 20 ticks of 10 ms.
  logic wd_start, wd_stop, wd_check, wd_expired, wd_running_unused;
  logic [23:0] wd_left_unused;
  watchdog #(.Width(24)) u_watchdog (
    .clk_i, .rst_ni, .clocks_i(BaudWatchdogClocks), .start_i(wd_start),
    .start_if_stopped_i(1'b0), .stop_i(wd_stop), .check_i(wd_check),
    .expired_o(wd_expired), .running_o(wd_running_unused), .left_o(wd_left_unused)
  );

  // ---- One clock, in the model's order ----
  // Each stage is an always_comb block of its own that reads only the stages before it and
  // the blocks they drive, so that no combinational loop appears between the blocks (a stage
  // later in the clock never feeds an earlier one).

  // 1. The last clock's verdict, and the character of the last clock.
  assign det_char = det_q;
  assign ch_valid = det_q || rx_char;
  // The receiver's character goes to the delimiter unless it started while the transmitter
  // drove the line (the last end counts it all the same).
  logic ch_kept;
  assign drove_age   = de_o ? AgeWidth'(1) : drove_age_q;
  assign drove_age_d = drove_age + AgeWidth'(drove_age != '1);
  assign drove_at    = de_o ? AgeWidth'(now_q - 32'd1) : drove_at_q;
  assign drove_old   = drove_age[AgeWidth-1];
  // The start less the drive, less one: not negative when the start came later.
  assign start_less_drove = AgeWidth'(rx_start) + ~drove_at;
  assign ch_kept     = det_q || (rx_char && (Transmitter == 0 || drove_old
                                             || !start_less_drove[AgeWidth-1]));
  /* verilator lint_off UNUSEDSIGNAL */
  wire unused_start_high = &{1'b0, rx_start[31:AgeWidth]};
  /* verilator lint_on UNUSEDSIGNAL */
  logic [1:0]  state_m;
  logic        fb_valid_m, restore_m;
  logic [31:0] last_end_m;
  logic        wd1_start, wd1_stop, cfg1, rst1;
  always_comb begin
    last_end_m = ch_valid ? (det_q ? det_end_q : rx_end) : last_end_q;
    state_m    = state_q;
    rate_m     = rate_q;
    fb_valid_m = fb_valid_q;
    restore_m  = 1'b0;
    wd1_start  = 1'b0;
    wd1_stop   = 1'b0;
    cfg1       = 1'b0;
    rst1       = 1'b0;
    if (verdict_q && verdict_good_q) begin
      if (state_q == Trial && verdict_confirms_q) begin
        state_m    = Locked;
        fb_valid_m = 1'b0;
      end
      wd1_start = 1'b1;
    end else if (verdict_q && state_q == Trial) begin
      if (fb_valid_q) begin
        // The lock taken back: its receiver and idle line from this clock on.
        restore_m = 1'b1;
        rate_m    = fb_rate_q;
        state_m   = Locked;
        cfg1      = 1'b1;
      end else begin
        state_m  = Searching;
        wd1_stop = 1'b1;
        rst1     = 1'b1;
      end
      fb_valid_m = 1'b0;
    end
    rx_on_m = state_m != Searching;
  end

  // 2. The idle clocks before a fall at the rate heard (a receiver reset before this clock has
  // nothing under way): for the step at the rate as the clock began, or for a lock taken back
  // (its receiver handed over: the step's idle time then goes nowhere), its idle line chosen
  // first (the verdict is a gate from registers), so that one chain works it out.
  logic rx_was_active, idle_held;
  logic [31:0] idle_high;
  always_comb begin
    // A character under way as the clock began (a lock taken back starts afresh).
    rx_was_active = rx_active && !restore_m;
    idle_held     = restore_m ? held_q[fb_rate_q] : held_q[rate_q] && !rx_active;
    idle_high     = restore_m ? fb_since_q : idle_since_q;
    idle_before   = idle_held ? idle_since(now_q, later(last_end_m, idle_high)) : '0;
    fb_live       = state_q == Trial && fb_valid_q;
  end

  // 3. The search's detection of the last clock: a trial at its rate. This clock's is kept for
  // the next.
  logic        det, ignored, switched;
  logic [1:0]  state3;
  logic [3:0]  rate3;
  logic        fb_valid3, idle_load3;
  logic        wd3_start, wd3_stop, cfg3, rst3;
  logic [3:0]  cfg3_rate;
  always_comb begin
    det       = dp_valid_q;
    det_at    = now_q - 32'd1;
    det_age   = dp_age_q;
    det_end_ago = $signed({1'b0, det_age}) + (IW + 1)'(1)
                - $signed((IW + 1)'(rate_stop_end(dp_rate_q)));
    det_end   = now_q - 32'(det_end_ago);
    det_idle_from = dp_rose_q ? det_at : det_end;
    // The idle clocks before the hand-over's fall (on the detection's clock or this one), from
    // det_idle_from: the decision's clock, or the character's end.
    det_idle_ago = dp_rose_q ? (IW + 1)'(!dp_fell_q) : det_end_ago - (IW + 1)'(dp_fell_q);
    // The receiver's own rate, or the trial's own start delimiter read at a slower rate.
    ignored   = (rx_on_m && rate_m == dp_rate_q)
             || (state_m == Trial && since_trial_q <= det_age);
    switched  = det && !ignored;
    state3        = state_m;
    rate3         = rate_m;
    fb_valid3     = fb_valid_m;
    fb_rate_d     = fb_rate_q;
    since_trial_d = since_trial_q + IW'(since_trial_q != '1);
    last_end_d    = last_end_m;
    det_d         = 1'b0;
    det_byte_d    = det_byte_q;
    det_end_d     = det_end_q;
    fb_load       = 1'b0;
    idle_load3    = 1'b0;
    wd3_start     = wd1_start;
    wd3_stop      = wd1_stop;
    cfg3          = cfg1;
    cfg3_rate     = rate_m;
    rst3          = rst1;
    rx_hand_over      = !rx_on_m || restore_m;
    rx_hand_over_idle = restore_m ? idle_before : '0;
    // A fall at the hand-over's rate (as its figures: the same rate whenever a detection is
    // not acted on).
    rx_hand_over_fell = dp_valid_q ? changed[dp_rate_q] && !held_d[dp_rate_q]
                                   : changed[rate_m] && !held_d[rate_m];
    rx_hand_over_fell_last = 1'b0;
    if (switched) begin
      if (state_m == Searching) begin
        fb_valid3 = 1'b0;
      end else if (state_m == Locked) begin
        // The lock is the trial's fallback, with its idle line as this clock leaves it.
        fb_valid3 = 1'b1;
        fb_rate_d = rate_m;
        fb_load   = 1'b1;
      end
      state3        = Trial;
      rate3         = dp_rate_q;
      since_trial_d = '0;
      cfg3          = 1'b1;
      cfg3_rate     = dp_rate_q;
      // A trial from a lock keeps the lock's watchdog.
      if (!fb_valid3) begin
        wd3_start = 1'b1;
        wd3_stop  = 1'b0;
      end
      idle_load3        = 1'b1;
      last_end_d        = det_end;
      det_d             = 1'b1;
      det_byte_d        = dp_byte_q;
      det_end_d         = det_end;
      // Handed over as of the detection's clock: its fall there, or one on this clock.
      rx_hand_over      = 1'b1;
      rx_hand_over_idle = det_idle_ago < 0 ? '0 : det_idle_ago[IW] ? '1 : det_idle_ago[IW-1:0];
      rx_hand_over_fell_last = dp_fell_q;
    end
  end

  // 4. With no character under way at the receiver as the clock began, the delimiter's idle
  // check.
  // The idle time now (the model's idle(): now less the later of the last end and the line's
  // high tick, saturating at 24 bits) exceeds the gap when now less the gap passes both ticks:
  // one subtraction a tick, against a bound worked out from registers (the gap is under 2^24
  // clocks, each tick within 2^31 of now).
  // A clock that delivers a character finds no gap (the model's rule too), so the bound is
  // compared with the last end kept. The high tick compared is the idle copy's the verdict
  // leaves (a lock taken back: the fallback's).
  logic [31:0] gap_bound;
  always_comb begin
    dl_idle_check = rx_on_m && !switched && !rx_was_active;
    gap_bound     = now_q - 32'(dl_gap) - 32'd1;
    idle_over_gap = !ch_valid && $signed(gap_bound - last_end_q) >= 0
                    && (restore_m ? held_d[fb_rate_q] : held_d[rate_q])
                    && $signed(gap_bound - (restore_m ? fb_since_e : idle_since_e)) >= 0;
  end

  // 5. The idle line's load (a detection's, stage 3, before a lock taken back, stage 1); the
  // watchdog, checked between telegrams, whose expiry searches again; the telegram's verdict
  // for the next clock.
  always_comb begin
    idle_load        = idle_load3 || restore_m;
    idle_load_left   = idle_load3 ? det_left_e : fb_left_e;
    idle_load_since  = idle_load3 ? det_since_e : fb_since_e;
    idle_load_before = idle_load3 ? det_before_e : fb_before_e;
    wd_start         = wd3_start;
    wd_stop          = wd3_stop;
    // Between telegrams: none under way as the clock began (in_telegram_o), so not on the
    // clock one ends (its verdict restarts the watchdog on the next), and no character
    // delivered on this clock (a telegram's first, whose telegram it would drop).
    wd_check         = rx_on_m && !switched && !rx_was_active && !in_telegram_o && !ch_valid;
  end

  always_comb begin
    rate_d             = rate3;
    state_d            = wd_expired ? Searching : state3;
    fb_valid_d         = fb_valid3 && !wd_expired;
    dl_config          = cfg3;
    dl_config_rate     = cfg3_rate;
    dl_reset           = rst3 || wd_expired;
    verdict_d          = dl_deliver && !switched && !wd_expired;
    verdict_good_d     = dl_status == StGood;
    verdict_confirms_d = dl_first != SC;
  end

  // 6. The transmitter. A waiting response (or one taken on this clock) starts if the line was
  // idle for min TSDR as the clock began (idle_o, idle_since_o: the registers) and its
  // earliest tick has come, unless this clock gives the transmitter a new rate or none (a
  // trial, a lock taken back, a search: the model's use_rate and search_again), which drops
  // what waits and stops what goes out. The idle time is the registers': with idle_o no
  // character is delivered, and on the clock a detection's reaches the delimiter the last
  // end kept is its own; a lock taken back clears the transmitter whatever it says.
  logic [7:0]  min_tsdr;
  logic        tx_busy, tx_clear, respond_ok, resp_waiting, resp_due;
  logic [7:0]  resp_len;
  logic [31:0] resp_not_before;
  always_comb begin
    min_tsdr        = min_tsdr_bits_i < MinTsdrBits ? MinTsdrBits : min_tsdr_bits_i;
    respond_ok      = Transmitter != 0 && respond_i && state_q != Searching
                      && respond_len_i != '0 && !pending_q && !tx_busy;
    resp_waiting    = pending_q || respond_ok;
    resp_len        = pending_q ? resp_len_q : respond_len_i;
    resp_not_before = pending_q ? not_before_q : respond_not_before_i;
    resp_due        = resp_waiting && !tsdr_restart && tsdr_step_q == '0 && idle_o
                      && $signed(now_q - resp_not_before) >= 0
                      && $signed(tsdr_bound_q - last_end_q) >= 0
                      && $signed(tsdr_bound_q - idle_since_q) >= 0;
    // The transmitter starts on resp_due unless tx_clear drops it (uart_tx.v takes both).
    tx_clear        = dl_config || dl_reset;
    pending_d       = resp_waiting && !resp_due && !tx_clear;
    resp_len_d      = resp_len;
    not_before_d    = resp_not_before;
  end
  always_comb begin
    tsdr_restart = rate_moved_q || min_tsdr != min_tsdr_q;
    tsdr_d       = tsdr_q;
    tsdr_step_d  = tsdr_step_q;
    if (tsdr_restart) begin
      tsdr_d      = '0;
      tsdr_step_d = 4'd8;
    end else if (tsdr_step_q != '0) begin
      tsdr_d      = {tsdr_q[19:0], 1'b0} + (min_tsdr[3'(tsdr_step_q - 4'd1)] ? 21'(tx_bit_q) : '0);
      tsdr_step_d = tsdr_step_q - 4'd1;
    end
    tsdr_bound_d = now_q + 32'd1 - 32'(tsdr_d);
  end
  if (Transmitter != 0) begin : g_tx
    uart_tx #(.PhaseWidth(13)) u_tx (
      .clk_i, .rst_ni, .inc_i(13'd1), .modulo_i(rate_bit(rate_q)), .clear_i(tx_clear),
      .start_i(resp_due), .len_i(resp_len), .rd_addr_o(tx_rd_addr_o),
      .rd_data_i(tx_rd_data_i), .tx_o, .de_o, .busy_o(tx_busy)
    );
  end else begin : g_no_tx
    assign tx_rd_addr_o = '0;
    assign tx_o         = 1'b1;
    assign de_o         = 1'b0;
    assign tx_busy      = 1'b0;
    /* verilator lint_off UNUSEDSIGNAL */
    wire unused_tx = &{1'b0, tx_rd_data_i, tx_clear, resp_len};
    /* verilator lint_on UNUSEDSIGNAL */
  end

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      now_q         <= NowReset;
      state_q       <= Searching;
      rate_q        <= '0;
      fb_valid_q    <= 1'b0;
      fb_rate_q     <= '0;
      since_trial_q <= '1;
      last_end_q    <= NowReset;
      det_q         <= 1'b0;
      det_byte_q    <= '0;
      det_end_q     <= '0;
      dp_valid_q    <= 1'b0;
      dp_rate_q     <= '0;
      dp_byte_q     <= '0;
      dp_age_q      <= '0;
      dp_left_q     <= '0;
      dp_rose_q     <= 1'b0;
      dp_fell_q     <= 1'b0;
      verdict_q          <= 1'b0;
      verdict_good_q     <= 1'b0;
      verdict_confirms_q <= 1'b0;
      held_q        <= '1;
      pending_q     <= 1'b0;
      resp_len_q    <= '0;
      not_before_q  <= '0;
      tx_bit_q      <= rate_bit(4'd0);
      tsdr_q        <= 21'(rate_bit(4'd0)) * 21'(MinTsdrBits);
      tsdr_step_q   <= '0;
      tsdr_bound_q  <= NowReset - 32'(21'(rate_bit(4'd0)) * 21'(MinTsdrBits));
      min_tsdr_q    <= MinTsdrBits;
      rate_moved_q  <= 1'b0;
      drove_age_q   <= '1;
      drove_at_q    <= '0;
    end else begin
      now_q         <= now_q + 32'd1;
      state_q       <= state_d;
      rate_q        <= rate_d;
      fb_valid_q    <= fb_valid_d;
      fb_rate_q     <= fb_rate_d;
      since_trial_q <= since_trial_d;
      last_end_q    <= last_end_d;
      det_q         <= det_d;
      det_byte_q    <= det_byte_d;
      det_end_q     <= det_end_d;
      dp_valid_q    <= s_valid && s_detect;
      dp_rate_q     <= dp_rate_d;
      dp_byte_q     <= s_byte;
      dp_age_q      <= s_age;
      dp_left_q     <= s_pending_left;
      dp_rose_q     <= s_rose_after_end;
      // The line fell at the detection's rate: its one-hot rate against every rate's fall,
      // not a multiplexer by its index (which comes late in the clock).
      dp_fell_q     <= |(s_detect_rate & changed & ~held_d);
      verdict_q          <= verdict_d;
      verdict_good_q     <= verdict_good_d;
      verdict_confirms_q <= verdict_confirms_d;
      held_q        <= held_d;
      pending_q     <= pending_d;
      resp_len_q    <= resp_len_d;
      not_before_q  <= not_before_d;
      tx_bit_q      <= rate_bit(rate_d);
      tsdr_q        <= tsdr_d;
      tsdr_step_q   <= tsdr_step_d;
      tsdr_bound_q  <= tsdr_bound_d;
      min_tsdr_q    <= min_tsdr;
      rate_moved_q  <= rate_d != rate_q;
      drove_age_q   <= drove_age_d;
      drove_at_q    <= drove_at;
    end
  end

  assign state_o          = state_q;
  assign rate_o           = state_q == Searching ? 4'd0 : rate_q;
  assign fallback_valid_o = fb_valid_q;
  assign fallback_o       = fb_valid_q ? fb_rate_q : 4'd0;
  assign deliver_o        = dl_deliver;
  assign status_o         = dl_status;
  assign rx_active_o      = rx_active && state_q != Searching;
  assign idle_o           = state_q != Searching && held_q[rate_q] && !rx_active_o && !rx_char;
  assign idle_since_o     = later(last_end_q, idle_since_q);
  assign respond_ok_o     = respond_ok;
endmodule

`default_nettype wire
