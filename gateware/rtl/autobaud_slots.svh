// Written by crates/rtl-check (`blocks::autobaud`) from
// dp_phy::autobaud::AutoBaud::channel_figures at 48 MHz, every figure in the channel's
// samples. A test holds this file equal to the model's figures; do not edit.
// autobaud_shared.v's tables: the channel whose turn a clock of the frame is (turn_of:
// {a channel's turn, which}), and the figures of the channel in turn, at its
// widths (P phase, G pending edge, I idle line, T measurement, F frames, E an idle line
// and a measurement added, Q the sample period in clocks).
function automatic logic [C:0] turn_of(input logic [SlotWidth-1:0] slot);
  case (slot)
    0: turn_of = {1'b1, C'(6)}; // 1.5M
    1: turn_of = {1'b1, C'(5)}; // 500k
    2: turn_of = {1'b1, C'(6)}; // 1.5M
    3: turn_of = {1'b1, C'(4)}; // 187.5k
    4: turn_of = {1'b1, C'(6)}; // 1.5M
    5: turn_of = {1'b1, C'(3)}; // 93.75k
    6: turn_of = {1'b1, C'(6)}; // 1.5M
    7: turn_of = {1'b1, C'(5)}; // 500k
    8: turn_of = {1'b1, C'(6)}; // 1.5M
    9: turn_of = {1'b1, C'(2)}; // 45.45k
    10: turn_of = {1'b1, C'(6)}; // 1.5M
    11: turn_of = {1'b1, C'(1)}; // 19.2k
    12: turn_of = {1'b1, C'(6)}; // 1.5M
    13: turn_of = {1'b1, C'(5)}; // 500k
    14: turn_of = {1'b1, C'(6)}; // 1.5M
    15: turn_of = {1'b1, C'(4)}; // 187.5k
    16: turn_of = {1'b1, C'(6)}; // 1.5M
    17: turn_of = {1'b1, C'(0)}; // 9.6k
    18: turn_of = {1'b1, C'(6)}; // 1.5M
    19: turn_of = {1'b1, C'(5)}; // 500k
    20: turn_of = {1'b1, C'(6)}; // 1.5M
    21: turn_of = '0; // free
    22: turn_of = {1'b1, C'(6)}; // 1.5M
    23: turn_of = '0; // free
    default: turn_of = '0;
  endcase
endfunction

function automatic logic [G+I-1:0] idle_reset_of(input logic [C-1:0] channel);
  case (channel)
    0: idle_reset_of = {G'(9), I'(678)}; // 9.6k
    1: idle_reset_of = {G'(9), I'(678)}; // 19.2k
    2: idle_reset_of = {G'(10), I'(715)}; // 45.45k
    3: idle_reset_of = {G'(9), I'(694)}; // 93.75k
    4: idle_reset_of = {G'(9), I'(694)}; // 187.5k
    5: idle_reset_of = {G'(7), I'(520)}; // 500k
    6: idle_reset_of = {G'(8), I'(520)}; // 1.5M
    default: idle_reset_of = '0;
  endcase
endfunction

always_comb begin
  inc = '0; modulo = '0; quarter = '0; three_quarters = '0; half_less_inc = '0;
  two_inc = '0; modulo_less_inc = '0; modulo_less_two_inc = '0; glitch = '0;
  tsyn_less_one = '0; to_middle = '0; middle_to_end = '0;
  start_bit = '0; frames_less_one = '0; tsyn_past_end = '0; sample_period = '0;
  case (channel_q)
    // 9.6k: a sample every 240 clocks from tick 17
    0: begin
      inc = P'(6); modulo = P'(125); quarter = P'(31); three_quarters = P'(94);
      half_less_inc = P'(56); two_inc = (P + 1)'(12);
      modulo_less_inc = P'(119); modulo_less_two_inc = P'(113);
      glitch = G'(9); tsyn_less_one = I'(677);
      to_middle = T'(218); middle_to_end = T'(10); start_bit = T'(21);
      frames_less_one = F'(9); tsyn_past_end = E'(907); sample_period = Q'(240);
    end
    // 19.2k: a sample every 120 clocks from tick 11
    1: begin
      inc = P'(6); modulo = P'(125); quarter = P'(31); three_quarters = P'(94);
      half_less_inc = P'(56); two_inc = (P + 1)'(12);
      modulo_less_inc = P'(119); modulo_less_two_inc = P'(113);
      glitch = G'(9); tsyn_less_one = I'(677);
      to_middle = T'(218); middle_to_end = T'(10); start_bit = T'(21);
      frames_less_one = F'(4); tsyn_past_end = E'(907); sample_period = Q'(120);
    end
    // 45.45k: a sample every 48 clocks from tick 9
    2: begin
      inc = P'(1); modulo = P'(22); quarter = P'(5); three_quarters = P'(17);
      half_less_inc = P'(10); two_inc = (P + 1)'(2);
      modulo_less_inc = P'(21); modulo_less_two_inc = P'(20);
      glitch = G'(10); tsyn_less_one = I'(714);
      to_middle = T'(230); middle_to_end = T'(10); start_bit = T'(22);
      frames_less_one = F'(1); tsyn_past_end = E'(956); sample_period = Q'(48);
    end
    // 93.75k: a sample every 24 clocks from tick 5
    3: begin
      inc = P'(3); modulo = P'(64); quarter = P'(16); three_quarters = P'(48);
      half_less_inc = P'(29); two_inc = (P + 1)'(6);
      modulo_less_inc = P'(61); modulo_less_two_inc = P'(58);
      glitch = G'(9); tsyn_less_one = I'(693);
      to_middle = T'(223); middle_to_end = T'(10); start_bit = T'(22);
      frames_less_one = F'(0); tsyn_past_end = E'(928); sample_period = Q'(24);
    end
    // 187.5k: a sample every 12 clocks from tick 3
    4: begin
      inc = P'(3); modulo = P'(64); quarter = P'(16); three_quarters = P'(48);
      half_less_inc = P'(29); two_inc = (P + 1)'(6);
      modulo_less_inc = P'(61); modulo_less_two_inc = P'(58);
      glitch = G'(9); tsyn_less_one = I'(693);
      to_middle = T'(223); middle_to_end = T'(10); start_bit = T'(22);
      frames_less_one = F'(0); tsyn_past_end = E'(928); sample_period = Q'(12);
    end
    // 500k: a sample every 6 clocks from tick 1
    5: begin
      inc = P'(1); modulo = P'(16); quarter = P'(4); three_quarters = P'(12);
      half_less_inc = P'(7); two_inc = (P + 1)'(2);
      modulo_less_inc = P'(15); modulo_less_two_inc = P'(14);
      glitch = G'(7); tsyn_less_one = I'(519);
      to_middle = T'(167); middle_to_end = T'(7); start_bit = T'(16);
      frames_less_one = F'(0); tsyn_past_end = E'(695); sample_period = Q'(6);
    end
    // 1.5M: a sample every 2 clocks from tick 0
    6: begin
      inc = P'(1); modulo = P'(16); quarter = P'(4); three_quarters = P'(12);
      half_less_inc = P'(7); two_inc = (P + 1)'(2);
      modulo_less_inc = P'(15); modulo_less_two_inc = P'(14);
      glitch = G'(7); tsyn_less_one = I'(519);
      to_middle = T'(167); middle_to_end = T'(7); start_bit = T'(16);
      frames_less_one = F'(0); tsyn_past_end = E'(695); sample_period = Q'(2);
    end
    default: ;
  endcase
end
