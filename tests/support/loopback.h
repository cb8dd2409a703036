// A raw TCP connection to a test server on 127.0.0.1, for tests that must see the bytes of HTTP
// (framing, keep-alive) rather than a client library's view of them.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

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

// One kept-alive HTTP/1.1 connection: each ask() sends a whole request and reads its whole answer,
// the head and then its Content-Length body (none after a HEAD request's).
class KeptConnection {
 public:
  KeptConnection(int port, int timeout_s) : fd_(connect_loopback(port, timeout_s)) {}
  ~KeptConnection() {
    if (fd_ >= 0) close(fd_);
  }
  KeptConnection(const KeptConnection&) = delete;
  KeptConnection& operator=(const KeptConnection&) = delete;

  // The answer's head; "" once the connection is gone or if the answer has no Content-Length.
  std::string ask(const std::string& request, bool head_only = false) {
    if (fd_ < 0 || send(fd_, request.data(), request.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(request.size())) return "";
    size_t end;
    while ((end = got_.find("\r\n\r\n")) == std::string::npos)
      if (!receive()) return "";
    const std::string head = got_.substr(0, end);
    const size_t at = head.find("Content-Length: ");
    if (at == std::string::npos) return "";
    const size_t whole = end + 4 + (head_only ? 0 : std::strtoul(head.c_str() + at + 16, nullptr, 10));
    while (got_.size() < whole)
      if (!receive()) return "";
    got_.erase(0, whole);
    return head;
  }
  unsigned data_segments_in() const { return forklift_test::data_segments_in(fd_); }

 private:
  bool receive() {
    char buf[64 << 10];
    const ssize_t n = recv(fd_, buf, sizeof buf, 0);
    if (n <= 0) return false;
    got_.append(buf, static_cast<size_t>(n));
    return true;
  }

  int fd_;
  std::string got_;
};

// Whether an answer's head tells the client to close the connection.
inline bool says_close(const std::string& head) { return head.find("Connection: close") != std::string::npos; }

}  // namespace forklift_test
