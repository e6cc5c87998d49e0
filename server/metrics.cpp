#include "server/metrics.h"

#include <chrono>
#include <cstdio>
#include <sstream>

namespace vismap::server {

void Metrics::error(const std::string& code) {
  std::lock_guard lk(mu_);
  ++errors_[code];
}

void Metrics::Histogram::add(double ms) {
  for (size_t i = 0; i < kBuckets.size(); ++i)
    if (ms <= kBuckets[i]) ++buckets[i];
  ++count;
  sum_ms += ms;
}

void Metrics::render_ms(double ms) {
  std::lock_guard lk(mu_);
  render_.add(ms);
}

void Metrics::encode_ms(Format f, double ms) {
  std::lock_guard lk(mu_);
  encode_[static_cast<size_t>(f)].add(ms);
}

void Metrics::frame_sent(Format f, uint64_t payload_bytes) {
  std::lock_guard lk(mu_);
  ++format_frames_[static_cast<size_t>(f)];
  format_bytes_[static_cast<size_t>(f)] += payload_bytes;
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
  // One histogram's series; labels: "" or `format="svg",` (a label list's prefix).
  auto histogram = [&](const char* name, const std::string& labels, const Histogram& h) {
    for (size_t i = 0; i < kBuckets.size(); ++i)
      o << name << "_bucket{" << labels << "le=\"" << kBuckets[i] << "\"} " << h.buckets[i] << '\n';
    std::string plain = labels.empty() ? "" : "{" + labels.substr(0, labels.size() - 1) + "}";
    o << name << "_bucket{" << labels << "le=\"+Inf\"} " << h.count << '\n'
      << name << "_sum" << plain << ' ' << h.sum_ms << '\n'
      << name << "_count" << plain << ' ' << h.count << '\n';
  };
  auto label = [](const FormatSpec& s) { return std::string("format=\"") + s.name + "\""; };
  o << "# HELP vismap_render_ms Render plus encode time per frame, milliseconds.\n"
       "# TYPE vismap_render_ms histogram\n";
  histogram("vismap_render_ms", "", render_);
  o << "# HELP vismap_encode_ms Encode time per frame (on the encode pool), milliseconds, by "
       "format.\n# TYPE vismap_encode_ms histogram\n";
  for (const FormatSpec& s : kFormats)
    histogram("vismap_encode_ms", label(s) + ",", encode_[static_cast<size_t>(s.format)]);
  o << "# HELP vismap_frames_by_format_total Frames sent, by format.\n"
       "# TYPE vismap_frames_by_format_total counter\n";
  for (const FormatSpec& s : kFormats)
    o << "vismap_frames_by_format_total{" << label(s) << "} "
      << format_frames_[static_cast<size_t>(s.format)] << '\n';
  o << "# HELP vismap_frame_bytes_total Frame payload bytes sent (before any permessage-deflate), "
       "by format.\n# TYPE vismap_frame_bytes_total counter\n";
  for (const FormatSpec& s : kFormats)
    o << "vismap_frame_bytes_total{" << label(s) << "} "
      << format_bytes_[static_cast<size_t>(s.format)] << '\n';
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
