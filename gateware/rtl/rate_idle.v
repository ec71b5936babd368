// The transceiver's copy of its rate's idle line: dp_phy::rate_idle::RateIdle's twin
// (crates/dp-phy/src/rate_idle.rs), the line at the receiver's rate as the idle time, the gap
// and TSDR count it: high since when, the rate's glitches aside.
//
// The model keeps the pending edge as a tick and cancels with an edge within the glitch's
// clocks of it; this keeps the samples within which a next edge still cancels it
// (cancel_left_q, 0: none), counted down on the rate's samples, as autobaud_channel_step.v does
// for the search's channel: the same decisions, for edges come only on the rate's samples and a
// glitch is whole samples. Per clock, in the transceiver's order: a restore (the other copy's
// registers, taken before this clock's change: a lock taken back when its trial fails), the
// sampled line's change (edge_i, to level_i, on a sample only), and a load, which replaces what
// the change left (a detection's channel state, or the other copy after its change). *_e_o are
// the registers after the change, before the load (what the other copy takes).
`default_nettype none

module rate_idle #(
  parameter int PendWidth = 12
) (
  input  wire                 clk_i,
  input  wire                 rst_ni,
  input  wire [31:0]          now_i,
  // The rate's glitch, in its samples; its sample ticks.
  input  wire [PendWidth-1:0] glitch_i,
  input  wire                 sample_i,
  input  wire                 edge_i,
  input  wire                 level_i,
  input  wire                 restore_i,
  input  wire [PendWidth-1:0] restore_cancel_left_i,
  input  wire [31:0]          restore_high_since_i,
  input  wire [31:0]          restore_high_before_i,
  input  wire                 load_i,
  input  wire [PendWidth-1:0] load_cancel_left_i,
  input  wire [31:0]          load_high_since_i,
  input  wire [31:0]          load_high_before_i,
  output wire [PendWidth-1:0] cancel_left_o,
  output wire [31:0]          high_since_o,
  output wire [31:0]          high_before_o,
  output logic [PendWidth-1:0] cancel_left_e_o,
  output logic [31:0]          high_since_e_o,
  output logic [31:0]          high_before_e_o
);
  logic [PendWidth-1:0] cancel_left_q, cancel_left_d;
  logic [31:0]          high_since_q, high_since_d;
  logic [31:0]          high_before_q, high_before_d;
  logic                 cancels;

  // Before this clock's change.
  logic [PendWidth-1:0] cancel_left_b;
  logic [31:0]          high_since_b, high_before_b;

  always_comb begin
    cancel_left_b   = restore_i ? restore_cancel_left_i : cancel_left_q;
    high_since_b    = restore_i ? restore_high_since_i : high_since_q;
    high_before_b   = restore_i ? restore_high_before_i : high_before_q;
    cancel_left_e_o = cancel_left_b;
    high_since_e_o  = high_since_b;
    high_before_e_o = high_before_b;
    cancels         = cancel_left_b != '0;
    if (sample_i && edge_i) begin
      cancel_left_e_o = cancels ? '0 : glitch_i;
      if (level_i && !cancels) begin
        high_since_e_o  = now_i;
        high_before_e_o = high_since_b;
      end else if (!level_i && cancels) begin
        high_since_e_o  = high_before_b;
      end
    end else if (sample_i && cancels) begin
      cancel_left_e_o = cancel_left_b - 1'b1;
    end
  end

  // The load, in a block of its own: what it loads may come from these registers' change.
  always_comb begin
    cancel_left_d = load_i ? load_cancel_left_i : cancel_left_e_o;
    high_since_d  = load_i ? load_high_since_i : high_since_e_o;
    high_before_d = load_i ? load_high_before_i : high_before_e_o;
  end

  // RATE_IDLE_NONE.
  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      cancel_left_q <= '0;
      high_since_q  <= '0;
      high_before_q <= '0;
    end else begin
      cancel_left_q <= cancel_left_d;
      high_since_q  <= high_since_d;
      high_before_q <= high_before_d;
    end
  end

  assign cancel_left_o = cancel_left_q;
  assign high_since_o  = high_since_q;
  assign high_before_o = high_before_q;
endmodule
