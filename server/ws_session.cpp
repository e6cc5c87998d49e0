// The WebSocket session: one explicit state (WsSession::State) for where the session is in its
// life, and one phase for the frame in flight (a frame and a scene load may overlap). Everything
// here runs on the connection's strand except render() (a RenderQueue worker), encode() (the
// encode pool) and the load job (the load pool), which post their results back.
#include "server/ws_session.h"

#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <deque>
#include <nlohmann/json.hpp>

#include "core/frame/frame.h"
#include "core/scene.h"
#include "core/stream/delta.h"
#include "core/util/clock.h"
#include "server/error_reply.h"
#include "server/protocol.h"
#include "server/tcp_send.h"

namespace vismap::server {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using nlohmann::json;

namespace {

using frame::scene_bytes;

// How a session's frames are written (core/frame/encoders.h), from its hello. level: compact and
// delta frames' entropy coder level (Config::frame_level; 0: its default).
frame::OutputSpec output_spec(const Hello& h, int level) {
  frame::OutputSpec o;
  o.format = format_spec(h.format).output;
  o.fill = h.fill_id ? Fill::Id : Fill::Shade;
  o.style = frame::style_named(h.style).value_or(frame::DrawStyle::Fill);
  o.lines.hidden = h.hidden;
  o.lines.crease_angle_deg = h.crease_angle_deg;
  o.attributes = h.attributes;
  o.quantum = h.quantum;
  o.compression = h.compression;
  o.level = level;
  o.keyframe_every = h.keyframe_every;
  o.delta_version = h.version >= 3 ? 2 : 1;  // DELTA.md version 2 from protocol version 3
  o.client_holds_scene = h.hold_scene;
  return o;
}

websocket::close_code close_code_for(const std::string& c) {
  if (c == code::busy) return websocket::close_code::try_again_later;
  if (c == code::shutting_down) return websocket::close_code::going_away;
  if (c == code::unauthorized || c == code::version_mismatch)
    return websocket::close_code::policy_error;
  if (c == code::internal) return websocket::close_code::internal_error;
  return websocket::close_code::normal;
}

const ErrorReply kShuttingDown{code::shutting_down, "server is stopping", true};

// A message, frame or upload this big makes the session's end hand freed memory back to the
// kernel (Server::Impl::trim_memory): one spike must not stay resident for the process's life.
constexpr uint64_t kTrimAfterBytes = 16ull << 20;

// A request refused for its size or its time held up to its limits (a frame's render_memory_bytes,
// a load's max_session_bytes) until it was stopped: that memory goes back to the kernel at once.
bool spike(const ErrorReply& e) {
  return e.code == code::too_large || e.code == to_string(InputErrorKind::TimeLimit);
}

// The read buffer keeps at most this much capacity between messages.
constexpr size_t kKeepReadBuffer = 1 << 20;

class WsSession : public SessionHandle, public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Server::Impl& srv, ConnectionSlot slot)
      : slot_(std::move(slot)),
        ws_(std::move(socket)),
        srv_(srv),
        hello_timer_(ws_.get_executor()),
        idle_timer_(ws_.get_executor()) {
    beast::error_code ec;
    auto ep = beast::get_lowest_layer(ws_).socket().remote_endpoint(ec);
    peer_ = ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
  }

  void run(http::request<http::string_body> req) {
    const Limits& L = srv_.cfg.limits;
    beast::get_lowest_layer(ws_).expires_never();
    auto t = websocket::stream_base::timeout::suggested(beast::role_type::server);
    t.handshake_timeout = seconds(L.handshake_timeout_s);
    // No Beast idle timeout: it counts only bytes received, and its keep-alive ping waits behind
    // the frame being written, so a client reading a big frame slowly (it sends nothing until
    // it has read through to the ping) was dropped mid-frame (issue 45, item 8). The session's
    // own idle timer (check_idle) covers silent and dead peers.
    t.idle_timeout = websocket::stream_base::none();
    t.keep_alive_pings = false;
    ws_.set_option(t);
    ws_.read_message_max(0);  // no Beast limit: on_read enforces ours and answers too_large
    if (srv_.cfg.permessage_deflate) {
      // Offered; used only when the client asks in its upgrade. Reads stay bounded: on_read's
      // limits count inflated bytes (async_read_some inflates at most 64 KiB a call).
      websocket::permessage_deflate pmd;
      pmd.server_enable = true;
      pmd.server_max_window_bits = srv_.cfg.deflate_window_bits;
      pmd.compLevel = srv_.cfg.deflate_level;
      pmd.memLevel = srv_.cfg.deflate_mem_level;
      ws_.set_option(pmd);
    }
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "vismapd"); }));
    ws_.async_accept(req, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

  void drain_async() override {
    net::post(ws_.get_executor(), [self = shared_from_this()] { self->drain(); });
  }
  void close_now_async() override {
    net::post(ws_.get_executor(), [self = shared_from_this()] { self->fail(kShuttingDown, {}); });
  }

 private:
  // Where the session is. Every transition happens on the strand:
  //   Upgrading     -> AwaitingHello  WebSocket handshake done (else Closed)
  //   AwaitingHello -> Open           hello accepted: the session slot is taken only now
  //   Open          -> Draining       server stopping while a frame or a load is in flight
  //   AwaitingHello, Open, Draining
  //                 -> Flushing       fatal error queued (Draining: when the work is done)
  //   Flushing      -> Closing        write queue empty: close frame sent
  //   any           -> Closed         close handshake done, peer gone, read or write error
  enum class State : uint8_t {
    Upgrading,
    AwaitingHello,
    Open,
    Draining,
    Flushing,
    Closing,
    Closed
  };
  // The session's one frame in flight: queued or rendering on a worker, encoding on the encode
  // pool, or header and payload in the write queue.
  enum class FramePhase : uint8_t { Idle, Rendering, Encoding, Sending };

  struct Out {
    std::shared_ptr<const std::string> data;
    bool binary = false;
    bool frame_payload = false;
    Format format = Format::Svg;  // of a frame payload
  };

  bool accepting_messages() const {
    return state_ == State::AwaitingHello || state_ == State::Open || state_ == State::Draining;
  }
  bool work_in_flight() const { return frame_ != FramePhase::Idle || loading_; }

  void on_accept(beast::error_code ec) {
    if (ec) {
      state_ = State::Closed;  // handshake failed or timed out: nothing to clean up
      return;
    }
    state_ = State::AwaitingHello;
    connection_ = srv_.add(shared_from_this());
    const Limits& L = srv_.cfg.limits;
    if (srv_.stopping) {
      srv_.metrics.sessions_refused++;
      return fail(kShuttingDown, {});
    }
    // Refused at once when full; the slot itself is taken at hello (on_hello), so connections
    // that never send hello cannot hold the sessions of clients that do.
    if (srv_.metrics.sessions_active.load() >= static_cast<int64_t>(L.max_sessions))
      return refuse_busy();
    hello_timer_.expires_after(seconds(L.handshake_timeout_s));
    hello_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (!ec && self->state_ == State::AwaitingHello)
        self->fail({code::timeout, "no hello within the handshake timeout", true}, {});
    });
    do_read();
  }

  void refuse_busy() {
    uint32_t max = srv_.cfg.limits.max_sessions;
    srv_.metrics.sessions_refused++;
    srv_.log.warn("session_refused", {{"peer", peer_}, {"reason", "max_sessions"}});
    fail({code::busy, "server has its maximum of " + std::to_string(max) + " sessions", true}, {});
  }

  void drain() {
    if (state_ == State::Draining) return;
    if (state_ == State::Open && work_in_flight())
      state_ = State::Draining;
    else
      fail(kShuttingDown, {});
  }

  // The idle timer (limits.idle_timeout_s) counts from the later of the client's last message
  // and the end of the server's last send, the moment the client's side acknowledged its last
  // byte (issue 45, item 8: it counted from the client's last message, so a client reading a
  // 2.7 MB frame at 150 KB/s was cut off mid-frame). It never fires while a frame renders or
  // encodes, a scene loads, or a send makes progress; a send that makes none for a whole
  // idle_timeout_s (the peer reads nothing, or is gone) ends the connection at once: the error
  // could not get past the unread bytes. arm_idle: a client message just came.
  void arm_idle() {
    last_active_ = Clock::now();
    schedule_idle_check(srv_.cfg.limits.idle_timeout_s);
  }
  void schedule_idle_check(double after_s) {
    idle_timer_.expires_after(
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(after_s)));
    idle_timer_.async_wait([self = shared_from_this(), gen = ++idle_gen_](beast::error_code ec) {
      if (ec || gen != self->idle_gen_) return;
      self->check_idle();
    });
  }
  void check_idle() {
    if (!accepting_messages()) return;
    const double idle = srv_.cfg.limits.idle_timeout_s;
    auto now = Clock::now();
    TcpSendState tcp = send_state();
    bool sending = !out_.empty() || tcp.queued > 0;
    if (sending) {
      if (tcp.acked != last_acked_) last_active_ = now;  // the peer took bytes since the last look
      send_tracked_ = true;
    } else if (send_tracked_) {
      last_active_ = now;  // the send ended since the last look, at most idle/4 ago
      send_tracked_ = false;
    }
    last_acked_ = tcp.acked;
    // A client waiting for a frame or a scene we owe it is not idle (found by server_bench:
    // at 50 sessions a lock-step client waited longer than idle_timeout_s for its frame).
    bool owed = frame_ == FramePhase::Rendering || frame_ == FramePhase::Encoding || loading_;
    if (owed) last_active_ = now;
    double since = std::chrono::duration<double>(now - last_active_).count();
    if (since < idle) {
      // While a send or a frame is under way, look again every quarter of the timeout: the end
      // of the send is seen at most idle/4 late, so the client gets idle to 1.25 x idle after it.
      double next = idle - since;
      if (sending || owed) next = std::min(next, idle / 4);
      return schedule_idle_check(next);
    }
    if (!sending) return fail({code::timeout, "no message within the idle timeout", true}, {});
    // A send that made no progress for the whole timeout: the peer reads nothing, or is gone,
    // and an error message could not get past the unread bytes. The pending write fails once
    // the socket is closed (on_write cleans up).
    srv_.metrics.error(code::timeout);
    srv_.log.warn("error", {{"session", session_},
                            {"peer", peer_},
                            {"code", code::timeout},
                            {"message", "the client read nothing of a send for the idle timeout"},
                            {"fatal", true}});
    finish("send_stalled");
  }
  TcpSendState send_state() {
    auto& sock = beast::get_lowest_layer(ws_).socket();
    return sock.is_open() ? tcp_send_state(sock.native_handle()) : TcpSendState{};
  }
  // The write queue just emptied: the send's end as far as the process can tell. Where the
  // kernel still holds unacknowledged bytes, the idle check follows them within idle/4.
  void note_send_done() {
    last_active_ = Clock::now();
    if (state_ != State::Open && state_ != State::Draining) return;
    TcpSendState tcp = send_state();
    last_acked_ = tcp.acked;
    if (tcp.queued == 0) return;
    send_tracked_ = true;
    double quarter = srv_.cfg.limits.idle_timeout_s / 4;
    if (idle_timer_.expiry() > Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                  std::chrono::duration<double>(quarter)))
      schedule_idle_check(quarter);
  }

  // Reads in chunks so an over-limit message is answered with too_large and discarded, instead
  // of killing the connection: memory stays bounded by the limit, the session goes on.
  void do_read() {
    if (!accepting_messages() || read_pending_) return;
    read_pending_ = true;
    ws_.async_read_some(buf_, 64 * 1024,
                        beast::bind_front_handler(&WsSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t bytes) {
    read_pending_ = false;
    if (ec) return finish(ec == websocket::error::closed ? "client_closed" : ec.message());
    if (!accepting_messages()) return;
    srv_.metrics.bytes_received += bytes;
    const Limits& L = srv_.cfg.limits;
    bool before_hello = state_ == State::AwaitingHello;
    uint64_t limit = before_hello ? L.max_control_bytes : L.message_max();  // nothing big yet
    if (discarded_ || buf_.size() > limit) {
      discarded_ = discarded_.value_or(0) + buf_.size();
      buf_.consume(buf_.size());
    }
    if (!ws_.is_message_done()) return do_read();
    if (!before_hello) arm_idle();
    try {
      if (discarded_) {
        uint64_t n = *discarded_;
        discarded_.reset();
        upload_.reset();
        throw ProtoError(code::too_large,
                         "message of " + std::to_string(n) + " bytes is larger than " +
                             std::to_string(limit) + " bytes; discarded",
                         before_hello);
      }
      std::string msg = beast::buffers_to_string(buf_.data());
      buf_.consume(buf_.size());
      if (buf_.capacity() > kKeepReadBuffer) buf_.shrink_to_fit();
      peak_bytes_ = std::max<uint64_t>(peak_bytes_, msg.size());
      if (ws_.got_binary())
        on_binary(std::move(msg));
      else
        on_text(msg);
    } catch (...) {
      fail(error_reply(std::current_exception(), "reading a message"), {});
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
    check_control_message(text, L.max_control_bytes);  // before any DOM is built
    Request r = parse_request(text, L.max_scene_bytes, L.max_viewport, /*checked_depth=*/true);
    if (state_ == State::AwaitingHello) {
      if (!std::holds_alternative<Hello>(r))
        throw ProtoError(code::unexpected_message, "the first message must be hello", true);
      return on_hello(std::get<Hello>(r));
    }
    if (std::holds_alternative<Hello>(r))
      throw ProtoError(code::unexpected_message, "hello was already sent");
    if (auto* s = std::get_if<SceneRequest>(&r)) return on_scene(std::move(*s));
    if (auto* c = std::get_if<CameraRequest>(&r)) return on_camera(*c);
    if (auto* p = std::get_if<Ping>(&r)) send_text(pong_message(p->seq));
    if (std::holds_alternative<KeyframeRequest>(r)) {
      if (hello_->format != Format::Delta)
        throw ProtoError(code::unexpected_message, "keyframe is for delta sessions");
      encoder_->request_keyframe();
    }
  }

  void on_hello(const Hello& h) {
    const std::string& token = srv_.cfg.token;
    if (!token.empty()) {
      // Compare in constant time over the expected token's length.
      unsigned diff = h.token.size() != token.size();
      for (size_t i = 0; i < token.size(); ++i)
        diff |= static_cast<unsigned>(token[i] ^ (i < h.token.size() ? h.token[i] : 0));
      if (diff) throw ProtoError(code::unauthorized, "hello has no valid token", true);
    }
    const Limits& L = srv_.cfg.limits;
    // Take a session slot atomically: hellos on other io threads may race for the last one.
    if (srv_.metrics.sessions_active.fetch_add(1) >= static_cast<int64_t>(L.max_sessions)) {
      srv_.metrics.sessions_active--;
      return refuse_busy();
    }
    session_ = srv_.queue.add_session();
    srv_.metrics.sessions_total++;
    srv_.log.info("session_open", {{"session", session_}, {"peer", peer_}});
    hello_ = h;
    output_ = output_spec(h, srv_.cfg.frame_level);
    encoder_ = frame::make_encoder(output_);
    state_ = State::Open;
    hello_timer_.cancel();
    arm_idle();
    const char* format = format_spec(h.format).name;
    send_text(welcome_message(h, session_, srv_.library.enabled(),
                              {L.message_max(), L.max_control_bytes, L.max_scene_bytes,
                               L.max_triangles, L.max_session_bytes, L.max_viewport,
                               L.idle_timeout_s}));
    srv_.log.info("hello", {{"session", session_},
                            {"version", h.version},
                            {"format", format},
                            {"width", h.width},
                            {"height", h.height}});
  }

  void on_scene(SceneRequest req) {
    if (loading_) throw ProtoError(code::busy, "a scene is already loading");
    if (state_ == State::Draining) throw ProtoError(code::shutting_down, "server is stopping");
    const Limits& L = srv_.cfg.limits;
    if (req.size > L.max_session_bytes || (req.data && req.data->size() > L.max_session_bytes))
      throw ProtoError(code::too_large, "upload is larger than max_session_bytes");
    if (!req.library.empty()) {
      std::string path = srv_.library.resolve(req.library);
      return load(std::move(req), {}, std::move(path));
    }
    if (req.data) {
      std::string bytes = std::move(*req.data);
      req.data.reset();
      return load(std::move(req), std::move(bytes), {});
    }
    upload_ = std::move(req);  // bytes follow as the next binary message
  }

  void on_binary(std::string bytes) {
    if (state_ == State::AwaitingHello)
      throw ProtoError(code::unexpected_message, "the first message must be hello", true);
    if (!upload_)
      throw ProtoError(code::unexpected_message, "binary message without a scene header");
    SceneRequest req = std::move(*upload_);
    upload_.reset();
    if (bytes.size() != req.size)
      throw ProtoError(code::bad_message, "scene header announced " + std::to_string(req.size) +
                                              " bytes, got " + std::to_string(bytes.size()));
    load(std::move(req), std::move(bytes), {});
  }

  // Parses the scene on the load pool. library_path: the resolved library file, or empty for
  // an upload (`bytes`).
  void load(SceneRequest req, std::string bytes, std::string library_path) {
    loading_ = true;
    srv_.loads_in_flight++;
    auto job = [self = shared_from_this(), req = std::move(req), bytes = std::move(bytes),
                path = std::move(library_path), t0 = Clock::now()]() mutable {
      Server::Impl& srv = self->srv_;
      const Limits& L = srv.cfg.limits;
      std::shared_ptr<Scene> scene;
      std::optional<ErrorReply> err;
      try {
        LoadOptions opts;
        opts.max_triangles = L.max_triangles;
        opts.time_limit_s = L.render_time_limit_s;  // a load answers within it, as a frame does
        if (!path.empty()) {
          // A library file: confined to the library (symlinks inside it, files a scene file
          // references) and its input bytes capped at one session's budget.
          opts.confine_to = srv.library.root();
          opts.max_bytes = L.max_session_bytes;
          scene = std::make_shared<Scene>(load_scene(path, opts));
          scene->source = req.library;  // never echo server paths
        } else {
          // What the session may still hold besides the upload: a .ply.gz's inflated bytes
          // count against it (at least 1: 0 would mean no limit).
          opts.max_bytes = std::max<uint64_t>(1, L.max_session_bytes - bytes.size());
          scene = std::make_shared<Scene>(load_scene_from_memory(req.name, bytes, opts));
        }
        if (scene->triangle_count() > L.max_triangles) {
          err = ErrorReply{code::too_large, req.name + ": " +
                                                std::to_string(scene->triangle_count()) +
                                                " triangles, more than max_triangles (" +
                                                std::to_string(L.max_triangles) + ")"};
        } else if (scene_bytes(*scene) + bytes.size() > L.max_session_bytes) {
          err = ErrorReply{code::too_large, req.name + ": scene needs more than max_session_bytes"};
        }
      } catch (...) {
        err = error_reply(std::current_exception(), "loading " + req.name, &srv.library);
      }
      if (err) scene.reset();
      double ms = ms_since(t0);
      uint64_t held = bytes.size();
      std::string().swap(bytes);
      if (held >= kTrimAfterBytes || (err && spike(*err)))
        srv.trim_memory();  // the upload's or the load's spike is over
      net::post(self->ws_.get_executor(),
                [self, scene = std::move(scene), err = std::move(err), name = req.name, ms] {
                  self->on_loaded(scene, err, name, ms);
                });
      srv.loads_in_flight--;
    };
    net::post(srv_.load_pool, std::move(job));
  }

  void on_loaded(const std::shared_ptr<Scene>& scene, const std::optional<ErrorReply>& err,
                 const std::string& name, double ms) {
    loading_ = false;
    if (!accepting_messages()) return;
    if (err) {
      fail(*err, {});
    } else {
      const Camera cam = frame::scene_camera(*scene, hello_->width, hello_->height);
      auto bounds = scene_bounds(*scene);
      auto state = std::make_shared<frame::SceneState>(scene);  // (the old one's facts and
      {                                                           // plans go with its last frame)
        std::lock_guard lk(cam_mu_);
        scene_ = state;
        base_camera_ = cam;
      }
      peak_bytes_ = std::max(peak_bytes_, scene_bytes(*scene));
      srv_.metrics.scenes_loaded++;
      // What the load could not take as it is (a polygon whose edges cross): the operator's to
      // see, in the log; the client gets the frames as they are.
      for (const std::string& w : scene->warnings)
        srv_.log.warn("scene_warning", {{"session", session_}, {"name", name}, {"message", w}});
      srv_.log.info("scene_loaded", {{"session", session_},
                                     {"name", name},
                                     {"triangles", scene->triangle_count()},
                                     {"load_ms", ms}});
      send_text(scene_ready_message(name, scene->meshes.size(), scene->triangle_count(), bounds,
                                    cam, ms));
      if (hello_->hold_scene) send_sources(*scene);
      find_facts(state);
    }
    if (state_ == State::Draining && !work_in_flight()) fail(kShuttingDown, {});
  }

  // The scene's facts on the load pool, beside the frames (which go without them until they are
  // there): where their search fits half of render_memory_bytes (counted before, 512 B a
  // triangle), within the load's time limit, and kept where the session's budget has room for
  // them beside the scene (frame::SceneState::find_facts). A scene diced every frame (surfaces)
  // has none.
  void find_facts(const std::shared_ptr<frame::SceneState>& state) {
    if (state->scene()->has_surfaces()) return;
    net::post(srv_.load_pool, [self = shared_from_this(), state] {
      const Limits& L = self->srv_.cfg.limits;
      const Clock::time_point t0 = Clock::now();
      if (!state->find_facts(L.render_memory_bytes, L.render_time_limit_s, L.max_session_bytes))
        return;
      {
        std::lock_guard lk(self->cam_mu_);
        if (self->scene_ != state) return;  // (another scene came meanwhile)
      }
      self->srv_.log.info("scene_facts", {{"session", self->session_},
                                          {"triangles", state->scene()->triangle_count()},
                                          {"ms", ms_since(t0)}});
    });
  }

  // A delta session whose client holds the scene (protocol version 3, hold_scene): the scene's
  // sources once, right after scene_ready and before any frame of it (proto/DELTA.md, "Sources
  // message"). Made here on the strand: a few ms for the bunny, ~0.2 s for the dragon.
  void send_sources(const Scene& scene) {
    auto bytes =
        std::make_shared<const std::string>(encode_delta_sources(scene, hello_->compression));
    send_text(json{{"type", "sources"}, {"bytes", bytes->size()}}.dump());
    send(Out{bytes, true, false});
  }

  void on_camera(const CameraRequest& c) {
    if (state_ == State::Draining) throw ProtoError(code::shutting_down, "server is stopping");
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
    if (frame_ != FramePhase::Idle || state_ != State::Open) return;
    {
      std::lock_guard lk(cam_mu_);
      if (!latest_) return;
    }
    frame_ = FramePhase::Rendering;
    srv_.queue.submit(session_, [self = shared_from_this()](Renderer* r) { self->render(r); });
  }

  // What a frame carries from the render worker to the encoder and the strand.
  struct FrameJob {
    frame::FrameSpec spec;
    uint64_t seq = 0, skipped = 0;
    double queue_ms = 0;
    frame::RenderedFrame rendered;
  };

  // The frame's spec: the session's scene and camera, its hello's output and tolerances, the
  // server's limits (one time limit for the frame from here: core/frame/frame.h).
  frame::FrameSpec frame_spec(std::shared_ptr<frame::SceneState> state, Camera cam) const {
    const Hello& h = *hello_;
    const Limits& L = srv_.cfg.limits;
    frame::FrameSpec spec;
    spec.started = Clock::now();
    spec.camera = cam;
    spec.output = output_;
    spec.tolerance_px = h.tolerance_px;
    spec.implicit_tolerance_px = h.implicit_tolerance_px;
    spec.time_limit_s = L.render_time_limit_s;
    spec.memory_budget = L.render_memory_bytes;
    // The session's Loop plans hold at most what max_session_bytes leaves besides the scene
    // (issue 35, case 6: six sessions' plans took the server from 2.6 to 8.6 GB for good).
    const uint64_t held = state->scene_bytes();
    spec.loop_plan_bytes = L.max_session_bytes > held ? L.max_session_bytes - held : 1;
    // The facts found on the load pool, or none (a frame never searches for them).
    spec.facts = frame::FactsPolicy::Found;
    spec.before_render = srv_.cfg.before_render;
    spec.scene = std::move(state);
    return spec;
  }

  // Runs on a render worker. Returns as soon as the planar map is built: the Renderer goes back
  // to the queue and the lines and the encoding are done on the encode pool.
  void render(Renderer* renderer) {
    FrameJob job;
    CameraRequest req;
    Clock::time_point queued;
    std::shared_ptr<frame::SceneState> state;
    Camera cam;
    {
      std::lock_guard lk(cam_mu_);
      req = *latest_;
      latest_.reset();
      state = scene_;
      cam = base_camera_;
      queued = latest_at_;
      job.skipped = skipped_;
      skipped_ = 0;
    }
    job.seq = req.seq;
    job.queue_ms = ms_since(queued);
    const std::string scene_name = state->scene()->source;
    try {
      if (!renderer) throw DeviceError("no render device: " + srv_.queue.device_error());
      bool keep_near_far = req.near_plane || req.far_plane;
      req.apply_to(cam);
      if (!keep_near_far) cam.near_plane = cam.far_plane = 0;
      fit_near_far(cam, *state->scene());
      cam.validate();
      job.spec = frame_spec(std::move(state), cam);
      job.rendered = frame::render_frame(*renderer, job.spec);
    } catch (...) {
      return frame_failed(error_reply(std::current_exception(), "rendering", nullptr, scene_name),
                          job.seq);
    }
    srv_.encodes_in_flight++;
    net::post(srv_.encode_pool, [self = shared_from_this(), job = std::move(job)]() mutable {
      self->encode(std::move(job));
      self->srv_.encodes_in_flight--;
    });
  }

  // Runs on the encode pool; the session's encoder is used by one frame at a time.
  void encode(FrameJob job) {
    const Format format = hello_->format;
    auto payload = std::make_shared<std::string>();
    std::string header;
    uint64_t held = 0;
    try {
      frame::Frame f = frame::finish_frame(std::move(job.rendered), job.spec, *encoder_);
      const double encode_ms = f.lines_ms + f.encode_ms;  // (the lines count as encoding)
      const RenderStats& st = f.rendered.stats;
      *payload = std::move(f.encoded.bytes);
      header = frame_message({job.seq, format, payload->size(), st.pipeline_ms, encode_ms,
                              job.queue_ms, st.input_triangles, f.rendered.map.fragment_count(),
                              st.buckets, job.skipped},
                             f.encoded.header);
      srv_.metrics.render_ms(st.pipeline_ms + encode_ms);
      srv_.metrics.encode_ms(format, encode_ms);
      held = st.peak_device_bytes;
    } catch (...) {
      return frame_failed(error_reply(std::current_exception(), "encoding the frame"), job.seq);
    }
    job = {};  // the map's memory goes before the frame is queued for writing
    net::post(ws_.get_executor(),
              [self = shared_from_this(), payload, header = std::move(header), held] {
                self->peak_bytes_ = std::max(self->peak_bytes_, held);
                self->on_frame_ready(payload, header);
              });
  }

  void frame_failed(ErrorReply err, uint64_t seq) {
    if (spike(err)) srv_.trim_memory();
    net::post(ws_.get_executor(), [self = shared_from_this(), err = std::move(err), seq] {
      self->frame_ = FramePhase::Idle;
      if (!self->accepting_messages()) return;
      self->fail(err, seq);
      self->after_frame();
    });
  }

  void on_frame_ready(const std::shared_ptr<std::string>& frame, const std::string& header) {
    if (!accepting_messages()) {
      frame_ = FramePhase::Idle;
      return;
    }
    frame_ = FramePhase::Sending;
    send_text(header);
    send(Out{frame, format_spec(hello_->format).binary, true, hello_->format});
  }

  void after_frame() {
    if (state_ == State::Draining && !loading_) return fail(kShuttingDown, {});
    kick();
  }

  void send_text(std::string s) {
    send(Out{std::make_shared<const std::string>(std::move(s)), false, false});
  }

  // Queues a message; the front of out_ is the one being written.
  void send(Out o) {
    if (!accepting_messages()) return;
    out_.push_back(std::move(o));
    if (out_.size() == 1) do_write();
  }

  void do_write() {
    ws_.binary(out_.front().binary);
    ws_.async_write(net::buffer(*out_.front().data),
                    beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
  }

  void on_write(beast::error_code ec, size_t bytes) {
    if (ec) {
      if (out_.front().frame_payload) frame_ = FramePhase::Idle;
      out_.clear();
      return finish("write: " + ec.message());
    }
    if (out_.front().frame_payload) {
      srv_.metrics.frames++;
      srv_.metrics.bytes_sent += bytes;
      srv_.metrics.frame_sent(out_.front().format, bytes);
      peak_bytes_ = std::max<uint64_t>(peak_bytes_, bytes + encoder_->state_bytes());
      frame_ = FramePhase::Idle;
      after_frame();  // may send(): it only queues, the front is still this message
    }
    out_.pop_front();
    if (!out_.empty()) return do_write();
    note_send_done();
    if (state_ == State::Flushing) return do_close();
    do_read();
  }

  // Sends an error; a fatal one closes the session after everything queued is flushed.
  void fail(const ErrorReply& err, std::optional<uint64_t> seq) {
    if (!accepting_messages()) return;
    srv_.metrics.error(err.code);
    srv_.log.warn("error", {{"session", session_},
                            {"peer", peer_},
                            {"code", err.code},
                            {"message", err.message},
                            {"fatal", err.fatal}});
    send_text(error_json(err.code, err.message, err.fatal, seq));
    if (!err.fatal) return;
    close_code_ = close_code_for(err.code);
    state_ = State::Flushing;  // on_write calls do_close once the queue is flushed
    if (out_.empty()) do_close();
  }

  void do_close() {
    if (state_ != State::Flushing) return;
    state_ = State::Closing;
    hello_timer_.cancel();
    idle_timer_.cancel();
    ws_.async_close(
        websocket::close_reason(close_code_),
        [self = shared_from_this()](beast::error_code) { self->finish("closed_by_server"); });
  }

  // The session is over (peer closed, error, or our close finished). Idempotent.
  void finish(const std::string& reason) {
    hello_timer_.cancel();
    idle_timer_.cancel();
    if (state_ == State::Closed) return;
    state_ = State::Closed;
    if (session_) {
      srv_.queue.remove_session(session_);
      srv_.metrics.sessions_active--;
      srv_.log.info("session_close", {{"session", session_}, {"reason", reason}});
    }
    if (connection_) srv_.remove(connection_);
    if (peak_bytes_ >= kTrimAfterBytes) srv_.trim_memory();
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
  State state_ = State::Upgrading;
  FramePhase frame_ = FramePhase::Idle;
  bool loading_ = false;       // a scene load is on the load pool (at most one)
  bool read_pending_ = false;  // an async_read_some is in flight (paused under backpressure)
  uint64_t connection_ = 0;    // Server::Impl registry id, once upgraded
  uint64_t session_ = 0;       // RenderQueue session id; non-zero: holds a session slot
  std::optional<Hello> hello_;
  // How frames are written, and the format's encoder, made at hello; used on the encode pool by
  // one frame at a time (its state, if any, is bounded: frame::FrameEncoder).
  frame::OutputSpec output_;
  std::unique_ptr<frame::FrameEncoder> encoder_;
  std::optional<SceneRequest> upload_;
  std::deque<Out> out_;
  std::optional<uint64_t> discarded_;  // bytes of an over-limit message being dropped
  uint64_t idle_gen_ = 0;
  Clock::time_point last_active_;  // the client's last message or the send's last progress
  uint64_t last_acked_ = 0;        // the peer's acknowledged bytes at the last idle check
  bool send_tracked_ = false;      // the last look found bytes still on their way to the peer
  uint64_t peak_bytes_ = 0;  // largest message, frame, scene or frame's device memory
  websocket::close_code close_code_ = websocket::close_code::normal;

  // Shared with the render worker.
  std::mutex cam_mu_;
  // The session's scene and what is found once for it: its facts (found on the load pool after
  // scene_ready and given to every frame from then on, whichever renderer draws it) and its
  // Loop plans (charged to this session).
  std::shared_ptr<frame::SceneState> scene_;
  Camera base_camera_;
  std::optional<CameraRequest> latest_;
  Clock::time_point latest_at_;
  uint64_t skipped_ = 0;
};

}  // namespace

void start_ws_session(tcp::socket&& socket, http::request<http::string_body> req, Server::Impl& srv,
                      ConnectionSlot slot) {
  std::make_shared<WsSession>(std::move(socket), srv, std::move(slot))->run(std::move(req));
}

}  // namespace vismap::server
