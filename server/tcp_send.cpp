// The kernel's view of a TCP send (Linux): what the peer has acknowledged, and what is still in
// the send queue. A TU of its own: <linux/tcp.h> has TCP_INFO's byte counters, and clashes with
// glibc's older <netinet/tcp.h>, which Asio includes (clients/tcp_bytes.cpp does the same).
#include "server/tcp_send.h"

#include <linux/sockios.h>
#include <linux/tcp.h>
#include <netinet/in.h>
#include <sys/ioctl.h>
#include <sys/socket.h>

#include <cstddef>
#include <cstdint>

namespace vismap::server {

TcpSendState tcp_send_state(int fd) {
  TcpSendState s;
  struct tcp_info info {};
  socklen_t len = sizeof info;
  if (::getsockopt(fd, IPPROTO_TCP, TCP_INFO, &info, &len) == 0 &&
      len >= offsetof(struct tcp_info, tcpi_bytes_acked) + sizeof info.tcpi_bytes_acked)
    s.acked = info.tcpi_bytes_acked;
  int queued = 0;  // SIOCOUTQ: bytes written and not yet acknowledged (sent or not)
  if (::ioctl(fd, SIOCOUTQ, &queued) == 0 && queued > 0) s.queued = static_cast<uint64_t>(queued);
  return s;
}

}  // namespace vismap::server
