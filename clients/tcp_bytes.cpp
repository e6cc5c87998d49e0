// TCP_INFO's byte counters (Linux >= 4.1), in a TU of their own: glibc's <netinet/tcp.h>, which
// Asio includes, has an older struct tcp_info without them, and <linux/tcp.h> clashes with it.
#include <linux/tcp.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstddef>
#include <cstdint>

namespace vismap::client {

uint64_t tcp_bytes_received(int fd) {
  struct tcp_info info {};
  socklen_t len = sizeof info;
  if (::getsockopt(fd, IPPROTO_TCP, TCP_INFO, &info, &len) != 0 ||
      len < offsetof(struct tcp_info, tcpi_bytes_received) + sizeof info.tcpi_bytes_received)
    return 0;
  return info.tcpi_bytes_received;
}

}  // namespace vismap::client
