// The telegram delimiter: dp_phy::delimiter::Delimiter's twin (crates/dp-phy/src/delimiter.rs).
//
// Cuts the receiver's characters into telegrams and checks their frame. A telegram starts only
// after TSYN of idle line, and ends where its start delimiter (and SD2's length) says, or at the
// first thing wrong with it: a character error, an idle gap inside, LE != LEr or a missing second
// SD2, LE out of 4..249, a bad FCS, a missing ED. Each call of the model is an input strobe of
// this clock, in the model's order: a character (on_char, with the idle clocks before it), then
// the idle check (on_idle, on every clock the receiver is not inside a character), then a reset
// or a rate's configuration (Delimiter::reset, Delimiter::new's figures). The outputs are what
// those calls return, in the same clock (three always_comb blocks, one a call).
//
// What changed for hardware: the model sums the FCS over its buffer when the telegram is
// complete; here fcs_q sums the body as the characters come, and fcs_ok_q keeps whether the FCS
// character matched (the same status, one byte at a time). The telegram's bytes go to a RAM as
// they come (wr_*), its length out with the delivery. Times are 32 bits (the model's u64 ticks
// truncated: 89 s at 48 MHz, more than any telegram lasts; the end tick is passed through).
`default_nettype none

module delimiter (
  input  wire        clk_i,
  input  wire        rst_ni,
  // Delimiter::new: TSYN and the gap inside a telegram, in clocks; a rate's (re)start.
  input  wire        config_i,
  input  wire [23:0] tsyn_clocks_i,
  input  wire [23:0] gap_clocks_i,
  // Delimiter::reset: drop a telegram under way.
  input  wire        reset_i,
  // on_char: a character, its error (0 none, 1 parity, 2 framing, 3 break, 4 noise), the idle
  // clocks before it (saturating) and its end tick.
  input  wire        char_i,
  input  wire [7:0]  char_byte_i,
  input  wire [2:0]  char_error_i,
  input  wire [23:0] char_idle_before_i,
  input  wire [31:0] char_end_i,
  // on_idle: whether the line's idle clocks now exceed the gap (gap_clocks_o: the caller
  // compares, with figures it has at hand, and spares the clock a subtraction), and the tick.
  input  wire        idle_check_i,
  input  wire        idle_over_gap_i,
  input  wire [31:0] now_i,
  // The gap inside a telegram now, in clocks (what idle_over_gap_i compares with).
  output wire [23:0] gap_clocks_o,
  // The telegram's first byte (an SC does not confirm a rate).
  output logic [7:0] first_o,
  // A telegram under way as the last clock left it (the register).
  output wire        in_telegram_o,
  // Delivery::Telegram and Delivery::NotSynced of this clock, the telegram's status (0 good,
  // 1-4 a character error as char_error_i, 5 gap, 6 bad delimiter, 7 length mismatch, 8 bad
  // length, 9 bad FCS, 10 no ED), its length and end tick.
  output logic       deliver_o,
  output logic       not_synced_o,
  output logic [3:0] status_o,
  output logic [7:0] len_o,
  output logic [31:0] end_o,
  // The telegram RAM.
  output logic       wr_o,
  output logic [7:0] wr_addr_o,
  output logic [7:0] wr_data_o
);
  localparam logic [7:0] SD1 = 8'h10, SD2 = 8'h68, SD3 = 8'hA2, SD4 = 8'hDC, SC = 8'hE5,
                         ED = 8'h16;
  localparam logic [3:0] StGood = 4'd0, StGap = 4'd5, StBadDelimiter = 4'd6,
                         StLengthMismatch = 4'd7, StBadLength = 4'd8, StBadFcs = 4'd9,
                         StNoEnd = 4'd10;

  logic [23:0] tsyn_q, tsyn_d, gap_q, gap_d;
  logic        inside_q, inside_d;
  // The telegram's length by its delimiter, 0 while an SD2's is not known yet.
  logic [7:0]  expect_q, expect_d;
  logic [7:0]  len_q, len_d;
  logic [7:0]  first_q, first_d;
  logic [7:0]  le_q, le_d;
  logic [7:0]  fcs_q, fcs_d;
  logic        fcs_ok_q, fcs_ok_d;

  // The character's next place, worked out from the registers alone, so that the character
  // meets only the few levels of choice below (with the character's byte in the length checks,
  // the delimiter took 24 ns after its character: README "Gateware"). Inside a telegram at
  // least its delimiter is kept (len_q >= 1: its first byte is first_q), and the byte at
  // len_q is:
  //   in_body:  summed into the FCS (SD1 and SD3 bytes 1 .. expect-3, SD2 bytes 4 .. expect-3);
  //   at_fcs:   the FCS (expect-2);
  //   last:     the last (expect-1, the ED; never the FCS, so the FCS's check is fcs_ok_q);
  //   sd2_le, sd2_ler, sd2_sd: an SD2's LE, LEr and second SD2 (expect is 0 until LEr).
  logic       has_fcs, is_sd2, in_body, at_fcs, last, sd2_le, sd2_ler, sd2_sd;
  logic [7:0] index_fcs;
  always_comb begin
    is_sd2    = first_q == SD2;
    has_fcs   = first_q == SD1 || is_sd2 || first_q == SD3;
    index_fcs = expect_q - 8'd2;
    in_body   = has_fcs && expect_q != 8'd0 && len_q < index_fcs
                && len_q >= (is_sd2 ? 8'd4 : 8'd1);
    at_fcs    = has_fcs && expect_q != 8'd0 && len_q == index_fcs;
    last      = expect_q != 8'd0 && len_q + 8'd1 >= expect_q;
    sd2_le    = is_sd2 && len_q == 8'd1;
    sd2_ler   = is_sd2 && len_q == 8'd2;
    sd2_sd    = is_sd2 && len_q == 8'd3;
  end

  // A telegram's start: its delimiter's expected length (0: not a start delimiter).
  logic       start_known;
  logic [7:0] start_expect;
  always_comb begin
    start_known = 1'b1;
    case (char_byte_i)
      SD1:     start_expect = 8'd6;
      SD2:     start_expect = 8'd0;
      SD3:     start_expect = 8'd14;
      SD4:     start_expect = 8'd3;
      SC:      start_expect = 8'd1;
      default: begin
        start_expect = 8'd0;
        start_known  = 1'b0;
      end
    endcase
  end

  // After the character: its delivery alone (Delivery::Telegram from on_char) and its status.
  logic        char_deliver, inside_c, ends;
  logic [3:0]  char_status;
  logic [31:0] char_end;

  always_comb begin
    inside_c     = inside_q;
    expect_d     = expect_q;
    len_d        = len_q;
    first_d      = first_q;
    le_d         = le_q;
    fcs_d        = fcs_q;
    fcs_ok_d     = fcs_ok_q;
    not_synced_o = 1'b0;
    char_status  = StGood;
    wr_o         = 1'b0;
    wr_addr_o    = len_q;
    wr_data_o    = char_byte_i;
    ends         = 1'b0;
    first_o      = first_q;

    if (char_i && inside_q) begin
      if (char_idle_before_i > gap_q) begin
        ends        = 1'b1;
        char_status = StGap;
      end else if (char_error_i != 3'd0) begin
        ends        = 1'b1;
        char_status = {1'b0, char_error_i};
      end else begin
        wr_o  = 1'b1;
        len_d = len_q + 8'd1;
        if (in_body) fcs_d = fcs_q + char_byte_i;
        if (at_fcs) fcs_ok_d = char_byte_i == fcs_q;
        if (sd2_le && (char_byte_i < 8'd4 || char_byte_i > 8'd249)) begin
          ends        = 1'b1;
          char_status = StBadLength;
        end else if (sd2_le) begin
          le_d = char_byte_i;
        end else if (sd2_ler && char_byte_i != le_q) begin
          ends        = 1'b1;
          char_status = StLengthMismatch;
        end else if (sd2_ler) begin
          // LE was checked to be at most 249: LE + 6 fits.
          expect_d = le_q + 8'd6;
        end else if (sd2_sd && char_byte_i != SD2) begin
          ends        = 1'b1;
          char_status = StLengthMismatch;
        end else if (last) begin
          ends = 1'b1;
          if (has_fcs && !fcs_ok_q)        char_status = StBadFcs;
          else if (has_fcs && char_byte_i != ED) char_status = StNoEnd;
        end
      end
    end else if (char_i && char_idle_before_i < tsyn_q) begin
      not_synced_o = 1'b1;
    end else if (char_i) begin
      // A telegram's start: its delimiter is kept (a start delimiter or not).
      len_d    = '0;
      inside_c = 1'b1;
      fcs_d    = '0;
      fcs_ok_d = 1'b0;
      if (char_error_i != 3'd0) begin
        ends        = 1'b1;
        char_status = {1'b0, char_error_i};
      end else begin
        wr_o      = 1'b1;
        wr_addr_o = 8'd0;
        len_d     = 8'd1;
        if (start_known) begin
          first_d  = char_byte_i;
          first_o  = char_byte_i;
          expect_d = start_expect;
          // An SC is the whole telegram.
          ends     = char_byte_i == SC;
        end else begin
          ends        = 1'b1;
          char_status = StBadDelimiter;
        end
      end
    end

    // A character that ends the telegram delivers it, at its end tick.
    char_deliver = ends;
    char_end     = ends ? char_end_i : '0;
    if (ends) inside_c = 1'b0;
    len_o = len_d;
  end

  // on_idle, after the character: a telegram still under way (before a reset).
  logic gap, inside_after;
  always_comb begin
    gap          = idle_check_i && inside_c && idle_over_gap_i;
    inside_after = inside_c && !gap;
    deliver_o    = char_deliver || gap;
    status_o     = gap ? StGap : char_status;
    end_o        = gap ? now_i : char_end;
  end

  // Then a reset or a rate's figures.
  always_comb begin
    tsyn_d   = config_i ? tsyn_clocks_i : tsyn_q;
    gap_d    = config_i ? gap_clocks_i : gap_q;
    inside_d = inside_after && !config_i && !reset_i;
  end

  assign in_telegram_o = inside_q;
  assign gap_clocks_o  = gap_q;

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      tsyn_q   <= '0;
      gap_q    <= '0;
      inside_q <= 1'b0;
      expect_q <= '0;
      len_q    <= '0;
      first_q  <= '0;
      le_q     <= '0;
      fcs_q    <= '0;
      fcs_ok_q <= 1'b0;
    end else begin
      tsyn_q   <= tsyn_d;
      gap_q    <= gap_d;
      inside_q <= inside_d;
      expect_q <= expect_d;
      len_q    <= len_d;
      first_q  <= first_d;
      le_q     <= le_d;
      fcs_q    <= fcs_d;
      fcs_ok_q <= fcs_ok_d;
    end
  end
endmodule

`default_nettype wire
