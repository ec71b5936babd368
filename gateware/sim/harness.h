// What every block's Verilator harness shares: the stimulus it reads and the outputs it writes,
// both files of little-endian records. The Rust side (crates/rtl-check) writes the stimulus,
// runs the Rust model on the same, and judges: the harness only clocks the RTL.
//
// Outputs are run-length coded: a record (u8 outputs, u32 clocks) for each run of clocks whose
// outputs are the same, so a character at 9.6 kbit/s (55,000 clocks) is a handful of records.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace harness {

// The block's reset, asynchronous: a falling rst_ni, then its release (the first eval with
// rst_ni low is no edge).
template <class Top>
void reset(Top& top) {
  top.rst_ni = 1;
  top.eval();
  top.rst_ni = 0;
  top.eval();
  top.rst_ni = 1;
  top.eval();
}

// `bytes` little-endian bytes of `x` onto an event's payload.
inline void put(std::vector<uint8_t>& v, uint32_t x, int bytes) {
  for (int i = 0; i < bytes; i++) v.push_back((x >> (8 * i)) & 0xFF);
}

inline void fail(const char* what) {
  std::fprintf(stderr, "harness: %s\n", what);
  std::exit(2);
}

class Stimulus {
 public:
  explicit Stimulus(const char* path) : f_(std::fopen(path, "rb")) {
    if (!f_) fail("cannot open the stimulus");
  }
  ~Stimulus() { std::fclose(f_); }
  // The next record's op, or -1 at the end.
  int op() { return std::fgetc(f_); }
  uint8_t u8() {
    int c = std::fgetc(f_);
    if (c < 0) fail("stimulus ends inside a record");
    return static_cast<uint8_t>(c);
  }
  uint32_t u32() {
    uint32_t v = 0;
    for (int i = 0; i < 4; i++) v |= static_cast<uint32_t>(u8()) << (8 * i);
    return v;
  }

 private:
  std::FILE* f_;
};

class Outputs {
 public:
  explicit Outputs(const char* path) : f_(std::fopen(path, "wb")) {
    if (!f_) fail("cannot open the outputs");
  }
  ~Outputs() {
    flush();
    std::fclose(f_);
  }
  // This clock's outputs.
  void clock(uint8_t value) {
    if (count_ > 0 && value == value_) {
      count_++;
      return;
    }
    flush();
    value_ = value;
    count_ = 1;
  }

 private:
  void flush() {
    if (count_ == 0) return;
    std::fputc(value_, f_);
    for (int i = 0; i < 4; i++) std::fputc((count_ >> (8 * i)) & 0xFF, f_);
    count_ = 0;
  }
  std::FILE* f_;
  uint8_t value_ = 0;
  uint32_t count_ = 0;
};

// A rate's sample ticks as the top's strobe will give them: every `period` clocks, the first
// `wait` clocks from the next one (a stimulus's 'T' record sets both).
class Samples {
 public:
  void set(uint32_t period, uint32_t wait) {
    if (period == 0 || wait >= period) fail("a sample period of none");
    period_ = period;
    wait_ = wait;
  }
  // Whether this clock is a sample tick; then on to the next clock.
  bool clock() {
    bool sample = wait_ == 0;
    wait_ = sample ? period_ - 1 : wait_ - 1;
    return sample;
  }

 private:
  uint32_t period_ = 1;
  uint32_t wait_ = 0;
};

// What a block delivers beside its per-clock outputs (a telegram with its bytes, say): records
// of u32 clock, u16 payload length, payload, compared one by one by the Rust side.
class Events {
 public:
  explicit Events(const char* path) : f_(std::fopen(path, "wb")) {
    if (!f_) fail("cannot open the events");
  }
  ~Events() { std::fclose(f_); }
  void record(uint32_t clock, const std::vector<uint8_t>& payload) {
    put32(clock);
    std::fputc(payload.size() & 0xFF, f_);
    std::fputc((payload.size() >> 8) & 0xFF, f_);
    std::fwrite(payload.data(), 1, payload.size(), f_);
  }

 private:
  void put32(uint32_t v) {
    for (int i = 0; i < 4; i++) std::fputc((v >> (8 * i)) & 0xFF, f_);
  }
  std::FILE* f_;
};

}  // namespace harness
