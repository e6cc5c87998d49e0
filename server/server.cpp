// The network side of vismapd: listener, plain HTTP (health, metrics, static viewer), WebSocket
// sessions. Everything a session does runs on its strand; renders run on RenderQueue workers and
// post their results back to the strand; scene parsing runs on a small load pool.
#include "server/server.h"

// Boost 1.74 asio/awaitable.hpp uses std::exchange without <utility> (fails under C++20, g++ 12).
#include <utility>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cctype>
#include <chrono>
#include <csignal>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include "core/output.h"
#include "core/clock.h"
#include "core/pipeline.h"
#include "core/scene.h"
#include "server/protocol.h"

#ifndef VISMAP_WWW_DIR
#define VISMAP_WWW_DIR ""
#endif

namespace vismap::server {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
using nlohmann::json;
static std::chrono::milliseconds seconds(double s) {
  return std::chrono::milliseconds(static_cast<int64_t>(s * 1000));
}

static uint64_t scene_bytes(const Scene& s) {
  uint64_t b = sizeof(Scene);
  for (const Mesh& m : s.meshes)
    b += sizeof(Mesh) + m.name.size() + 4 * (m.positions.size() + m.indices.size() + m.face_ids.size());
  return b;
}

static json camera_json(const Camera& c) {
  return {{"projection", c.projection == Camera::Projection::Orthographic ? "orthographic" : "perspective"},
          {"eye", c.eye},
          {"target", c.target},
          {"up", c.up},
          {"fov_y_deg", c.fov_y_deg},
          {"ortho_height", c.ortho_height},
          {"near", c.near_plane},
          {"far", c.far_plane},
          {"viewport", {{"width", c.width}, {"height", c.height}}}};
}

class WsSession;

// Holds one of max_connections while a connection is open (moved from HTTP to WebSocket).
struct ConnectionSlot {
  std::atomic<uint32_t>* n = nullptr;
  ConnectionSlot() = default;
  explicit ConnectionSlot(std::atomic<uint32_t>& c) : n(&c) {}
  ConnectionSlot(ConnectionSlot&& o) noexcept : n(std::exchange(o.n, nullptr)) {}
  ConnectionSlot& operator=(ConnectionSlot&&) = delete;
  ~ConnectionSlot() {
    if (n) --*n;
  }
};

struct Server::Impl {
  Config cfg;
  Metrics metrics;
  Log log;
  net::io_context ioc;
  std::optional<net::executor_work_guard<net::io_context::executor_type>> work;
  tcp::acceptor acceptor{net::make_strand(ioc)};
  net::thread_pool load_pool;
  RenderQueue queue;
  std::vector<std::thread> threads;
  std::atomic<bool> stopping{false};
  std::atomic<bool> stopped{false};
  std::atomic<uint32_t> connections{0};  // open TCP connections (HTTP and WebSocket)
  std::mutex sessions_mu;
  std::map<uint64_t, std::weak_ptr<WsSession>> sessions;
  std::string www;

  Impl(Config c, RenderQueue::RendererFactory make)
      : cfg(std::move(c)),
        load_pool(cfg.load_threads),
        queue(cfg.renderers, make ? std::move(make) : [dev = cfg.device] {
          return std::make_unique<Renderer>(dev);
        }) {
    log.set_level(cfg.log_level);
    www = cfg.www.empty() ? std::string(VISMAP_WWW_DIR) : cfg.www;
  }

  void accept();
  void add(uint64_t id, const std::shared_ptr<WsSession>& s) {
    std::lock_guard lk(sessions_mu);
    sessions[id] = s;
  }
  void remove(uint64_t id) {
    std::lock_guard lk(sessions_mu);
    sessions.erase(id);
  }
  size_t session_count() {
    std::lock_guard lk(sessions_mu);
    return sessions.size();
  }
};

// ---------------------------------------------------------------------------------------------
// WebSocket session

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Server::Impl& srv, ConnectionSlot slot)
      : slot_(std::move(slot)), ws_(std::move(socket)), srv_(srv),
        hello_timer_(ws_.get_executor()), idle_timer_(ws_.get_executor()) {
    beast::error_code ec;
    auto ep = beast::get_lowest_layer(ws_).socket().remote_endpoint(ec);
    peer_ = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
  }

  void run(http::request<http::string_body> req) {
    const Limits& L = srv_.cfg.limits;
    beast::get_lowest_layer(ws_).expires_never();
    websocket::stream_base::timeout t = websocket::stream_base::timeout::suggested(beast::role_type::server);
    t.handshake_timeout = seconds(L.handshake_timeout_s);
    t.idle_timeout = seconds(std::max(L.idle_timeout_s, 1.0));  // pings a silent peer, then drops it
    t.keep_alive_pings = true;
    ws_.set_option(t);
    ws_.read_message_max(0);  // no Beast limit: on_read enforces ours and answers too_large
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& res) {
      res.set(http::field::server, "vismapd");
    }));
    ws_.async_accept(req, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

  // Graceful stop: no new renders; close once the frame in flight is sent.
  void shutdown_async() {
    net::post(ws_.get_executor(), [self = shared_from_this()] { self->shutdown(); });
  }

 private:
  void shutdown() {
    stopping_ = true;
    if (!busy_ && !loading_) fail(code::shutting_down, "server is stopping", true, std::nullopt);
  }

  struct Out {
    std::shared_ptr<const std::string> data;
    bool binary = false;
    bool frame_payload = false;
  };

  void on_accept(beast::error_code ec) {
    if (ec) return;  // handshake failed or timed out: nothing to clean up
    const Limits& L = srv_.cfg.limits;
    if (srv_.stopping) {
      srv_.metrics.sessions_refused++;
      return fail(code::shutting_down, "server is stopping", true, std::nullopt);
    }
    // Reserve a place atomically: accepts on other io threads may race for the last one.
    if (srv_.metrics.sessions_active.fetch_add(1) >= static_cast<int64_t>(L.max_sessions)) {
      srv_.metrics.sessions_active--;
      srv_.metrics.sessions_refused++;
      srv_.log.warn("session_refused", {{"peer", peer_}, {"reason", "max_sessions"}});
      return fail(code::busy, "server has its maximum of " + std::to_string(L.max_sessions) + " sessions",
                  true, std::nullopt);
    }
    id_ = srv_.queue.add_session();
    registered_ = true;
    srv_.add(id_, shared_from_this());
    srv_.metrics.sessions_total++;
    srv_.log.info("session_open", {{"session", id_}, {"peer", peer_}});
    hello_timer_.expires_after(seconds(L.handshake_timeout_s));
    hello_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (!ec && !self->hello_) self->fail(code::timeout, "no hello within the handshake timeout", true, std::nullopt);
    });
    do_read();
  }

  void arm_idle() {
    idle_timer_.expires_after(seconds(srv_.cfg.limits.idle_timeout_s));
    idle_timer_.async_wait([self = shared_from_this(), gen = ++idle_gen_](beast::error_code ec) {
      if (ec || gen != self->idle_gen_) return;
      // A client waiting for a frame or a scene we owe it is not idle (found by server_bench:
      // at 50 sessions a lock-step client waited longer than idle_timeout_s for its frame).
      if (self->busy_ || self->loading_) return self->arm_idle();
      self->fail(code::timeout, "no message within the idle timeout", true, std::nullopt);
    });
  }

  // Reads in chunks so an over-limit message is answered with too_large and discarded, instead
  // of killing the connection: memory stays bounded by the limit, the session goes on.
  void do_read() {
    if (closing_ || reading_) return;
    reading_ = true;
    ws_.async_read_some(buf_, 64 * 1024, beast::bind_front_handler(&WsSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t bytes) {
    reading_ = false;
    if (ec) return finish(ec == websocket::error::closed ? "client_closed" : ec.message());
    srv_.metrics.bytes_received += bytes;
    const Limits& L = srv_.cfg.limits;
    uint64_t limit = hello_ ? L.message_max() : L.max_control_bytes;  // nothing big before hello
    if (discarding_ || buf_.size() > limit) {
      discarding_ = true;
      discarded_ += buf_.size();
      buf_.consume(buf_.size());
    }
    if (!ws_.is_message_done()) return do_read();
    if (hello_) arm_idle();
    try {
      if (discarding_) {
        discarding_ = false;
        uint64_t n = discarded_;
        discarded_ = 0;
        upload_.reset();
        throw ProtoError(code::too_large, "message of " + std::to_string(n) + " bytes is larger than " +
                                              std::to_string(limit) + " bytes; discarded", !hello_);
      }
      std::string msg = beast::buffers_to_string(buf_.data());
      buf_.consume(buf_.size());
      if (ws_.got_binary()) on_binary(std::move(msg));
      else on_text(msg);
    } catch (const ProtoError& e) {
      fail(e.code, e.what(), e.fatal, std::nullopt);
    } catch (const std::exception& e) {
      fail(code::internal, e.what(), false, std::nullopt);
    }
    if (out_.size() < kMaxOut) do_read();  // else on_write resumes reading (backpressure)
  }

  void on_text(const std::string& text) {
    const Limits& L = srv_.cfg.limits;
    if (upload_) {
      upload_.reset();
      throw ProtoError(code::unexpected_message,
                       "expected the scene's bytes as one binary message; upload cancelled");
    }
    Request r = parse_request(text, L.max_scene_bytes, L.max_viewport);
    if (text.size() > L.max_control_bytes && !std::holds_alternative<SceneRequest>(r))
      throw ProtoError(code::too_large, "control message is larger than max_control_bytes (" +
                                            std::to_string(L.max_control_bytes) + ")");
    if (!hello_) {
      if (!std::holds_alternative<Hello>(r))
        throw ProtoError(code::unexpected_message, "the first message must be hello", true);
      return on_hello(std::get<Hello>(r));
    }
    if (std::holds_alternative<Hello>(r)) throw ProtoError(code::unexpected_message, "hello was already sent");
    if (auto* s = std::get_if<SceneRequest>(&r)) return on_scene(std::move(*s));
    if (auto* c = std::get_if<CameraRequest>(&r)) return on_camera(*c);
    if (auto* p = std::get_if<Ping>(&r)) send_text(json{{"type", "pong"}, {"seq", p->seq}}.dump());
  }

  void on_hello(const Hello& h) {
    const std::string& token = srv_.cfg.token;
    if (!token.empty()) {
      // Compare in constant time over the expected token's length.
      unsigned diff = h.token.size() != token.size();
      for (size_t i = 0; i < token.size(); ++i) diff |= static_cast<unsigned>(token[i] ^ (i < h.token.size() ? h.token[i] : 0));
      if (diff) throw ProtoError(code::unauthorized, "hello has no valid token", true);
    }
    hello_ = h;
    hello_timer_.cancel();
    arm_idle();
    const Limits& L = srv_.cfg.limits;
    json limits = {{"max_message_bytes", L.message_max()},   {"max_control_bytes", L.max_control_bytes},
                   {"max_scene_bytes", L.max_scene_bytes},   {"max_triangles", L.max_triangles},
                   {"max_session_bytes", L.max_session_bytes}, {"max_viewport", L.max_viewport},
                   {"idle_timeout_s", L.idle_timeout_s}};
    send_text(json{{"type", "welcome"},
                   {"version", kProtocolVersion},
                   {"session", id_},
                   {"server", "vismapd"},
                   {"format", h.format == Format::Bin ? "bin" : "svg"},
                   {"library", !srv_.cfg.library.empty()},
                   {"limits", limits}}
                  .dump());
    srv_.log.info("hello", {{"session", id_}, {"format", h.format == Format::Bin ? "bin" : "svg"},
                            {"width", h.width}, {"height", h.height}});
  }

  void on_scene(SceneRequest req) {
    if (loading_) throw ProtoError(code::busy, "a scene is already loading");
    if (stopping_) throw ProtoError(code::shutting_down, "server is stopping");
    const Limits& L = srv_.cfg.limits;
    if (req.size > L.max_session_bytes || (req.data && req.data->size() > L.max_session_bytes))
      throw ProtoError(code::too_large, "upload is larger than max_session_bytes");
    if (!req.library.empty()) {
      if (srv_.cfg.library.empty()) throw ProtoError(to_string(InputErrorKind::FileNotFound), "server has no scene library");
      if (!safe_library_name(req.library))
        throw ProtoError(code::bad_message, "library scene names are relative paths without '..'");
      return load(std::move(req), {});
    }
    if (req.data) {
      std::string bytes = std::move(*req.data);
      req.data.reset();
      return load(std::move(req), std::move(bytes));
    }
    upload_ = std::move(req);  // bytes follow as the next binary message
  }

  void on_binary(std::string bytes) {
    if (!hello_) throw ProtoError(code::unexpected_message, "the first message must be hello", true);
    if (!upload_) throw ProtoError(code::unexpected_message, "binary message without a scene header");
    SceneRequest req = std::move(*upload_);
    upload_.reset();
    if (bytes.size() != req.size)
      throw ProtoError(code::bad_message, "scene header announced " + std::to_string(req.size) +
                                              " bytes, got " + std::to_string(bytes.size()));
    load(std::move(req), std::move(bytes));
  }

  void load(SceneRequest req, std::string bytes) {
    loading_ = true;
    auto t0 = Clock::now();
    net::post(srv_.load_pool, [self = shared_from_this(), req = std::move(req), bytes = std::move(bytes), t0]() mutable {
      const Limits& L = self->srv_.cfg.limits;
      std::shared_ptr<Scene> scene;
      std::string err_code, err_msg;
      try {
        LoadOptions opts{L.max_triangles};
        if (!req.library.empty()) {
          auto path = std::filesystem::path(self->srv_.cfg.library) / req.library;
          scene = std::make_shared<Scene>(load_scene(path.string(), opts));
          scene->source = req.library;  // never echo server paths
        } else {
          scene = std::make_shared<Scene>(load_scene_from_memory(req.name, bytes, opts));
        }
        if (scene->triangle_count() > L.max_triangles) {
          err_code = code::too_large;
          err_msg = req.name + ": " + std::to_string(scene->triangle_count()) +
                    " triangles, more than max_triangles (" + std::to_string(L.max_triangles) + ")";
        } else if (scene_bytes(*scene) + bytes.size() > L.max_session_bytes) {
          err_code = code::too_large;
          err_msg = req.name + ": scene needs more than max_session_bytes";
        }
      } catch (const InputError& e) {
        err_code = error_code(e);
        err_msg = e.what();
        if (!req.library.empty()) {  // name the library entry, not the server's folder
          err_msg = req.library + ": " + e.detail();
        }
      } catch (const std::bad_alloc&) {
        err_code = code::too_large;
        err_msg = req.name + ": out of memory while loading";
      } catch (const std::exception& e) {
        err_code = code::internal;
        err_msg = req.name + ": " + e.what();
      }
      double ms = ms_since(t0);
      net::post(self->ws_.get_executor(), [self, scene = std::move(scene), err_code, err_msg, name = req.name, ms] {
        self->on_loaded(scene, err_code, err_msg, name, ms);
      });
    });
  }

  void on_loaded(std::shared_ptr<Scene> scene, const std::string& err_code, const std::string& err_msg,
                 const std::string& name, double ms) {
    loading_ = false;
    if (closing_) return;
    if (!err_code.empty()) {
      fail(err_code, err_msg, false, std::nullopt);
    } else {
      Camera cam;
      if (scene->camera) {
        cam = *scene->camera;
        cam.width = hello_->width;
        cam.height = hello_->height;
      } else {
        cam = frame_scene(*scene, hello_->width, hello_->height);
      }
      auto bounds = scene_bounds(*scene);
      {
        std::lock_guard lk(cam_mu_);
        scene_ = scene;
        base_camera_ = cam;
      }
      srv_.metrics.scenes_loaded++;
      srv_.log.info("scene_loaded", {{"session", id_}, {"name", name}, {"triangles", scene->triangle_count()},
                                     {"load_ms", ms}});
      send_text(json{{"type", "scene_ready"},
                     {"name", name},
                     {"meshes", scene->meshes.size()},
                     {"triangles", scene->triangle_count()},
                     {"bounds", {{"lo", bounds.lo}, {"hi", bounds.hi}}},
                     {"camera", camera_json(cam)},
                     {"load_ms", ms}}
                    .dump());
    }
    if (stopping_ && !busy_) fail(code::shutting_down, "server is stopping", true, std::nullopt);
  }

  void on_camera(const CameraRequest& c) {
    if (stopping_) throw ProtoError(code::shutting_down, "server is stopping");
    {
      std::lock_guard lk(cam_mu_);
      if (!scene_) throw ProtoError(code::no_scene, "camera before any scene was loaded");
      if (latest_) {
        ++skipped_;
        srv_.metrics.frames_skipped++;
      }
      latest_ = c;
      latest_at_ = Clock::now();
    }
    kick();
  }

  // Starts a render when none is in flight. The task takes the newest camera when it starts, so
  // a camera that arrives while the task waits in the queue replaces the older one.
  void kick() {
    if (busy_ || stopping_ || closing_) return;
    {
      std::lock_guard lk(cam_mu_);
      if (!latest_) return;
    }
    busy_ = true;
    srv_.queue.submit(id_, [self = shared_from_this()](Renderer* r) { self->render(r); });
  }

  // Runs on a render worker.
  void render(Renderer* renderer) {
    std::shared_ptr<const Scene> scene;
    Camera cam;
    CameraRequest req;
    Clock::time_point queued;
    uint64_t skipped;
    {
      std::lock_guard lk(cam_mu_);
      req = *latest_;
      latest_.reset();
      scene = scene_;
      cam = base_camera_;
      queued = latest_at_;
      skipped = skipped_;
      skipped_ = 0;
    }
    const Hello& h = *hello_;
    double queue_ms = ms_since(queued);
    auto frame = std::make_shared<std::string>();
    json header;
    std::string err_code, err_msg;
    try {
      if (!renderer) throw DeviceError("no render device: " + srv_.queue.device_error());
      bool keep_near_far = req.near_plane || req.far_plane;
      req.apply_to(cam);
      if (!keep_near_far) cam.near_plane = cam.far_plane = 0;
      fit_near_far(cam, *scene);
      cam.validate();
      RenderOptions opts;
      opts.attributes = h.attributes && h.format == Format::Bin;
      opts.memory_budget = srv_.cfg.limits.render_memory_bytes;
      RenderStats stats;
      PlanarMap map = renderer->render(*scene, cam, opts, &stats);
      auto t0 = Clock::now();
      *frame = h.format == Format::Bin ? write_bin(map, *scene)
                                       : write_svg(map, *scene, cam, h.fill_id ? Fill::Id : Fill::Shade);
      double encode_ms = ms_since(t0);
      header = {{"type", "frame"},
                {"seq", req.seq},
                {"format", h.format == Format::Bin ? "bin" : "svg"},
                {"bytes", frame->size()},
                {"render_ms", stats.pipeline_ms},
                {"encode_ms", encode_ms},
                {"queue_ms", queue_ms},
                {"triangles", stats.input_triangles},
                {"fragments", map.fragment_count()},
                {"buckets", stats.buckets},
                {"skipped", skipped}};
      srv_.metrics.render_ms(stats.pipeline_ms + encode_ms);
    } catch (const InputError& e) {
      err_code = error_code(e);
      err_msg = e.what();
    } catch (const DeviceError& e) {
      err_code = code::device_error;
      err_msg = e.what();
    } catch (const std::bad_alloc&) {
      err_code = code::too_large;
      err_msg = "out of memory while rendering";
    } catch (const std::exception& e) {
      err_code = code::internal;
      err_msg = e.what();
    }
    net::post(ws_.get_executor(), [self = shared_from_this(), frame, header = std::move(header), err_code,
                                   err_msg, seq = req.seq] {
      if (!err_code.empty()) {
        self->busy_ = false;
        self->fail(err_code, err_msg, false, seq);
        self->after_frame();
        return;
      }
      self->send_text(header.dump());
      self->send(Out{frame, self->hello_->format == Format::Bin, true});
    });
  }

  void after_frame() {
    if (stopping_ && !loading_) return fail(code::shutting_down, "server is stopping", true, std::nullopt);
    kick();
  }

  void send_text(std::string s) { send(Out{std::make_shared<const std::string>(std::move(s)), false, false}); }

  void send(Out o) {
    if (closing_ && !closing_flush_) return;
    out_.push_back(std::move(o));
    if (!writing_) do_write();
  }

  void do_write() {
    writing_ = true;
    ws_.binary(out_.front().binary);
    ws_.async_write(net::buffer(*out_.front().data),
                    beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
  }

  void on_write(beast::error_code ec, size_t bytes) {
    writing_ = false;  // after_frame() below may send(), which starts the next write itself
    Out done = std::move(out_.front());
    out_.pop_front();
    if (ec) {
      out_.clear();
      if (done.frame_payload) busy_ = false;
      return finish("write: " + ec.message());
    }
    if (done.frame_payload) {
      srv_.metrics.frames++;
      srv_.metrics.bytes_sent += bytes;
      busy_ = false;
      after_frame();
    }
    if (writing_) return;
    if (!out_.empty()) return do_write();
    if (closing_flush_) return do_close();
    if (!reading_ && !closing_) do_read();
  }

  // Sends an error; a fatal one closes the session after the message is flushed.
  void fail(const std::string& c, const std::string& message, bool fatal, std::optional<uint64_t> seq) {
    if (closing_) return;
    srv_.metrics.error(c);
    srv_.log.warn("error", {{"session", id_}, {"peer", peer_}, {"code", c}, {"message", message}, {"fatal", fatal}});
    send_text(error_json(c, message, fatal, seq));
    if (!fatal) return;
    closing_ = true;
    closing_flush_ = true;
    close_code_ = c == code::busy                                                ? websocket::close_code::try_again_later
                  : c == code::shutting_down                                     ? websocket::close_code::going_away
                  : c == code::unauthorized || c == code::version_mismatch ? websocket::close_code::policy_error
                  : c == code::internal                                          ? websocket::close_code::internal_error
                                                                                 : websocket::close_code::normal;
    // send() started or queued the write; on_write calls do_close once everything is flushed.
  }

  void do_close() {
    if (writing_close_) return;
    writing_close_ = true;
    closing_flush_ = false;
    hello_timer_.cancel();
    idle_timer_.cancel();
    ws_.async_close(websocket::close_reason(close_code_),
                    [self = shared_from_this()](beast::error_code) { self->finish("closed_by_server"); });
  }

  // The session is over (peer closed, error, or our close finished). Idempotent.
  void finish(const std::string& reason) {
    closing_ = true;
    hello_timer_.cancel();
    idle_timer_.cancel();
    if (finished_) return;
    finished_ = true;
    if (registered_) {
      srv_.queue.remove_session(id_);
      srv_.remove(id_);
      srv_.metrics.sessions_active--;
      srv_.log.info("session_close", {{"session", id_}, {"reason", reason}});
    }
    beast::error_code ec;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ec);
    beast::get_lowest_layer(ws_).socket().close(ec);
  }

  static constexpr size_t kMaxOut = 32;

  ConnectionSlot slot_;
  websocket::stream<beast::tcp_stream> ws_;
  Server::Impl& srv_;
  net::steady_timer hello_timer_, idle_timer_;
  beast::flat_buffer buf_;
  std::string peer_;
  uint64_t id_ = 0;
  bool registered_ = false;
  std::optional<Hello> hello_;
  std::optional<SceneRequest> upload_;
  std::deque<Out> out_;
  bool discarding_ = false;
  uint64_t discarded_ = 0;
  bool writing_ = false;
  bool reading_ = false, busy_ = false, loading_ = false, stopping_ = false;
  bool closing_ = false, closing_flush_ = false, writing_close_ = false, finished_ = false;
  uint64_t idle_gen_ = 0;
  websocket::close_code close_code_ = websocket::close_code::normal;

  // Shared with the render worker.
  std::mutex cam_mu_;
  std::shared_ptr<const Scene> scene_;
  Camera base_camera_;
  std::optional<CameraRequest> latest_;
  Clock::time_point latest_at_;
  uint64_t skipped_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Plain HTTP: /health, /metrics, the viewer; upgrades go to WsSession.

static const char* mime(const std::string& path) {
  auto ends = [&](const char* e) { return path.size() >= strlen(e) && path.compare(path.size() - strlen(e), strlen(e), e) == 0; };
  if (ends(".html")) return "text/html; charset=utf-8";
  if (ends(".js")) return "text/javascript";
  if (ends(".css")) return "text/css";
  if (ends(".svg")) return "image/svg+xml";
  if (ends(".json")) return "application/json";
  return "application/octet-stream";
}

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& s, Server::Impl& srv, ConnectionSlot slot)
      : slot_(std::move(slot)), stream_(std::move(s)), srv_(srv) {}
  void run() {
    net::dispatch(stream_.get_executor(), beast::bind_front_handler(&HttpSession::read, shared_from_this()));
  }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(16 * 1024);
    parser_->body_limit(srv_.cfg.limits.max_control_bytes);
    stream_.expires_after(seconds(srv_.cfg.limits.handshake_timeout_s));
    http::async_read(stream_, buf_, *parser_, beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t) {
    if (ec) {
      beast::error_code ec2;
      stream_.socket().shutdown(tcp::socket::shutdown_both, ec2);
      return;
    }
    auto& req = parser_->get();
    std::string target(req.target());
    if (websocket::is_upgrade(req)) {
      if (target != "/" && target != "/ws" && target.rfind("/?", 0) != 0 && target.rfind("/ws?", 0) != 0)
        return respond(http::status::not_found, "text/plain", "WebSocket endpoint is / or /ws\n");
      auto s = std::make_shared<WsSession>(stream_.release_socket(), srv_, std::move(slot_));
      return s->run(parser_->release());
    }
    srv_.metrics.http_requests++;
    if (req.method() != http::verb::get && req.method() != http::verb::head)
      return respond(http::status::method_not_allowed, "text/plain", "only GET\n");
    std::string path = target.substr(0, target.find('?'));
    if (path == "/health") {
      json j = {{"status", srv_.stopping ? "stopping" : "ok"},
                {"sessions", srv_.metrics.sessions_active.load()},
                {"protocol", kProtocolVersion}};
      return respond(srv_.stopping ? http::status::service_unavailable : http::status::ok, "application/json",
                     j.dump() + "\n");
    }
    if (path == "/metrics") return respond(http::status::ok, "text/plain; version=0.0.4", srv_.metrics.prometheus());
    if (path == "/") path = "/index.html";
    std::string name = path.substr(1);
    bool ok = !srv_.www.empty() && !name.empty() && name.size() < 100;
    for (char ch : name) ok = ok && (std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '-' || ch == '_');
    ok = ok && name[0] != '.';
    if (ok) {
      try {
        return respond(http::status::ok, mime(name), read_file(srv_.www + "/" + name));
      } catch (const std::exception&) {
      }
    }
    respond(http::status::not_found, "text/plain", "not found\n");
  }

  void respond(http::status st, const char* type, std::string body) {
    auto res = std::make_shared<http::response<http::string_body>>(st, parser_->get().version());
    res->set(http::field::server, "vismapd");
    res->set(http::field::content_type, type);
    res->set(http::field::cache_control, "no-store");
    res->keep_alive(parser_->get().keep_alive() && !srv_.stopping);
    if (parser_->get().method() != http::verb::head) res->body() = std::move(body);
    res->prepare_payload();
    http::async_write(stream_, *res, [self = shared_from_this(), res](beast::error_code ec, size_t) {
      if (ec) return;
      if (!res->keep_alive()) {
        beast::error_code ec2;
        self->stream_.socket().shutdown(tcp::socket::shutdown_send, ec2);
        return;
      }
      self->read();
    });
  }

  ConnectionSlot slot_;
  beast::tcp_stream stream_;
  beast::flat_buffer buf_;
  std::optional<http::request_parser<http::string_body>> parser_;
  Server::Impl& srv_;
};

void Server::Impl::accept() {
  acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket s) {
    if (ec) {
      if (ec == net::error::operation_aborted || stopping) return;
      log.warn("accept_error", {{"message", ec.message()}});
    } else {
      beast::error_code ignored;
      if (connections.fetch_add(1) >= cfg.limits.max_connections) {
        --connections;  // over the cap: close at once, before reading a byte
        metrics.sessions_refused++;
        s.close(ignored);
      } else {
        s.set_option(tcp::no_delay(true), ignored);  // frames are latency-bound: no Nagle delay
        std::make_shared<HttpSession>(std::move(s), *this, ConnectionSlot(connections))->run();
      }
    }
    if (!stopping) accept();
  });
}

// ---------------------------------------------------------------------------------------------

Server::Server(Config cfg, RenderQueue::RendererFactory make)
    : impl_(std::make_unique<Impl>(std::move(cfg), std::move(make))) {}

Server::~Server() { stop(); }

Metrics& Server::metrics() { return impl_->metrics; }
const Config& Server::config() const { return impl_->cfg; }

uint16_t Server::start() {
  Impl& s = *impl_;
  beast::error_code ec;
  auto addr = net::ip::make_address(s.cfg.address, ec);
  if (ec) throw std::runtime_error("bad address '" + s.cfg.address + "'");
  tcp::endpoint ep(addr, s.cfg.port);
  s.acceptor.open(ep.protocol(), ec);
  if (!ec) s.acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) s.acceptor.bind(ep, ec);
  if (!ec) s.acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("cannot listen on " + s.cfg.address + ":" + std::to_string(s.cfg.port) + ": " + ec.message());
  uint16_t port = s.acceptor.local_endpoint().port();
  s.work.emplace(s.ioc.get_executor());
  s.accept();
  for (uint32_t i = 0; i < s.cfg.io_threads; ++i) s.threads.emplace_back([&s] { s.ioc.run(); });
  s.log.info("listening", {{"address", s.cfg.address}, {"port", port}, {"renderers", s.cfg.renderers},
                           {"library", s.cfg.library}, {"auth", !s.cfg.token.empty()}});
  return port;
}

void Server::stop() {
  Impl& s = *impl_;
  if (s.stopped.exchange(true)) return;
  if (s.threads.empty()) {
    s.queue.stop();
    return;
  }
  s.stopping = true;
  s.log.info("stopping", {{"sessions", s.metrics.sessions_active.load()}});
  net::post(s.acceptor.get_executor(), [&s] {
    beast::error_code ec;
    s.acceptor.close(ec);
  });
  std::vector<std::shared_ptr<WsSession>> live;
  {
    std::lock_guard lk(s.sessions_mu);
    for (auto& [id, w] : s.sessions)
      if (auto p = w.lock()) live.push_back(p);
  }
  for (auto& p : live) p->shutdown_async();
  auto deadline = Clock::now() + seconds(s.cfg.drain_timeout_s);
  s.queue.drain(s.cfg.drain_timeout_s);
  while (s.session_count() > 0 && Clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  s.work.reset();
  s.ioc.stop();
  for (auto& t : s.threads) t.join();
  s.threads.clear();
  s.queue.stop();
  s.load_pool.join();
  s.log.info("stopped", {{"frames", s.metrics.frames.load()}});
}

void Server::run_until_signal() {
  net::io_context sig_ioc;
  net::signal_set signals(sig_ioc, SIGINT, SIGTERM);
  signals.async_wait([&](beast::error_code, int sig) { impl_->log.info("signal", {{"signal", sig}}); });
  sig_ioc.run();
  stop();
}

}  // namespace vismap::server
