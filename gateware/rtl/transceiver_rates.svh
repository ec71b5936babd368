// Written by crates/rtl-check (`blocks::transceiver`) from the model at 48 MHz: each
// rate's receiver (EdgeRx::sampled, its figures in samples), its search channel's sample
// period, glitch (samples) and stop bit's end (clocks), TSYN and the gap in clocks
// (Transceiver::use_rate), and the baud watchdog. A test holds this file equal to the
// model's figures; do not edit.

  // The receiver's figures, packed: inc, two_inc, modulo, quarter, three_quarters,
  // half_less_inc, modulo_less_inc, modulo_less_two_inc (PW bits each, two_inc PW + 1),
  // then start_end, stop_middle, stop_end (16 bits each), least significant first.
  localparam int RdInc = 0, RdTwoInc = PW, RdModulo = 2 * PW + 1,
    RdQuarter = 3 * PW + 1, RdThreeQuarters = 4 * PW + 1, RdHalfLessInc = 5 * PW + 1,
    RdModuloLessInc = 6 * PW + 1, RdModuloLessTwoInc = 7 * PW + 1,
    RdStartEnd = 8 * PW + 1, RdStopMiddle = 8 * PW + 17, RdStopEnd = 8 * PW + 33,
    RateReaderWidth = 8 * PW + 49;
  localparam logic [23:0] BaudWatchdogClocks = 24'd9600000;

  function automatic logic [RateReaderWidth-1:0] rate_reader(input logic [3:0] r);
    case (r)
      4'd0: rate_reader = {16'd55200, 16'd52560, 16'd5040, PW'(113), PW'(119), PW'(56), PW'(94), PW'(31), PW'(125), (PW + 1)'(12), PW'(6)}; // 9.6k
      4'd1: rate_reader = {16'd27600, 16'd26280, 16'd2520, PW'(113), PW'(119), PW'(56), PW'(94), PW'(31), PW'(125), (PW + 1)'(12), PW'(6)}; // 19.2k
      4'd2: rate_reader = {16'd11616, 16'd11088, 16'd1056, PW'(20), PW'(21), PW'(10), PW'(17), PW'(5), PW'(22), (PW + 1)'(2), PW'(1)}; // 45.45k
      4'd3: rate_reader = {16'd5640, 16'd5376, 16'd528, PW'(58), PW'(61), PW'(29), PW'(48), PW'(16), PW'(64), (PW + 1)'(6), PW'(3)}; // 93.75k
      4'd4: rate_reader = {16'd2820, 16'd2688, 16'd264, PW'(58), PW'(61), PW'(29), PW'(48), PW'(16), PW'(64), (PW + 1)'(6), PW'(3)}; // 187.5k
      4'd5: rate_reader = {16'd1056, 16'd1008, 16'd96, PW'(14), PW'(15), PW'(7), PW'(12), PW'(4), PW'(16), (PW + 1)'(2), PW'(1)}; // 500k
      4'd6: rate_reader = {16'd352, 16'd336, 16'd32, PW'(14), PW'(15), PW'(7), PW'(12), PW'(4), PW'(16), (PW + 1)'(2), PW'(1)}; // 1.5M
      4'd7: rate_reader = {16'd176, 16'd168, 16'd16, PW'(14), PW'(15), PW'(7), PW'(12), PW'(4), PW'(16), (PW + 1)'(2), PW'(1)}; // 3M
      4'd8: rate_reader = {16'd88, 16'd84, 16'd8, PW'(6), PW'(7), PW'(3), PW'(6), PW'(2), PW'(8), (PW + 1)'(2), PW'(1)}; // 6M
      4'd9: rate_reader = {16'd44, 16'd42, 16'd4, PW'(2), PW'(3), PW'(1), PW'(3), PW'(1), PW'(4), (PW + 1)'(2), PW'(1)}; // 12M
      default: rate_reader = '0;
    endcase
  endfunction

  function automatic logic [12:0] rate_bit(input logic [3:0] r);
    case (r)
      4'd0: rate_bit = 13'd5000; // 9.6k
      4'd1: rate_bit = 13'd2500; // 19.2k
      4'd2: rate_bit = 13'd1056; // 45.45k
      4'd3: rate_bit = 13'd512; // 93.75k
      4'd4: rate_bit = 13'd256; // 187.5k
      4'd5: rate_bit = 13'd96; // 500k
      4'd6: rate_bit = 13'd32; // 1.5M
      4'd7: rate_bit = 13'd16; // 3M
      4'd8: rate_bit = 13'd8; // 6M
      4'd9: rate_bit = 13'd4; // 12M
      default: rate_bit = '0;
    endcase
  endfunction

  function automatic logic [15:0] rate_stop_end(input logic [3:0] r);
    case (r)
      4'd0: rate_stop_end = 16'd55200; // 9.6k
      4'd1: rate_stop_end = 16'd27600; // 19.2k
      4'd2: rate_stop_end = 16'd11616; // 45.45k
      4'd3: rate_stop_end = 16'd5640; // 93.75k
      4'd4: rate_stop_end = 16'd2820; // 187.5k
      4'd5: rate_stop_end = 16'd1056; // 500k
      4'd6: rate_stop_end = 16'd352; // 1.5M
      4'd7: rate_stop_end = 16'd176; // 3M
      4'd8: rate_stop_end = 16'd88; // 6M
      4'd9: rate_stop_end = 16'd44; // 12M
      default: rate_stop_end = '0;
    endcase
  endfunction

  function automatic logic [PendWidth-1:0] rate_glitch(input logic [3:0] r);
    case (r)
      4'd0: rate_glitch = PendWidth'(9); // 9.6k
      4'd1: rate_glitch = PendWidth'(9); // 19.2k
      4'd2: rate_glitch = PendWidth'(10); // 45.45k
      4'd3: rate_glitch = PendWidth'(9); // 93.75k
      4'd4: rate_glitch = PendWidth'(9); // 187.5k
      4'd5: rate_glitch = PendWidth'(7); // 500k
      4'd6: rate_glitch = PendWidth'(7); // 1.5M
      4'd7: rate_glitch = PendWidth'(7); // 3M
      4'd8: rate_glitch = PendWidth'(3); // 6M
      4'd9: rate_glitch = PendWidth'(1); // 12M
      default: rate_glitch = '0;
    endcase
  endfunction

  function automatic logic [23:0] rate_tsyn(input logic [3:0] r);
    case (r)
      4'd0: rate_tsyn = 24'd162720; // 9.6k
      4'd1: rate_tsyn = 24'd81360; // 19.2k
      4'd2: rate_tsyn = 24'd34320; // 45.45k
      4'd3: rate_tsyn = 24'd16656; // 93.75k
      4'd4: rate_tsyn = 24'd8328; // 187.5k
      4'd5: rate_tsyn = 24'd3120; // 500k
      4'd6: rate_tsyn = 24'd1040; // 1.5M
      4'd7: rate_tsyn = 24'd520; // 3M
      4'd8: rate_tsyn = 24'd260; // 6M
      4'd9: rate_tsyn = 24'd130; // 12M
      default: rate_tsyn = '0;
    endcase
  endfunction

  function automatic logic [23:0] rate_gap(input logic [3:0] r);
    case (r)
      4'd0: rate_gap = 24'd5000; // 9.6k
      4'd1: rate_gap = 24'd2500; // 19.2k
      4'd2: rate_gap = 24'd1056; // 45.45k
      4'd3: rate_gap = 24'd512; // 93.75k
      4'd4: rate_gap = 24'd256; // 187.5k
      4'd5: rate_gap = 24'd96; // 500k
      4'd6: rate_gap = 24'd32; // 1.5M
      4'd7: rate_gap = 24'd16; // 3M
      4'd8: rate_gap = 24'd8; // 6M
      4'd9: rate_gap = 24'd4; // 12M
      default: rate_gap = '0;
    endcase
  endfunction
