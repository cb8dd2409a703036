// forklift-server's HTTP(S) listener: cpp-httplib's Server and SSLServer with every request read
// within fixed bounds, whatever its framing.
//
// Debian 12's cpp-httplib (0.11.4) bounds a body only by its Content-Length. A chunked body, a
// body with no length, one chunk-size line, the request line and each header line it keeps in
// memory for as long as the client sends (a 300 MB chunked body to /api/login took the server to
// 664 MB), and it inflates gzip, deflate and br bodies without limit. Here each byte httplib reads
// comes through a stream that allows a request kMaxHeadBytes of request line and headers, then
// the body its headers announce: at most kMaxBodyBytes with a Content-Length, twice that in
// chunks (their framing), none when they announce none. A request beyond these, with an
// ambiguous length or a compressed body is refused (Refusal) and its connection closed after the
// answer; before closing, what the client still sends is read and dropped (until it stops or is
// quiet for 2 s, for at most 30 s), so that a client that sends its whole body before reading
// (most do) still reads why. A request line past the allowance is closed unanswered.
//
// The listener's pre-routing and 100-continue handlers are its own: leave them.
//
// Its socket takes SO_REUSEADDR only, not httplib's default SO_REUSEPORT: with that, a second
// server bound the same port and the kernel split the connections between the two (and their
// databases); now the second one's bind fails.
#pragma once

#include <httplib.h>

#include <chrono>
#include <cstddef>
#include <string>

namespace forklift::server {

constexpr size_t kMaxHeadBytes = 64 << 10;  // a request's line and headers together
constexpr size_t kMaxBodyBytes = 1 << 20;   // a request's body, out of its chunks
constexpr size_t kKeepAliveRequests = 1000;  // requests on one connection before it is closed (or 5 s)

// Why the listener refused the request now being answered on this thread: the HTTP status, a
// code and words for the JSON error; nullptr when it refused nothing (or is not a listener's).
struct Refusal {
  int status;
  const char* code;
  const char* message;
};
const Refusal* request_refusal();

// A body past kMaxBodyBytes; the listener can count only a chunked body's bytes with its framing,
// so the API also checks the size of the body it was given.
extern const Refusal kBodyTooLarge;

// What the access log tells of the request now being answered on this thread: when its first
// byte came, and who it was authenticated as (empty: nobody). Reset for each request a listener
// reads; outside a listener's thread, a thread-local that nothing resets.
struct RequestNotes {
  std::chrono::steady_clock::time_point started;
  std::string user;
};
RequestNotes& request_notes();

// Plain HTTP.
class Listener : public httplib::Server {
 public:
  Listener();

 private:
  bool process_and_close_socket(socket_t sock) override;
};

// HTTPS with a PEM certificate (chain) and its private key; is_valid() is false if they do not load.
class TlsListener : public httplib::SSLServer {
 public:
  TlsListener(const std::string& cert_path, const std::string& key_path);

 private:
  bool process_and_close_socket(socket_t sock) override;
};

}  // namespace forklift::server
