#include "server/metrics.h"

#include <chrono>
#include <cstdio>
#include <sstream>

namespace vismap::server {

void Metrics::error(const std::string& code) {
  std::lock_guard lk(mu_);
  ++errors_[code];
}

void Metrics::render_ms(double ms) {
  std::lock_guard lk(mu_);
  for (size_t i = 0; i < kBuckets.size(); ++i)
    if (ms <= kBuckets[i]) ++buckets_[i];
  ++render_count_;
  render_sum_ms_ += ms;
}

std::string Metrics::prometheus() const {
  std::ostringstream o;
  auto metric = [&](const char* name, const char* type, const char* help, auto value) {
    o << "# HELP " << name << ' ' << help << "\n# TYPE " << name << ' ' << type << '\n'
      << name << ' ' << value << '\n';
  };
  metric("vismap_sessions_active", "gauge", "Open WebSocket sessions.", sessions_active.load());
  metric("vismap_sessions_total", "counter", "Sessions accepted.", sessions_total.load());
  metric("vismap_sessions_refused_total", "counter",
         "Sessions refused (busy, unauthorized, stopping).", sessions_refused.load());
  metric("vismap_frames_total", "counter", "Frames sent.", frames.load());
  metric("vismap_frames_skipped_total", "counter",
         "Camera updates replaced by a newer one before rendering (latest camera wins).",
         frames_skipped.load());
  metric("vismap_bytes_sent_total", "counter", "Frame payload bytes sent.", bytes_sent.load());
  metric("vismap_bytes_received_total", "counter", "Message bytes received.",
         bytes_received.load());
  metric("vismap_scenes_loaded_total", "counter", "Scenes loaded.", scenes_loaded.load());
  metric("vismap_http_requests_total", "counter", "Plain HTTP requests.", http_requests.load());
  std::lock_guard lk(mu_);
  o << "# HELP vismap_render_ms Render plus encode time per frame, milliseconds.\n"
       "# TYPE vismap_render_ms histogram\n";
  for (size_t i = 0; i < kBuckets.size(); ++i)
    o << "vismap_render_ms_bucket{le=\"" << kBuckets[i] << "\"} " << buckets_[i] << '\n';
  o << "vismap_render_ms_bucket{le=\"+Inf\"} " << render_count_ << '\n'
    << "vismap_render_ms_sum " << render_sum_ms_ << '\n'
    << "vismap_render_ms_count " << render_count_ << '\n';
  o << "# HELP vismap_errors_total Error messages sent, by code.\n# TYPE vismap_errors_total "
       "counter\n";
  for (const auto& [code, n] : errors_)
    o << "vismap_errors_total{code=\"" << code << "\"} " << n << '\n';
  return o.str();
}

void Log::set_level(const std::string& name) {
  level_ = name == "off" ? Off : name == "warn" ? Warn : Info;
}

void Log::write(Level l, const std::string& event, nlohmann::json fields) {
  if (l < level_.load()) return;
  auto now = std::chrono::system_clock::now().time_since_epoch();
  nlohmann::json j = {{"ts", std::chrono::duration<double>(now).count()},
                      {"level", l == Warn ? "warn" : "info"},
                      {"event", event}};
  if (fields.is_object()) j.update(fields);
  std::string line = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  std::lock_guard lk(mu_);
  std::fwrite(line.data(), 1, line.size(), stderr);
}

}  // namespace vismap::server
