// How far a TCP send has got, from the kernel (Linux TCP_INFO and SIOCOUTQ): the session's idle
// timer counts from the end of the server's last send, which is when the peer has acknowledged
// its last byte, not when the write call returned into the socket's buffer (ws_session.cpp).
#pragma once

#include <cstdint>

namespace vismap::server {

struct TcpSendState {
  uint64_t acked = 0;   // bytes the peer has acknowledged over the connection's life
  uint64_t queued = 0;  // bytes written to the socket and not acknowledged yet
};

// Zeroes where the kernel does not tell (not a TCP socket, or a kernel before 4.1).
TcpSendState tcp_send_state(int fd);

}  // namespace vismap::server
