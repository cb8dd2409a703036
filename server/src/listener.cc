// The listener's connections: httplib's own request parser and handlers, fed by a stream that
// counts what each request may still read (see forklift/server/listener.h).
#include "forklift/server/listener.h"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <openssl/ssl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <strings.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <functional>
#include <optional>

namespace forklift::server {

namespace {

using Clock = std::chrono::steady_clock;

constexpr size_t kChunkedBodyBytes = 2 * kMaxBodyBytes;  // chunk framing may add as much as the data
// What a refused client still sends is read for at most kLingerFor (nginx's lingering_time), and
// no longer once it has sent nothing for kLingerQuiet.
constexpr auto kLingerFor = std::chrono::seconds(30);
constexpr auto kLingerQuiet = std::chrono::seconds(2);
constexpr int kPollSliceMs = 100;  // how often a wait looks whether the server is stopping
// A connection serves at most kKeepAliveRequests, and none begun after it has lived kKeepAliveFor:
// each holds one of httplib's few threads while it lives, so a page polling every second (the
// fleet's, a session's) must hand its thread back as often as when httplib closed it after 5
// requests, while a client asking back to back reuses its connection (about 17 % more history
// requests a second: forklift-bench-server).
constexpr auto kKeepAliveFor = std::chrono::seconds(5);

const Refusal kHeadTooLarge{431, "too_large", "the request's line and headers are larger than 64 KiB"};
const Refusal kAmbiguousLength{400, "bad_request",
                               "the body's length is ambiguous: send one Content-Length, or Transfer-Encoding: chunked"};
const Refusal kBadLength{400, "bad_request", "Content-Length must be a whole number of bytes"};
const Refusal kUnknownCoding{501, "not_implemented", "the only Transfer-Encoding understood is chunked"};
const Refusal kCompressed{415, "compressed", "compressed bodies are not accepted: send it without Content-Encoding"};

// What the server lets each of its connections do, from its settings.
struct Settings {
  const std::atomic<socket_t>& server_sock;  // INVALID_SOCKET once the server is stopping
  size_t keep_alive_max_count;
  time_t keep_alive_timeout_s;
  int write_timeout_ms;
};

using ProcessRequest =
    std::function<bool(httplib::Stream&, bool last, bool& closed, const std::function<void(httplib::Request&)>& setup)>;

// Waits up to `timeout_ms` for `sock` to be readable (or writable); false on timeout or error.
bool wait_for(socket_t sock, short events, int timeout_ms) {
  pollfd p{sock, events, 0};
  int r;
  while ((r = ::poll(&p, 1, timeout_ms)) < 0 && errno == EINTR) {}
  return r > 0;
}

// SIGPIPE held back on this thread while it writes to a TLS connection, and one raised dropped:
// OpenSSL writes with write(2), which raises it when the client has gone, and its default action
// ends the process (forklift-server happens to run with it ignored; the listener does not count
// on that).
class NoSigpipe {
 public:
  NoSigpipe() {
    sigemptyset(&pipe_);
    sigaddset(&pipe_, SIGPIPE);
    sigset_t pending;
    sigpending(&pending);
    was_pending_ = sigismember(&pending, SIGPIPE) == 1;
    pthread_sigmask(SIG_BLOCK, &pipe_, &old_);
  }
  ~NoSigpipe() {
    sigset_t pending;
    sigpending(&pending);
    if (!was_pending_ && sigismember(&pending, SIGPIPE) == 1) {
      const timespec now{};
      sigtimedwait(&pipe_, nullptr, &now);
    }
    pthread_sigmask(SIG_SETMASK, &old_, nullptr);
  }
  NoSigpipe(const NoSigpipe&) = delete;
  NoSigpipe& operator=(const NoSigpipe&) = delete;

 private:
  sigset_t pipe_, old_;
  bool was_pending_ = false;
};

// ---------------------------------------------------------------- transports

// One connection's bytes, plain or TLS. Reads and writes block at most the server's read and
// write timeouts (httplib sets them on each accepted socket). Destroying it closes the socket.
class Transport {
 public:
  explicit Transport(socket_t sock) : sock_(sock) {}
  virtual ~Transport() {
    ::shutdown(sock_, SHUT_RDWR);
    ::close(sock_);
  }
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  virtual ssize_t receive(char* p, size_t n) = 0;  // 0: the client closed; -1: error or timeout
  virtual ssize_t send(const char* p, size_t n) = 0;
  virtual bool has_pending() const { return false; }  // bytes received but not yet read
  virtual void end_writes() { ::shutdown(sock_, SHUT_WR); }
  socket_t sock() const { return sock_; }

 protected:
  socket_t sock_;
};

class PlainTransport final : public Transport {
 public:
  using Transport::Transport;
  ssize_t receive(char* p, size_t n) override {
    ssize_t r;
    while ((r = ::recv(sock_, p, n, 0)) < 0 && errno == EINTR) {}
    return r;
  }
  ssize_t send(const char* p, size_t n) override {
    ssize_t r;
    while ((r = ::send(sock_, p, n, MSG_NOSIGNAL)) < 0 && errno == EINTR) {}
    return r;
  }
};

class TlsTransport final : public Transport {
 public:
  TlsTransport(socket_t sock, SSL_CTX* ctx) : Transport(sock), ssl_(SSL_new(ctx)) {
    if (!ssl_ || SSL_set_fd(ssl_, sock) != 1) return;
    const NoSigpipe guard;
    usable_ = SSL_accept(ssl_) == 1;
  }
  ~TlsTransport() override {
    if (!ssl_) return;
    if (usable_) end_tls();
    SSL_free(ssl_);
  }

  bool handshaken() const { return usable_; }
  SSL* ssl() const { return ssl_; }

  ssize_t receive(char* p, size_t n) override {
    const int r = SSL_read(ssl_, p, static_cast<int>(std::min<size_t>(n, 1 << 30)));
    if (r > 0) return r;
    return failed(r) == SSL_ERROR_ZERO_RETURN ? 0 : -1;
  }
  ssize_t send(const char* p, size_t n) override {
    const NoSigpipe guard;
    const int r = SSL_write(ssl_, p, static_cast<int>(std::min<size_t>(n, 1 << 30)));
    if (r > 0) return r;
    failed(r);
    return -1;
  }
  bool has_pending() const override { return SSL_pending(ssl_) > 0; }
  void end_writes() override {
    end_tls();
    Transport::end_writes();
  }

 private:
  // After a fatal error OpenSSL may not send close_notify (SSL_shutdown's manual).
  int failed(int r) {
    const int e = SSL_get_error(ssl_, r);
    if (e == SSL_ERROR_SYSCALL || e == SSL_ERROR_SSL) usable_ = false;
    return e;
  }
  void end_tls() {
    if (!usable_) return;
    const NoSigpipe guard;
    SSL_shutdown(ssl_);
    usable_ = false;
  }

  SSL* ssl_;
  bool usable_ = false;  // handshaken, no fatal error, close_notify not yet sent
};

// ---------------------------------------------------------------- one connection

// The stream httplib parses: the transport's bytes through a read-ahead buffer kept across the
// connection's requests, and an allowance of what the current request may still read. Past its
// allowance a read records the phase's refusal and fails; with no refusal it reads as the end.
class BoundedStream final : public httplib::Stream {
 public:
  BoundedStream(Transport& t, const Settings& s, std::optional<Refusal>& refusal) : t_(t), s_(s), refusal_(refusal) {}

  void allow(size_t bytes, const Refusal* past, bool skip_unread) {
    allowance_ = bytes;
    past_ = past;
    skip_unread_ = skip_unread;
  }
  bool failed() const { return failed_; }

  // Waits, while the server runs, up to its keep-alive timeout for the next request.
  bool wait_for_request() const {
    if (begin_ < end_ || t_.has_pending()) return true;
    const auto until = Clock::now() + std::chrono::seconds(s_.keep_alive_timeout_s);
    while (s_.server_sock != INVALID_SOCKET && Clock::now() < until)
      if (wait_for(t_.sock(), POLLIN, kPollSliceMs)) return true;
    return false;
  }

  // Reads and drops what is left of a Content-Length body nobody read (httplib reads none of a
  // GET's), so that the next request starts where it should. False if that fails.
  bool skip_unread_body() {
    std::array<char, 4096> sink;
    while (skip_unread_ && allowance_ > 0)
      if (read(sink.data(), sink.size()) <= 0) return false;
    return true;
  }

  bool is_readable() const override { return begin_ < end_ || t_.has_pending() || wait_for(t_.sock(), POLLIN, 0); }
  bool is_writable() const override { return wait_for(t_.sock(), POLLOUT, s_.write_timeout_ms); }

  ssize_t read(char* p, size_t n) override {
    if (!flush()) return -1;  // "100 Continue" before the body is read
    if (allowance_ == 0) {
      if (!past_) return 0;
      if (!refusal_) refusal_ = *past_;
      failed_ = true;
      return -1;
    }
    if (begin_ == end_) {
      const ssize_t got = t_.receive(buffer_.data(), buffer_.size());
      if (got <= 0) {
        failed_ = true;
        return got;
      }
      begin_ = 0;
      end_ = static_cast<size_t>(got);
    }
    const size_t k = std::min({n, allowance_, end_ - begin_});
    std::memcpy(p, buffer_.data() + begin_, k);
    begin_ += k;
    allowance_ -= k;
    return static_cast<ssize_t>(k);
  }

  // httplib writes an answer's head apart from its body. The head waits here and leaves with the
  // body: one segment (one TLS record) and one system call an answer instead of two. Whatever is
  // held leaves before the stream reads, and when httplib is done with a request (serve: flush).
  ssize_t write(const char* p, size_t n) override {
    if (held_.size() + n <= kHoldBytes) {
      held_.append(p, n);
      return static_cast<ssize_t>(n);
    }
    if (held_.empty() || n > kJoinBytes) return flush() ? t_.send(p, n) : -1;
    held_.append(p, n);
    return flush() ? static_cast<ssize_t>(n) : -1;
  }

  // Sends all that is held; false (and the stream failed) if the connection fails.
  bool flush() {
    for (size_t sent = 0; sent < held_.size();) {
      const ssize_t r = t_.send(held_.data() + sent, held_.size() - sent);
      if (r <= 0) {
        failed_ = true;
        held_.clear();
        return false;
      }
      sent += static_cast<size_t>(r);
    }
    held_.clear();
    return true;
  }

  // Asked for every request; a connection's two ends do not change, so asked of the socket once.
  void get_remote_ip_and_port(std::string& ip, int& port) const override { address(getpeername, remote_, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address(getsockname, local_, ip, port); }
  socket_t socket() const override { return t_.sock(); }

 private:
  struct Address {
    std::string ip;
    int port = 0;
  };
  void address(int (*name)(int, sockaddr*, socklen_t*), std::optional<Address>& known, std::string& ip, int& port) const {
    if (!known) {
      sockaddr_storage a{};
      socklen_t len = sizeof a;
      char host[NI_MAXHOST], serv[NI_MAXSERV];
      if (name(t_.sock(), reinterpret_cast<sockaddr*>(&a), &len) != 0 ||
          getnameinfo(reinterpret_cast<sockaddr*>(&a), len, host, sizeof host, serv, sizeof serv, NI_NUMERICHOST | NI_NUMERICSERV) != 0)
        return;
      known = Address{host, std::atoi(serv)};
    }
    ip = known->ip;
    port = known->port;
  }

  Transport& t_;
  const Settings& s_;
  std::optional<Refusal>& refusal_;
  std::array<char, 16 << 10> buffer_;
  size_t begin_ = 0, end_ = 0;
  static constexpr size_t kHoldBytes = 4 << 10;   // a head; more goes at once
  static constexpr size_t kJoinBytes = 64 << 10;  // a body copied behind the head; a larger one sent apart
  std::string held_;
  mutable std::optional<Address> remote_, local_;
  size_t allowance_ = 0;
  const Refusal* past_ = nullptr;
  bool skip_unread_ = false;
  bool failed_ = false;
};

// A request's body as its headers announce it: the stream's allowance for it, or a refusal.
struct Framing {
  size_t bytes = 0;
  const Refusal* past = nullptr;  // past `bytes`: chunked bodies only
  bool skip_unread = false;       // a Content-Length body
  const Refusal* refusal = nullptr;
};

// A Content-Length of digits only (httplib reads "-1" and "1e9" as numbers), capped at any
// number past kMaxBodyBytes; nullopt when it is no whole number.
std::optional<size_t> parse_length(const std::string& text) {
  if (text.empty() || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) return std::nullopt;
  return text.size() > 18 ? kMaxBodyBytes + 1 : static_cast<size_t>(std::stoull(text));
}

Framing framing_of(const httplib::Request& req) {
  Framing f;
  const size_t lengths = req.get_header_value_count("Content-Length"), codings = req.get_header_value_count("Transfer-Encoding");
  const std::string encoding = req.get_header_value("Content-Encoding");
  if (lengths > 1 || codings > 1 || (lengths && codings)) {
    f.refusal = &kAmbiguousLength;
  } else if ((lengths || codings) && !encoding.empty() && strcasecmp(encoding.c_str(), "identity") != 0) {
    f.refusal = &kCompressed;  // httplib would inflate it with no limit
  } else if (codings) {
    if (strcasecmp(req.get_header_value("Transfer-Encoding").c_str(), "chunked") != 0) f.refusal = &kUnknownCoding;
    f.bytes = kChunkedBodyBytes;
    f.past = &kBodyTooLarge;
  } else if (lengths) {
    const auto n = parse_length(req.get_header_value("Content-Length"));
    if (!n) f.refusal = &kBadLength;
    else if (*n > kMaxBodyBytes) f.refusal = &kBodyTooLarge;
    else f.bytes = *n, f.skip_unread = true;
  }  // else no body (RFC 9112, 6.3), where httplib would read a POST's until the client closes
  if (f.refusal) f = Framing{0, nullptr, false, f.refusal};
  return f;
}

// httplib reads a chunked body only for these; any other's chunks would be read as requests.
bool reads_chunks(const std::string& method) {
  return method == "POST" || method == "PUT" || method == "PATCH" || method == "PRI";
}

struct Connection;
thread_local Connection* t_connection = nullptr;  // the one this thread serves, for request_refusal()

struct Connection {
  Connection(Transport& t, const Settings& s) : stream(t, s, refusal) { t_connection = this; }
  ~Connection() { t_connection = nullptr; }
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  std::optional<Refusal> refusal;  // of the current request
  RequestNotes notes;              // of the current request
  bool close_after = false;        // the stream is out of step with the requests
  BoundedStream stream;
};

// After a refusal the client may still be sending what was refused: reads and drops it (keeping
// none) until the client stops or goes quiet, so that the socket is not closed with unread bytes,
// which resets the connection before the client has read the answer.
void linger(Transport& t, const Settings& s) {
  t.end_writes();
  std::array<char, 64 << 10> sink;
  const auto until = Clock::now() + kLingerFor;
  auto quiet_until = Clock::now() + kLingerQuiet;
  while (s.server_sock != INVALID_SOCKET) {
    const auto now = Clock::now();
    if (now >= until || now >= quiet_until) return;
    const ssize_t n = ::recv(t.sock(), sink.data(), sink.size(), MSG_DONTWAIT);
    if (n > 0) {
      quiet_until = Clock::now() + kLingerQuiet;
    } else if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
      return;
    } else {
      wait_for(t.sock(), POLLIN, kPollSliceMs);
    }
  }
}

// httplib's keep-alive loop (process_server_socket_core) over one bounded stream.
bool serve(Transport& t, const Settings& s, const ProcessRequest& process,
           const std::function<void(httplib::Request&)>& setup = nullptr) {
  Connection c(t, s);
  bool ok = false;
  const auto retire_at = Clock::now() + kKeepAliveFor;
  for (size_t left = s.keep_alive_max_count; left > 0 && s.server_sock != INVALID_SOCKET; --left) {
    if (!c.stream.wait_for_request()) break;
    c.refusal.reset();
    c.notes = RequestNotes{Clock::now(), {}};
    c.stream.allow(kMaxHeadBytes, &kHeadTooLarge, false);
    bool closed = false;
    const bool last = left == 1 || c.notes.started >= retire_at;  // answered with "Connection: close"
    ok = process(c.stream, last, closed, [&](httplib::Request& req) {
      const Framing f = framing_of(req);
      c.stream.allow(f.bytes, f.past, f.skip_unread);
      if (f.refusal) c.refusal = *f.refusal;
      if (f.past && !reads_chunks(req.method)) c.close_after = true;
      if (setup) setup(req);
    });
    if (!c.stream.flush()) ok = false;
    if (last || !ok || closed || c.refusal || c.close_after || c.stream.failed() || !c.stream.skip_unread_body()) break;
  }
  if (c.refusal || c.close_after) linger(t, s);
  return ok;
}

// SO_REUSEADDR, so that a restarted server binds while its old connections linger in TIME_WAIT;
// not SO_REUSEPORT (httplib's default), which lets a second server listen on the same port. And
// TCP_NODELAY, which the connections inherit: the port is bound before the API sets httplib's own
// flag, and without it every answer of a kept-alive connection waited ~40 ms for the client's
// delayed ACK (Nagle), holding the server to some 140 requests a second.
void reuse_address_only(socket_t sock) {
  const int yes = 1;
  setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  setsockopt(sock, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
}

// Answers a refused request without reading its body or routing it; the API's error handler
// words it (request_refusal()); and binds its port alone.
void refuse_before_routing(httplib::Server& svr) {
  svr.set_socket_options(reuse_address_only);
  svr.set_pre_routing_handler([](const httplib::Request&, httplib::Response& res) {
    const Refusal* r = request_refusal();
    if (!r) return httplib::Server::HandlerResponse::Unhandled;
    res.status = r->status;
    return httplib::Server::HandlerResponse::Handled;
  });
  // A client that waits for "100 Continue" before its body gets the refusal instead.
  svr.set_expect_100_continue_handler([](const httplib::Request&, httplib::Response& res) {
    const Refusal* r = request_refusal();
    if (!r) return 100;
    res.status = r->status;
    return r->status;
  });
  svr.set_payload_max_length(kMaxBodyBytes);
}

}  // namespace

const Refusal kBodyTooLarge{413, "too_large", "the body is larger than 1 MiB"};

const Refusal* request_refusal() {
  return t_connection && t_connection->refusal ? &*t_connection->refusal : nullptr;
}

RequestNotes& request_notes() {
  thread_local RequestNotes elsewhere;
  return t_connection ? t_connection->notes : elsewhere;
}

Listener::Listener() { refuse_before_routing(*this); }

bool Listener::process_and_close_socket(socket_t sock) {
  PlainTransport t(sock);
  const Settings s{svr_sock_, keep_alive_max_count_, keep_alive_timeout_sec_,
                   static_cast<int>(write_timeout_sec_ * 1000 + write_timeout_usec_ / 1000)};
  return serve(t, s, [this](auto& strm, bool last, bool& closed, const auto& setup) { return process_request(strm, last, closed, setup); });
}

TlsListener::TlsListener(const std::string& cert_path, const std::string& key_path)
    : httplib::SSLServer(cert_path.c_str(), key_path.c_str()) {
  refuse_before_routing(*this);
}

bool TlsListener::process_and_close_socket(socket_t sock) {
  TlsTransport t(sock, ssl_context());
  if (!t.handshaken()) return false;
  const Settings s{svr_sock_, keep_alive_max_count_, keep_alive_timeout_sec_,
                   static_cast<int>(write_timeout_sec_ * 1000 + write_timeout_usec_ / 1000)};
  return serve(t, s, [this](auto& strm, bool last, bool& closed, const auto& setup) { return process_request(strm, last, closed, setup); },
               [ssl = t.ssl()](httplib::Request& req) { req.ssl = ssl; });
}

}  // namespace forklift::server
