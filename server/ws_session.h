// The WebSocket session of proto/PROTOCOL.md (ws_session.cpp): an explicit state machine on the
// connection's strand. Renders run on RenderQueue workers, encoding on the encode pool, scene
// parsing on the load pool; each posts its result back to the strand.
#pragma once

#include <boost/beast/http.hpp>

#include "server/server_impl.h"

namespace vismap::server {

// Takes over an upgrade request's connection: WebSocket handshake, then the session.
void start_ws_session(tcp::socket&& socket,
                      boost::beast::http::request<boost::beast::http::string_body> req,
                      Server::Impl& srv, ConnectionSlot slot);

}  // namespace vismap::server
