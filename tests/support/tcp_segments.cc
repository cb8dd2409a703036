// Apart from loopback.h: the kernel's tcp_info (with the data segment counts) clashes with the
// older one in <netinet/tcp.h>, which httplib includes.
#include <linux/tcp.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include "support/loopback.h"

namespace forklift_test {

unsigned data_segments_in(int fd) {
  tcp_info info{};
  socklen_t len = sizeof info;
  return getsockopt(fd, IPPROTO_TCP, TCP_INFO, &info, &len) == 0 ? info.tcpi_data_segs_in : 0;
}

}  // namespace forklift_test
