// The line into the sample clock's domain: dp_phy::filter's twin (crates/dp-phy/src/filter.rs).
//
// One flop takes the RS-485 receiver's asynchronous output in (sync_q); the output (out_q)
// follows it only after it has held a new level for more than FilterLen clocks, which drops
// glitches of up to FilterLen clocks and delays every edge by FilterLen + 1 clocks, widths kept.
// The transceiver uses FilterLen = 0 (SYNC_FILTER_LEN: no glitch filter): a two-flop
// synchroniser, every glitch weighed where it falls, bit by bit, further on. With 0 the model's
// count stays 0, so the counter is not built.
//
// Outputs are the model's FilterOut of the same clock: the level the output takes on this
// edge, and whether it fell or rose on it.
`default_nettype none

module line_sync #(
  parameter int FilterLen = 0
) (
  input  wire clk_i,
  input  wire rst_ni,
  input  wire line_i,
  output wire level_o,
  output wire fell_o,
  output wire rose_o
);
  // FILTER_RESET: the line idles high.
  logic sync_q;
  logic out_q, out_d;

  generate
    if (FilterLen == 0) begin : g_sync_only
      assign out_d = sync_q;
    end else begin : g_filter
      // The counter holds FilterLen (the model's u16 holds up to 65534).
      localparam int CountW = $clog2(FilterLen + 1);
      localparam logic [CountW-1:0] Len = FilterLen[CountW-1:0];
      logic [CountW-1:0] count_q, count_d;
      logic              filtered_d;

      always_comb begin
        count_d    = count_q;
        filtered_d = out_q;
        if (sync_q == out_q) begin
          count_d = '0;
        end else if (count_q >= Len) begin
          filtered_d = sync_q;
          count_d    = '0;
        end else begin
          count_d = count_q + 1'b1;
        end
      end

      always_ff @(posedge clk_i or negedge rst_ni) begin
        if (!rst_ni) count_q <= '0;
        else         count_q <= count_d;
      end
      assign out_d = filtered_d;
    end
  endgenerate

  always_ff @(posedge clk_i or negedge rst_ni) begin
    if (!rst_ni) begin
      sync_q <= 1'b1;
      out_q  <= 1'b1;
    end else begin
      sync_q <= line_i;
      out_q  <= out_d;
    end
  end

  assign level_o = out_d;
  assign fell_o  = out_q && !out_d;
  assign rose_o  = !out_q && out_d;
endmodule

`default_nettype wire
