// Written by crates/rtl-check (`blocks::autobaud`) from
// dp_phy::autobaud::AutoBaud::channel_figures at 48 MHz, every figure in the channel's
// samples. A test holds this file equal to the model's figures; do not edit.
// One channel per rate, 9.6k first.

  if (Oversampled != 0) begin : g_oversampled

    // 9.6k to 1.5M, taking turns in a frame of 24 clocks (autobaud_slots.svh)
    logic [1:0] shared_code;
    logic [7:0] shared_byte;
    logic [ClocksWidth-1:0] shared_clocks;
    logic [PendWidth-1:0] shared_cancel;
    logic shared_rose;
    autobaud_shared #(
      .Slots(24), .Channels(7), .PhaseWidth(7), .IdleWidth(10),
      .PendWidth(4), .TimeWidth(9), .AltWidth(5), .FrameWidth(4),
      .PeriodWidth(8), .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_shared (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[6:0]), .heard_any_i(heard_valid_i), .detect_o(detect[6:0]),
      .reject_o(reject[6:0]), .reject_code_o(shared_code), .byte_o(shared_byte),
      .start_clocks_o(shared_clocks), .cancel_left_o(shared_cancel),
      .rose_after_end_o(shared_rose),
      .samples_o(samples_o[6:0]), .measuring_o(measuring_o[6:0])
    );
    for (genvar r = 0; r < 7; r++) begin : g_shared
      assign reject_code[r * 2 +: 2] = shared_code;
      assign bytes[r * 8 +: 8] = shared_byte;
      assign start_clocks[r * ClocksWidth +: ClocksWidth] = shared_clocks;
      assign cancel_left[r * PendWidth +: PendWidth] = shared_cancel;
      assign rose_after_end[r] = shared_rose;
    end


    // 3M, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(5), .Inc(1), .Modulo(16), .Quarter(4), .ThreeQuarters(12),
      .HalfLessInc(7), .TwoInc(2), .ModuloLessInc(15), .ModuloLessTwoInc(14),
      .Glitch(7), .Tsyn(520), .StopMiddle(168), .StopEnd(176),
      .StartBitClocks(16), .Period(1), .Phase(0),
      .IdleWidth(10), .PendWidth(4), .TimeWidth(8), .AltWidth(5),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_7 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[7]), .heard_any_i(heard_valid_i), .detect_o(detect[7]),
      .reject_o(reject[7]), .reject_code_o(reject_code[7 * 2 +: 2]),
      .byte_o(bytes[7 * 8 +: 8]),
      .start_clocks_o(start_clocks[7 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[7 * PendWidth +: PendWidth]), .sample_o(samples_o[7]),
      .rose_after_end_o(rose_after_end[7]), .measuring_o(measuring_o[7])
    );

    // 6M, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(4), .Inc(1), .Modulo(8), .Quarter(2), .ThreeQuarters(6),
      .HalfLessInc(3), .TwoInc(2), .ModuloLessInc(7), .ModuloLessTwoInc(6),
      .Glitch(3), .Tsyn(260), .StopMiddle(84), .StopEnd(88),
      .StartBitClocks(8), .Period(1), .Phase(0),
      .IdleWidth(9), .PendWidth(3), .TimeWidth(7), .AltWidth(4),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_8 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[8]), .heard_any_i(heard_valid_i), .detect_o(detect[8]),
      .reject_o(reject[8]), .reject_code_o(reject_code[8 * 2 +: 2]),
      .byte_o(bytes[8 * 8 +: 8]),
      .start_clocks_o(start_clocks[8 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[8 * PendWidth +: PendWidth]), .sample_o(samples_o[8]),
      .rose_after_end_o(rose_after_end[8]), .measuring_o(measuring_o[8])
    );

    // 12M, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(3), .Inc(1), .Modulo(4), .Quarter(1), .ThreeQuarters(3),
      .HalfLessInc(1), .TwoInc(2), .ModuloLessInc(3), .ModuloLessTwoInc(2),
      .Glitch(1), .Tsyn(130), .StopMiddle(42), .StopEnd(44),
      .StartBitClocks(4), .Period(1), .Phase(0),
      .IdleWidth(8), .PendWidth(2), .TimeWidth(6), .AltWidth(3),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_9 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[9]), .heard_any_i(heard_valid_i), .detect_o(detect[9]),
      .reject_o(reject[9]), .reject_code_o(reject_code[9 * 2 +: 2]),
      .byte_o(bytes[9 * 8 +: 8]),
      .start_clocks_o(start_clocks[9 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[9 * PendWidth +: PendWidth]), .sample_o(samples_o[9]),
      .rose_after_end_o(rose_after_end[9]), .measuring_o(measuring_o[9])
    );
  end

  else begin : g_every_clock

    // 9.6k, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(13), .Inc(1), .Modulo(5000), .Quarter(1250), .ThreeQuarters(3750),
      .HalfLessInc(2499), .TwoInc(2), .ModuloLessInc(4999), .ModuloLessTwoInc(4998),
      .Glitch(2499), .Tsyn(162500), .StopMiddle(52500), .StopEnd(55000),
      .StartBitClocks(5000), .Period(1), .Phase(0),
      .IdleWidth(18), .PendWidth(12), .TimeWidth(16), .AltWidth(13),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_0 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[0]), .heard_any_i(heard_valid_i), .detect_o(detect[0]),
      .reject_o(reject[0]), .reject_code_o(reject_code[0 * 2 +: 2]),
      .byte_o(bytes[0 * 8 +: 8]),
      .start_clocks_o(start_clocks[0 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[0 * PendWidth +: PendWidth]), .sample_o(samples_o[0]),
      .rose_after_end_o(rose_after_end[0]), .measuring_o(measuring_o[0])
    );

    // 19.2k, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(12), .Inc(1), .Modulo(2500), .Quarter(625), .ThreeQuarters(1875),
      .HalfLessInc(1249), .TwoInc(2), .ModuloLessInc(2499), .ModuloLessTwoInc(2498),
      .Glitch(1249), .Tsyn(81250), .StopMiddle(26250), .StopEnd(27500),
      .StartBitClocks(2500), .Period(1), .Phase(0),
      .IdleWidth(17), .PendWidth(11), .TimeWidth(15), .AltWidth(12),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_1 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[1]), .heard_any_i(heard_valid_i), .detect_o(detect[1]),
      .reject_o(reject[1]), .reject_code_o(reject_code[1 * 2 +: 2]),
      .byte_o(bytes[1 * 8 +: 8]),
      .start_clocks_o(start_clocks[1 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[1 * PendWidth +: PendWidth]), .sample_o(samples_o[1]),
      .rose_after_end_o(rose_after_end[1]), .measuring_o(measuring_o[1])
    );

    // 45.45k, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(19), .Inc(303), .Modulo(320000), .Quarter(80000), .ThreeQuarters(240000),
      .HalfLessInc(159697), .TwoInc(606), .ModuloLessInc(319697), .ModuloLessTwoInc(319394),
      .Glitch(527), .Tsyn(34324), .StopMiddle(11090), .StopEnd(11618),
      .StartBitClocks(1057), .Period(1), .Phase(0),
      .IdleWidth(16), .PendWidth(10), .TimeWidth(14), .AltWidth(11),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_2 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[2]), .heard_any_i(heard_valid_i), .detect_o(detect[2]),
      .reject_o(reject[2]), .reject_code_o(reject_code[2 * 2 +: 2]),
      .byte_o(bytes[2 * 8 +: 8]),
      .start_clocks_o(start_clocks[2 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[2 * PendWidth +: PendWidth]), .sample_o(samples_o[2]),
      .rose_after_end_o(rose_after_end[2]), .measuring_o(measuring_o[2])
    );

    // 93.75k, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(10), .Inc(1), .Modulo(512), .Quarter(128), .ThreeQuarters(384),
      .HalfLessInc(255), .TwoInc(2), .ModuloLessInc(511), .ModuloLessTwoInc(510),
      .Glitch(255), .Tsyn(16640), .StopMiddle(5376), .StopEnd(5632),
      .StartBitClocks(512), .Period(1), .Phase(0),
      .IdleWidth(15), .PendWidth(9), .TimeWidth(13), .AltWidth(10),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_3 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[3]), .heard_any_i(heard_valid_i), .detect_o(detect[3]),
      .reject_o(reject[3]), .reject_code_o(reject_code[3 * 2 +: 2]),
      .byte_o(bytes[3 * 8 +: 8]),
      .start_clocks_o(start_clocks[3 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[3 * PendWidth +: PendWidth]), .sample_o(samples_o[3]),
      .rose_after_end_o(rose_after_end[3]), .measuring_o(measuring_o[3])
    );

    // 187.5k, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(9), .Inc(1), .Modulo(256), .Quarter(64), .ThreeQuarters(192),
      .HalfLessInc(127), .TwoInc(2), .ModuloLessInc(255), .ModuloLessTwoInc(254),
      .Glitch(127), .Tsyn(8320), .StopMiddle(2688), .StopEnd(2816),
      .StartBitClocks(256), .Period(1), .Phase(0),
      .IdleWidth(14), .PendWidth(8), .TimeWidth(12), .AltWidth(9),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_4 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[4]), .heard_any_i(heard_valid_i), .detect_o(detect[4]),
      .reject_o(reject[4]), .reject_code_o(reject_code[4 * 2 +: 2]),
      .byte_o(bytes[4 * 8 +: 8]),
      .start_clocks_o(start_clocks[4 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[4 * PendWidth +: PendWidth]), .sample_o(samples_o[4]),
      .rose_after_end_o(rose_after_end[4]), .measuring_o(measuring_o[4])
    );

    // 500k, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(7), .Inc(1), .Modulo(96), .Quarter(24), .ThreeQuarters(72),
      .HalfLessInc(47), .TwoInc(2), .ModuloLessInc(95), .ModuloLessTwoInc(94),
      .Glitch(47), .Tsyn(3120), .StopMiddle(1008), .StopEnd(1056),
      .StartBitClocks(96), .Period(1), .Phase(0),
      .IdleWidth(12), .PendWidth(6), .TimeWidth(11), .AltWidth(7),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_5 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[5]), .heard_any_i(heard_valid_i), .detect_o(detect[5]),
      .reject_o(reject[5]), .reject_code_o(reject_code[5 * 2 +: 2]),
      .byte_o(bytes[5 * 8 +: 8]),
      .start_clocks_o(start_clocks[5 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[5 * PendWidth +: PendWidth]), .sample_o(samples_o[5]),
      .rose_after_end_o(rose_after_end[5]), .measuring_o(measuring_o[5])
    );

    // 1.5M, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(6), .Inc(1), .Modulo(32), .Quarter(8), .ThreeQuarters(24),
      .HalfLessInc(15), .TwoInc(2), .ModuloLessInc(31), .ModuloLessTwoInc(30),
      .Glitch(15), .Tsyn(1040), .StopMiddle(336), .StopEnd(352),
      .StartBitClocks(32), .Period(1), .Phase(0),
      .IdleWidth(11), .PendWidth(5), .TimeWidth(9), .AltWidth(6),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_6 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[6]), .heard_any_i(heard_valid_i), .detect_o(detect[6]),
      .reject_o(reject[6]), .reject_code_o(reject_code[6 * 2 +: 2]),
      .byte_o(bytes[6 * 8 +: 8]),
      .start_clocks_o(start_clocks[6 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[6 * PendWidth +: PendWidth]), .sample_o(samples_o[6]),
      .rose_after_end_o(rose_after_end[6]), .measuring_o(measuring_o[6])
    );

    // 3M, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(5), .Inc(1), .Modulo(16), .Quarter(4), .ThreeQuarters(12),
      .HalfLessInc(7), .TwoInc(2), .ModuloLessInc(15), .ModuloLessTwoInc(14),
      .Glitch(7), .Tsyn(520), .StopMiddle(168), .StopEnd(176),
      .StartBitClocks(16), .Period(1), .Phase(0),
      .IdleWidth(10), .PendWidth(4), .TimeWidth(8), .AltWidth(5),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_7 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[7]), .heard_any_i(heard_valid_i), .detect_o(detect[7]),
      .reject_o(reject[7]), .reject_code_o(reject_code[7 * 2 +: 2]),
      .byte_o(bytes[7 * 8 +: 8]),
      .start_clocks_o(start_clocks[7 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[7 * PendWidth +: PendWidth]), .sample_o(samples_o[7]),
      .rose_after_end_o(rose_after_end[7]), .measuring_o(measuring_o[7])
    );

    // 6M, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(4), .Inc(1), .Modulo(8), .Quarter(2), .ThreeQuarters(6),
      .HalfLessInc(3), .TwoInc(2), .ModuloLessInc(7), .ModuloLessTwoInc(6),
      .Glitch(3), .Tsyn(260), .StopMiddle(84), .StopEnd(88),
      .StartBitClocks(8), .Period(1), .Phase(0),
      .IdleWidth(9), .PendWidth(3), .TimeWidth(7), .AltWidth(4),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_8 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[8]), .heard_any_i(heard_valid_i), .detect_o(detect[8]),
      .reject_o(reject[8]), .reject_code_o(reject_code[8 * 2 +: 2]),
      .byte_o(bytes[8 * 8 +: 8]),
      .start_clocks_o(start_clocks[8 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[8 * PendWidth +: PendWidth]), .sample_o(samples_o[8]),
      .rose_after_end_o(rose_after_end[8]), .measuring_o(measuring_o[8])
    );

    // 12M, a sample every 1 clock(s) from tick 0
    autobaud_channel #(
      .PhaseWidth(3), .Inc(1), .Modulo(4), .Quarter(1), .ThreeQuarters(3),
      .HalfLessInc(1), .TwoInc(2), .ModuloLessInc(3), .ModuloLessTwoInc(2),
      .Glitch(1), .Tsyn(130), .StopMiddle(42), .StopEnd(44),
      .StartBitClocks(4), .Period(1), .Phase(0),
      .IdleWidth(8), .PendWidth(2), .TimeWidth(6), .AltWidth(3),
      .ClocksWidth(ClocksWidth), .PendOutWidth(PendWidth)
    ) u_channel_9 (
      .clk_i, .rst_ni, .level_i,
      .heard_i(heard[9]), .heard_any_i(heard_valid_i), .detect_o(detect[9]),
      .reject_o(reject[9]), .reject_code_o(reject_code[9 * 2 +: 2]),
      .byte_o(bytes[9 * 8 +: 8]),
      .start_clocks_o(start_clocks[9 * ClocksWidth +: ClocksWidth]),
      .cancel_left_o(cancel_left[9 * PendWidth +: PendWidth]), .sample_o(samples_o[9]),
      .rose_after_end_o(rose_after_end[9]), .measuring_o(measuring_o[9])
    );
  end
