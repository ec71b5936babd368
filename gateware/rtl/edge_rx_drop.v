// A lane's false starts dropped: dp_phy::edge_rx::EdgeRx::drop_false_starts's twin, without
// the deadline (the caller works it out from the kept starts and its stage).
//
// A candidate is kept while its start bit is under way (its reader's bit 0 not decided yet) or
// when its reader decided that start bit low (start_low). The kept ones move to the front, in
// order; a slot left behind keeps its old registers, as the model's array does.
`default_nettype none

module edge_rx_drop #(
  parameter int ReaderWidth = 73,
  parameter int TickWidth   = 32
) (
  input  wire  [1:0]               n_i,
  input  wire  [2*TickWidth-1:0]   starts_i,
  input  wire  [2*ReaderWidth-1:0] readers_i,
  input  wire  [1:0]               start_low_i,
  output logic [1:0]               n_o,
  output logic [2*TickWidth-1:0]   starts_o,
  output logic [2*ReaderWidth-1:0] readers_o,
  output logic [1:0]               start_low_o
);
  logic [1:0] keep;

  always_comb begin
    for (int s = 0; s < 2; s++) begin
      // A reader's bit count is the top four bits of its packed state.
      keep[s] = 2'(s) < n_i
          && (readers_i[s*ReaderWidth + ReaderWidth - 4 +: 4] == 4'd0 || start_low_i[s]);
    end
    n_o         = 2'(keep[0]) + 2'(keep[1]);
    starts_o    = starts_i;
    readers_o   = readers_i;
    start_low_o = start_low_i;
    if (!keep[0] && keep[1]) begin
      starts_o[0 +: TickWidth]      = starts_i[TickWidth +: TickWidth];
      readers_o[0 +: ReaderWidth]   = readers_i[ReaderWidth +: ReaderWidth];
      start_low_o[0]                = start_low_i[1];
    end
  end
endmodule
