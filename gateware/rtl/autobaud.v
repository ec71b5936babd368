// The baud-rate search: dp_phy::autobaud::AutoBaud's twin (crates/dp-phy/src/autobaud.rs),
// a channel per rate at that rate's constant figures (autobaud_channels.svh, written from the
// model by crates/rtl-check): in the transceiver's build the seven slowest take turns in
// autobaud_shared.v and the three fastest are an autobaud_channel each; and what the model's
// clock() returns.
//
// Each clock takes the synchronised line (level_i; each channel samples it and sees its changes)
// and the rate the receiver is on (heard_valid_i, heard_i: an index into Baud::ALL, 9.6k
// first). A decision falls due in a channel at the middle of its stop bit (or its end); of
// those due on one clock, the fastest rate's detection goes out, else the fastest rate's
// rejection (valid_o with detect_o low). With a rate heard, that rate's own decisions and
// every rejection go nowhere, as in the model.
`default_nettype none

module autobaud #(
  // 1: the transceiver's search, the channels up to 1.5 Mbit/s sampling the line every few
  // clocks (AutoBaud::sampled with OVERSAMPLED, the model's default); 0: every channel samples
  // every clock (AutoBaud::new, to compare).
  parameter int Oversampled = 1,
  // The detections' start age in clocks (each channel's own registers count its samples, at
  // its rate's widths: autobaud_channels.svh; each puts out its samples times its period).
  parameter int ClocksWidth = 24,
  // The detecting channel's samples within which a next edge cancels its idle line's last
  // one (9.6k's glitch at every clock: 2,499).
  parameter int PendWidth = 12
) (
  input  wire                 clk_i,
  input  wire                 rst_ni,
  input  wire                 level_i,
  input  wire                 heard_valid_i,
  input  wire [3:0]           heard_i,
  output logic                valid_o,
  output logic                detect_o,
  output logic [3:0]          rate_o,
  output logic [7:0]          byte_o,
  output logic [1:0]          reject_code_o,
  output logic [ClocksWidth-1:0] start_clocks_o,
  // With a detection: its channel's idle line's pending edge, as the samples within which a
  // next edge still cancels it (0: none); the transceiver's copy of that line goes on from it.
  output logic [PendWidth-1:0] pending_left_o,
  // With a detection: its channel's idle line rose after the character's end (the
  // transceiver's copy then counts from the decision).
  output logic                rose_after_end_o,
  // With a detection: its rate, one-hot (rate_o's index; 0 without one).
  output logic [9:0]          detect_rate_o,
  // Each channel samples the line on this clock (the receiver takes the line at its rate's).
  output wire  [9:0]          samples_o,
  output wire  [9:0]          measuring_o
);
  localparam int Rates = 10;

  // Per channel, flat (yosys 0.23 takes no packed arrays of arrays): channel r's field at
  // [r * width +: width].
  logic [Rates-1:0]           heard, detect, reject;
  logic [Rates*2-1:0]         reject_code;
  logic [Rates*8-1:0]         bytes;
  logic [Rates*ClocksWidth-1:0] start_clocks;
  logic [Rates*PendWidth-1:0] cancel_left;
  logic [Rates-1:0]           rose_after_end;

  // The rates whose channels take turns in one datapath (autobaud_shared.v): at most one of
  // them decides on a clock, and their fields are the same wires.
  localparam int SharedRates = Oversampled != 0 ? 7 : 1;

  always_comb begin
    for (int r = 0; r < Rates; r++) heard[r] = heard_valid_i && heard_i == 4'(r);
    // The fastest rate first; a detection before any rejection.
    valid_o       = 1'b0;
    detect_o      = 1'b0;
    rate_o        = '0;
    reject_code_o = '0;
    for (int r = 0; r < Rates; r++) begin
      if (reject[r]) begin
        valid_o       = 1'b1;
        rate_o        = 4'(r);
        reject_code_o = reject_code[r*2 +: 2];
      end
    end
    for (int r = 0; r < Rates; r++) begin
      if (detect[r]) begin
        valid_o       = 1'b1;
        detect_o      = 1'b1;
        rate_o        = 4'(r);
        reject_code_o = '0;
      end
    end
    // A detection's fields, read only with detect_o (the transceiver registers them every
    // clock, and acts on them a clock later only if a detection came): the channels of their
    // own over the shared datapath's, chosen by their detections alone, not by the rate above
    // (a priority encoder and then a multiplexer by its index, late in the clock).
    byte_o           = bytes[(SharedRates-1)*8 +: 8];
    start_clocks_o   = start_clocks[(SharedRates-1)*ClocksWidth +: ClocksWidth];
    pending_left_o   = cancel_left[(SharedRates-1)*PendWidth +: PendWidth];
    rose_after_end_o = rose_after_end[SharedRates-1];
    for (int r = SharedRates; r < Rates; r++) begin
      if (detect[r]) begin
        byte_o           = bytes[r*8 +: 8];
        start_clocks_o   = start_clocks[r*ClocksWidth +: ClocksWidth];
        pending_left_o   = cancel_left[r*PendWidth +: PendWidth];
        rose_after_end_o = rose_after_end[r];
      end
    end
    // The same choice, one-hot: the rate whose detection goes out.
    detect_rate_o = '0;
    for (int r = 0; r < Rates; r++) begin
      if (detect[r]) detect_rate_o = Rates'(1) << r;
    end
  end

`include "autobaud_channels.svh"
endmodule
