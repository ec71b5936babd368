// A measurement wrapper, not part of the design: the transceiver's two largest blocks on the
// part together, the search (autobaud, the transceiver's build) and the receiver (in
// edge_rx_fit.v's wrapper), so nextpnr reports what sharing the fabric does to their cells and
// clock rate until the top module exists (`cargo xtask gateware` builds it). The search's
// outputs are registered and folded into one pin, as the receiver's are.
`default_nettype none

module search_and_receiver_fit (
  input  wire clk_i,
  input  wire rst_ni,
  input  wire figures_i,
  input  wire step_i,
  input  wire level_i,
  input  wire edge_i,
  input  wire hand_over_i,
  input  wire clear_i,
  input  wire heard_valid_i,
  input  wire [3:0] heard_i,
  output wire receiver_fold_o,
  output wire search_fold_o
);
  edge_rx_fit u_receiver (
    .clk_i, .rst_ni, .figures_i, .step_i, .level_i, .edge_i, .hand_over_i, .clear_i,
    .fold_o(receiver_fold_o)
  );

  logic        valid, detect;
  logic [3:0]  rate;
  logic [7:0]  byte_;
  logic [1:0]  reject_code;
  logic [23:0] start_clocks;
  logic [9:0]  measuring, samples;
  logic [11:0] pending_left;
  autobaud #(.Oversampled(1)) u_search (
    .clk_i, .rst_ni, .level_i, .heard_valid_i, .heard_i, .valid_o(valid), .detect_o(detect),
    .rate_o(rate), .byte_o(byte_), .reject_code_o(reject_code), .start_clocks_o(start_clocks),
    .pending_left_o(pending_left), .samples_o(samples), .measuring_o(measuring)
  );

  logic [71:0] out_q;
  logic        fold_q;
  always_ff @(posedge clk_i) begin
    out_q  <= {valid, detect, rate, byte_, reject_code, start_clocks, pending_left, samples,
               measuring};
    fold_q <= ^out_q;
  end
  assign search_fold_o = fold_q;
endmodule
