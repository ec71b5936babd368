// A measurement wrapper, not part of the design: edge_rx on the part with a handful of pins,
// so nextpnr can place it alone and report its clock rate until the transceiver's top module
// exists (`cargo xtask gateware` builds it). The rate's figures shift in from one pin, the
// tick counts up, every output is registered and the registers are folded into one pin: the
// paths measured are edge_rx's own, register to register.
`default_nettype none

module edge_rx_fit (
  input  wire clk_i,
  input  wire rst_ni,
  input  wire figures_i,
  input  wire step_i,
  input  wire level_i,
  input  wire edge_i,
  input  wire hand_over_i,
  input  wire clear_i,
  output wire fold_o
);
  localparam int PW = 7;
  localparam int FiguresWidth = 7 * PW + (PW + 1) + 3 * 16 + 24 + 24 + 1;
  logic [FiguresWidth-1:0] figures_q;
  logic [31:0]             now_q;
  always_ff @(posedge clk_i) begin
    figures_q <= {figures_q[FiguresWidth-2:0], figures_i};
    now_q     <= now_q + 32'd1;
  end

  logic        char_, active, next_active, next_from_valid;
  logic [7:0]  byte_;
  logic [2:0]  error;
  logic [31:0] start, end_;
  logic [23:0] idle_before;
  logic [17:0] deadline, next_from;
  logic [1:0]  stage;
  localparam int Offsets = 8 * PW + 1;
  edge_rx #(.PhaseWidth(PW)) u_edge_rx (
    .clk_i, .rst_ni, .now_i(now_q),
    .inc_i(figures_q[0 +: PW]), .modulo_i(figures_q[PW +: PW]),
    .quarter_i(figures_q[2*PW +: PW]), .three_quarters_i(figures_q[3*PW +: PW]),
    .half_less_inc_i(figures_q[4*PW +: PW]), .modulo_less_inc_i(figures_q[5*PW +: PW]),
    .modulo_less_two_inc_i(figures_q[6*PW +: PW]), .two_inc_i(figures_q[7*PW +: PW + 1]),
    .start_end_i(figures_q[Offsets +: 16]), .stop_middle_i(figures_q[Offsets + 16 +: 16]),
    .stop_end_i(figures_q[Offsets + 32 +: 16]), .step_i, .level_i, .edge_i,
    .idle_before_i(figures_q[Offsets + 48 +: 24]), .hand_over_i,
    .hand_over_idle_i(figures_q[Offsets + 72 +: 24]),
    .hand_over_fell_i(edge_i && !level_i), .hand_over_fell_last_i(figures_q[Offsets + 96]),
    .hand_over_step_i(step_i), .hand_over_level_i(level_i), .hand_over_edge_i(edge_i),
    .hand_over_inc_i(figures_q[0 +: PW]), .hand_over_two_inc_i(figures_q[7*PW +: PW + 1]),
    .hand_over_quarter_i(figures_q[2*PW +: PW]),
    .hand_over_three_quarters_i(figures_q[3*PW +: PW]),
    .hand_over_half_less_inc_i(figures_q[4*PW +: PW]),
    .hand_over_modulo_i(figures_q[PW +: PW]),
    .hand_over_modulo_less_inc_i(figures_q[5*PW +: PW]),
    .hand_over_modulo_less_two_inc_i(figures_q[6*PW +: PW]),
    .hand_over_start_end_i(figures_q[Offsets +: 16]),
    .clear_i,
    .char_o(char_), .char_byte_o(byte_), .char_error_o(error), .char_start_o(start),
    .char_end_o(end_), .char_idle_before_o(idle_before), .active_o(active),
    .deadline_o(deadline), .stage_o(stage),
    .next_active_o(next_active), .next_from_valid_o(next_from_valid), .next_from_o(next_from)
  );

  localparam int OutWidth = 1 + 8 + 3 + 32 + 32 + 24 + 1 + 18 + 2 + 1 + 1 + 18;
  logic [OutWidth-1:0] out_q;
  logic                fold_q;
  always_ff @(posedge clk_i) begin
    out_q  <= {char_, byte_, error, start, end_, idle_before, active, deadline, stage, next_active,
               next_from_valid, next_from};
    fold_q <= ^out_q;
  end
  assign fold_o = fold_q;
endmodule
