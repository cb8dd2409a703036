#include "crypto.h"

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509_vfy.h>

#include <climits>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace forklift::security::detail {

namespace {

using StorePtr = std::unique_ptr<X509_STORE, Deleter<X509_STORE_free>>;
using StoreCtxPtr = std::unique_ptr<X509_STORE_CTX, Deleter<X509_STORE_CTX_free>>;
using MdCtxPtr = std::unique_ptr<EVP_MD_CTX, Deleter<EVP_MD_CTX_free>>;
struct CertStackFree {
  void operator()(STACK_OF(X509) * s) const noexcept { sk_X509_pop_free(s, X509_free); }
};
using CertStackPtr = std::unique_ptr<STACK_OF(X509), CertStackFree>;

// A read-only memory BIO over `text` (which must outlive it).
BioPtr memory_bio(std::string_view text) {
  if (text.size() > static_cast<size_t>(INT_MAX)) throw std::runtime_error("PEM text too large");
  BioPtr bio(BIO_new_mem_buf(text.data(), static_cast<int>(text.size())));
  if (!bio) throw std::runtime_error("out of memory: " + openssl_error());
  return bio;
}

// Refuses passphrases: the default callback would prompt on the terminal of a server or worker.
int no_passphrase(char*, int, int, void*) { return 0; }

bool supported_key(EVP_PKEY* key) {
  const int type = EVP_PKEY_get_base_id(key);
  return type == EVP_PKEY_EC || type == EVP_PKEY_RSA;
}

}  // namespace

std::string openssl_error() {
  std::string out;
  while (const unsigned long e = ERR_get_error()) {
    char buf[256];
    ERR_error_string_n(e, buf, sizeof buf);
    if (!out.empty()) out += "; ";
    out += buf;
  }
  return out.empty() ? "no OpenSSL reason given" : out;
}

std::string read_file(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + what + " file '" + path + "'");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw std::runtime_error("error reading " + what + " file '" + path + "'");
  return s.str();
}

std::vector<X509Ptr> parse_certificates(std::string_view pem) {
  std::vector<X509Ptr> certs;
  if (pem.empty()) return certs;
  BioPtr bio = memory_bio(pem);
  while (X509Ptr c{PEM_read_bio_X509(bio.get(), nullptr, no_passphrase, nullptr)}) certs.push_back(std::move(c));
  ERR_clear_error();  // the read that ends the loop always queues "no start line"
  return certs;
}

PkeyPtr parse_private_key(std::string_view pem, const std::string& what) {
  BioPtr bio = memory_bio(pem);
  PkeyPtr key(PEM_read_bio_PrivateKey(bio.get(), nullptr, no_passphrase, nullptr));
  if (!key) throw std::runtime_error(what + " is not an unencrypted PEM private key (" + openssl_error() + ")");
  if (!supported_key(key.get())) throw std::runtime_error(what + " is neither an EC nor an RSA key");
  return key;
}

std::string to_pem(const std::vector<X509Ptr>& certs) {
  BioPtr bio(BIO_new(BIO_s_mem()));
  if (!bio) throw std::runtime_error("out of memory: " + openssl_error());
  for (const X509Ptr& c : certs)
    if (PEM_write_bio_X509(bio.get(), c.get()) != 1) throw std::runtime_error("cannot write PEM: " + openssl_error());
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  return std::string(data, static_cast<size_t>(n));
}

std::string base64_encode(std::string_view bytes) {
  if (bytes.size() > static_cast<size_t>(INT_MAX / 2)) throw std::runtime_error("too much data to encode");
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<int>(bytes.size()));
  out.resize(static_cast<size_t>(n));
  return out;
}

std::optional<std::string> base64_decode(std::string_view text) {
  // EVP_DecodeBlock skips blanks and counts padding as zero bytes: check the shape here, trim after.
  if (text.size() % 4 != 0 || text.size() > static_cast<size_t>(INT_MAX / 2)) return std::nullopt;
  size_t pad = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const bool alpha =
        (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/';
    if (c == '=') {
      if (i + 2 < text.size()) return std::nullopt;
      ++pad;
    } else if (!alpha || pad) {
      return std::nullopt;
    }
  }
  std::string out(3 * (text.size() / 4), '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(text.data()), static_cast<int>(text.size()));
  if (n < 0 || static_cast<size_t>(n) < pad) return std::nullopt;
  out.resize(static_cast<size_t>(n) - pad);
  return out;
}

bool is_hex_sha256(std::string_view s) {
  if (s.size() != 64) return false;
  for (const char c : s)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

std::string sign_sha256(EVP_PKEY* key, std::string_view message) {
  MdCtxPtr ctx(EVP_MD_CTX_new());
  size_t len = 0;
  const auto* msg = reinterpret_cast<const unsigned char*>(message.data());
  if (!ctx || EVP_DigestSignInit(ctx.get(), nullptr, EVP_sha256(), nullptr, key) != 1 ||
      EVP_DigestSign(ctx.get(), nullptr, &len, msg, message.size()) != 1)
    throw std::runtime_error("cannot sign: " + openssl_error());
  std::string sig(len, '\0');
  if (EVP_DigestSign(ctx.get(), reinterpret_cast<unsigned char*>(sig.data()), &len, msg, message.size()) != 1)
    throw std::runtime_error("cannot sign: " + openssl_error());
  sig.resize(len);
  return sig;
}

bool verify_sha256(EVP_PKEY* key, std::string_view message, std::string_view signature, std::string* why) {
  if (!supported_key(key)) {
    if (why) *why = "the certificate's key is neither EC nor RSA";
    return false;
  }
  MdCtxPtr ctx(EVP_MD_CTX_new());
  if (!ctx || EVP_DigestVerifyInit(ctx.get(), nullptr, EVP_sha256(), nullptr, key) != 1) {
    if (why) *why = "cannot start verifying: " + openssl_error();
    return false;
  }
  const int rc = EVP_DigestVerify(ctx.get(), reinterpret_cast<const unsigned char*>(signature.data()), signature.size(),
                                  reinterpret_cast<const unsigned char*>(message.data()), message.size());
  if (rc != 1) {
    const std::string reason = openssl_error();  // always drain, so the next call starts clean
    if (why) *why = rc == 0 ? "the signature does not match" : "the signature is malformed (" + reason + ")";
    return false;
  }
  return true;
}

std::string common_name(X509* cert) {
  X509_NAME* name = X509_get_subject_name(cert);
  const int i = name ? X509_NAME_get_index_by_NID(name, NID_commonName, -1) : -1;
  if (i < 0) throw std::runtime_error("the certificate's subject has no common name");
  if (X509_NAME_get_index_by_NID(name, NID_commonName, i) >= 0)
    throw std::runtime_error("the certificate's subject has several common names");
  unsigned char* utf8 = nullptr;
  const int n = ASN1_STRING_to_UTF8(&utf8, X509_NAME_ENTRY_get_data(X509_NAME_get_entry(name, i)));
  if (n < 0) throw std::runtime_error("the certificate's common name is not text: " + openssl_error());
  std::string cn(reinterpret_cast<char*>(utf8), static_cast<size_t>(n));
  OPENSSL_free(utf8);
  return cn;
}

bool chains_to_ca(const std::vector<X509Ptr>& chain, const std::string& ca_pem, const std::string& crl_pem,
                  std::string* why) {
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    ERR_clear_error();
    return false;
  };
  if (chain.empty()) return fail("no certificate");
  const std::vector<X509Ptr> cas = parse_certificates(ca_pem);
  if (cas.empty()) return fail("the CA PEM holds no certificate");
  StorePtr store(X509_STORE_new());
  if (!store) return fail("out of memory");
  for (const X509Ptr& ca : cas)
    if (X509_STORE_add_cert(store.get(), ca.get()) != 1)
      return fail("cannot use the CA certificate: " + openssl_error());
  if (!crl_pem.empty()) {
    BioPtr bio = memory_bio(crl_pem);
    int crls = 0;
    while (X509CrlPtr crl{PEM_read_bio_X509_CRL(bio.get(), nullptr, no_passphrase, nullptr)}) {
      if (X509_STORE_add_crl(store.get(), crl.get()) != 1) return fail("cannot use the CRL: " + openssl_error());
      ++crls;
    }
    ERR_clear_error();
    if (crls == 0) return fail("the CRL PEM holds no CRL");
    X509_STORE_set_flags(store.get(), X509_V_FLAG_CRL_CHECK);  // the leaf's issuer must have a CRL in it
  }
  CertStackPtr untrusted(sk_X509_new_null());
  if (!untrusted) return fail("out of memory");
  for (size_t i = 1; i < chain.size(); ++i) {
    if (sk_X509_push(untrusted.get(), chain[i].get()) <= 0) return fail("out of memory");
    X509_up_ref(chain[i].get());  // the stack's deleter frees its own references
  }
  StoreCtxPtr ctx(X509_STORE_CTX_new());
  if (!ctx || X509_STORE_CTX_init(ctx.get(), store.get(), chain[0].get(), untrusted.get()) != 1)
    return fail("cannot start verifying: " + openssl_error());
  if (X509_verify_cert(ctx.get()) != 1) return fail(X509_verify_cert_error_string(X509_STORE_CTX_get_error(ctx.get())));
  return true;
}

Signer load_signer(const std::string& key_file, const std::string& cert_file, const std::string& who) {
  Signer s;
  {
    std::string pem = read_file(key_file, who + " key");
    struct Wipe {  // the key's text should not linger in freed memory
      std::string& s;
      ~Wipe() { OPENSSL_cleanse(s.data(), s.size()); }
    } wipe{pem};
    s.key = parse_private_key(pem, who + " key file '" + key_file + "'");
  }
  s.certs = parse_certificates(read_file(cert_file, who + " certificate"));
  if (s.certs.empty()) throw std::runtime_error(who + " certificate file '" + cert_file + "' holds no PEM certificate");
  if (EVP_PKEY_eq(X509_get0_pubkey(s.certs[0].get()), s.key.get()) != 1) {
    openssl_error();  // drain
    throw std::runtime_error(who + " key file '" + key_file + "' does not match the certificate in '" + cert_file +
                             "'");
  }
  return s;
}

}  // namespace forklift::security::detail
