// libcrypto behind RAII handles and a few string-in, string-out helpers. Private to forklift_security.
#pragma once

#include <openssl/bio.h>
#include <openssl/evp.h>
#include <openssl/x509.h>

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace forklift::security::detail {

template <auto Free>
struct Deleter {
  template <class T>
  void operator()(T* p) const noexcept {
    Free(p);
  }
};
using BioPtr = std::unique_ptr<BIO, Deleter<BIO_free>>;
using X509Ptr = std::unique_ptr<X509, Deleter<X509_free>>;
using X509CrlPtr = std::unique_ptr<X509_CRL, Deleter<X509_CRL_free>>;
using PkeyPtr = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY_free>>;

// The reasons OpenSSL queued for the last failure (and clears the queue, which is per thread).
std::string openssl_error();

// The whole file; throws std::runtime_error naming `what` and `path`.
std::string read_file(const std::string& path, const std::string& what);

// Every certificate in `pem`, in order; empty if none parses.
std::vector<X509Ptr> parse_certificates(std::string_view pem);
// An unencrypted PEM private key, EC or RSA; throws std::runtime_error naming `what`.
PkeyPtr parse_private_key(std::string_view pem, const std::string& what);
std::string to_pem(const std::vector<X509Ptr>& certs);

std::string base64_encode(std::string_view bytes);
// Strict: the standard alphabet with padding, no whitespace; nullopt on anything else.
std::optional<std::string> base64_decode(std::string_view text);
bool is_hex_sha256(std::string_view s);  // 64 lower-case hex digits

// A key and the certificate(s) that go with it, read from their files and checked to belong
// together; throws std::runtime_error naming `who` ("worker", "server") and the files.
struct Signer {
  PkeyPtr key;
  std::vector<X509Ptr> certs;
};
Signer load_signer(const std::string& key_file, const std::string& cert_file, const std::string& who);

// SHA-256 with the key's own scheme: ECDSA (DER) or RSA PKCS#1 v1.5. sign throws on failure.
std::string sign_sha256(EVP_PKEY* key, std::string_view message);
bool verify_sha256(EVP_PKEY* key, std::string_view message, std::string_view signature, std::string* why);

// The subject's single common name; throws std::runtime_error if it has none or several.
std::string common_name(X509* cert);
// Whether chain[0] chains to a certificate in `ca_pem` (chain[1..] untrusted intermediates), checked now
// and against the CRLs in `crl_pem` when that is not empty.
bool chains_to_ca(const std::vector<X509Ptr>& chain, const std::string& ca_pem, const std::string& crl_pem,
                  std::string* why);

}  // namespace forklift::security::detail
