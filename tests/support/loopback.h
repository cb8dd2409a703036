// A raw TCP connection to a test server on 127.0.0.1, for tests that must see the bytes of HTTP
// (framing, keep-alive) rather than a client library's view of them.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace forklift_test {

// A connected socket with `timeout_s` on its reads and writes; -1 if nothing answers on `port`.
inline int connect_loopback(int port, int timeout_s) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const timeval timeout{timeout_s, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) return fd;
  close(fd);
  return -1;
}

// How many segments with data `fd` has received so far, as the kernel counts them (0 if it cannot
// say). In tcp_segments.cc, which a test using it compiles too.
unsigned data_segments_in(int fd);

}  // namespace forklift_test
