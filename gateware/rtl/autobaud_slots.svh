// Written by crates/rtl-check (`blocks::autobaud`) from
// dp_phy::autobaud::AutoBaud::channel_figures at 48 MHz, every figure in the channel's
// samples. A test holds this file equal to the model's figures; do not edit.
// autobaud_shared.v's table: the figures of the channel in turn, at its widths (P phase,
// G pending edge, I idle line, T measurement, F frames, E an idle line and a measurement
// added).
      // 9.6k: a sample every 240 clocks from tick 0
      0: begin
        inc = P'(6); modulo = P'(125); quarter = P'(31); three_quarters = P'(94);
        half_less_inc = P'(56); two_inc = (P + 1)'(12);
        modulo_less_inc = P'(119); modulo_less_two_inc = P'(113);
        glitch = G'(9); edge_reset = G'(10); tsyn = I'(678); tsyn_less_one = I'(677);
        to_middle = T'(218); middle_to_end = T'(10); start_bit = T'(21);
        frames_less_one = F'(39); tsyn_past_end = E'(907);
      end
      // 19.2k: a sample every 120 clocks from tick 1
      1: begin
        inc = P'(6); modulo = P'(125); quarter = P'(31); three_quarters = P'(94);
        half_less_inc = P'(56); two_inc = (P + 1)'(12);
        modulo_less_inc = P'(119); modulo_less_two_inc = P'(113);
        glitch = G'(9); edge_reset = G'(9); tsyn = I'(678); tsyn_less_one = I'(677);
        to_middle = T'(218); middle_to_end = T'(10); start_bit = T'(21);
        frames_less_one = F'(19); tsyn_past_end = E'(907);
      end
      // 45.45k: a sample every 66 clocks from tick 2
      2: begin
        inc = P'(1); modulo = P'(16); quarter = P'(4); three_quarters = P'(12);
        half_less_inc = P'(7); two_inc = (P + 1)'(2);
        modulo_less_inc = P'(15); modulo_less_two_inc = P'(14);
        glitch = G'(7); edge_reset = G'(7); tsyn = I'(520); tsyn_less_one = I'(519);
        to_middle = T'(167); middle_to_end = T'(7); start_bit = T'(16);
        frames_less_one = F'(10); tsyn_past_end = E'(695);
      end
      // 93.75k: a sample every 24 clocks from tick 3
      3: begin
        inc = P'(3); modulo = P'(64); quarter = P'(16); three_quarters = P'(48);
        half_less_inc = P'(29); two_inc = (P + 1)'(6);
        modulo_less_inc = P'(61); modulo_less_two_inc = P'(58);
        glitch = G'(9); edge_reset = G'(9); tsyn = I'(694); tsyn_less_one = I'(693);
        to_middle = T'(223); middle_to_end = T'(10); start_bit = T'(22);
        frames_less_one = F'(3); tsyn_past_end = E'(928);
      end
      // 187.5k: a sample every 12 clocks from tick 4
      4: begin
        inc = P'(3); modulo = P'(64); quarter = P'(16); three_quarters = P'(48);
        half_less_inc = P'(29); two_inc = (P + 1)'(6);
        modulo_less_inc = P'(61); modulo_less_two_inc = P'(58);
        glitch = G'(9); edge_reset = G'(9); tsyn = I'(694); tsyn_less_one = I'(693);
        to_middle = T'(223); middle_to_end = T'(10); start_bit = T'(22);
        frames_less_one = F'(1); tsyn_past_end = E'(928);
      end
      // 500k: a sample every 6 clocks from tick 5
      5: begin
        inc = P'(1); modulo = P'(16); quarter = P'(4); three_quarters = P'(12);
        half_less_inc = P'(7); two_inc = (P + 1)'(2);
        modulo_less_inc = P'(15); modulo_less_two_inc = P'(14);
        glitch = G'(7); edge_reset = G'(7); tsyn = I'(520); tsyn_less_one = I'(519);
        to_middle = T'(167); middle_to_end = T'(7); start_bit = T'(16);
        frames_less_one = F'(0); tsyn_past_end = E'(695);
      end
