// Counters for /metrics (Prometheus text format 0.0.4) and the JSON-lines event log (stderr).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>

#include "server/protocol.h"

namespace vismap::server {

class Metrics {
 public:
  std::atomic<int64_t> sessions_active{0};
  std::atomic<uint64_t> sessions_total{0}, sessions_refused{0};
  std::atomic<uint64_t> frames{0}, frames_skipped{0}, bytes_sent{0}, bytes_received{0};
  std::atomic<uint64_t> scenes_loaded{0}, http_requests{0};

  void error(const std::string& code);
  void render_ms(double ms);  // pipeline + encode time of one frame
  void encode_ms(Format f, double ms);  // the encoder's time of one frame
  void frame_sent(Format f, uint64_t payload_bytes);
  std::string prometheus() const;

 private:
  static constexpr std::array<double, 10> kBuckets{1, 2, 5, 10, 20, 50, 100, 200, 500, 1000};
  struct Histogram {
    std::array<uint64_t, kBuckets.size()> buckets{};
    uint64_t count = 0;
    double sum_ms = 0;
    void add(double ms);
  };
  mutable std::mutex mu_;
  std::map<std::string, uint64_t> errors_;
  Histogram render_;
  std::array<Histogram, kFormats.size()> encode_;
  std::array<uint64_t, kFormats.size()> format_frames_{}, format_bytes_{};
};

// One JSON object per line on stderr: {"ts":..., "level":..., "event":..., ...fields}.
class Log {
 public:
  enum Level { Info = 0, Warn = 1, Off = 2 };
  void set_level(const std::string& name);
  void info(const std::string& event, nlohmann::json fields = nlohmann::json::object()) {
    write(Info, event, std::move(fields));
  }
  void warn(const std::string& event, nlohmann::json fields = nlohmann::json::object()) {
    write(Warn, event, std::move(fields));
  }

 private:
  void write(Level l, const std::string& event, nlohmann::json fields);
  std::atomic<int> level_{Info};
  std::mutex mu_;
};

}  // namespace vismap::server
