#include "forklift/security/certificate.h"

#include <stdexcept>

#include "crypto.h"

namespace forklift::security {

using nlohmann::json;
using namespace detail;

namespace {

constexpr const char* kFormat = "forklift-certificate-signature/1";

std::string message(const std::string& record_sha256) { return "forklift-certificate/1\n" + record_sha256 + "\n"; }

}  // namespace

json sign_certificate(const std::string& record_text, const std::string& server_key_file,
                      const std::string& server_cert_file) {
  const Signer s = load_signer(server_key_file, server_cert_file, "server");
  const std::string hash = sha256_hex(record_text);
  return {{"format", kFormat}, {"record_sha256", hash},
          {"server_signature", base64_encode(sign_sha256(s.key.get(), message(hash)))},
          {"server_certificate", to_pem(s.certs)}};
}

VerifyReport verify_certificate_signature(const std::string& record_text, const json& signature, const std::string& ca_pem,
                                          const std::string& crl_pem) {
  VerifyReport r;
  const auto ok = [&](const std::string& code, const std::string& value, const std::string& line) {
    r.passed.push_back(line);
    r.passed_codes.emplace_back(code, value);
  };
  const auto bad = [&](const std::string& line) { r.problems.push_back(line); };
  try {
    const auto text = [&](const char* key) -> const std::string* {
      if (!signature.is_object() || !signature.contains(key) || !signature[key].is_string()) return nullptr;
      return signature[key].get_ptr<const std::string*>();
    };
    const std::string *format = text("format"), *hash = text("record_sha256"), *sig = text("server_signature"),
                      *pem = text("server_certificate");
    if (!format || *format != kFormat || !hash || !sig || !pem) {
      bad("the certificate's signature is not a " + std::string(kFormat) + " object with its hash, signature and certificate");
    } else {
      const std::string actual = sha256_hex(record_text);
      if (actual == *hash) ok("record_signed", actual, "the record is the one signed (SHA-256 " + actual + ")");
      else bad("the record was changed after it was signed: its SHA-256 is " + actual + ", the signature is over " + *hash);
      const std::vector<X509Ptr> certs = parse_certificates(*pem);
      std::string why;
      if (certs.empty()) {
        bad("the signer's certificate is not a PEM certificate");
      } else {
        if (chains_to_ca(certs, ca_pem, crl_pem, &why)) ok("signer_ca", "", "the signer's certificate is the school CA's, and not revoked");
        else bad("the signer's certificate is not accepted by the school CA: " + why);
        std::string cn;
        try { cn = common_name(certs[0].get()); } catch (const std::exception& e) { bad(e.what()); }
        if (cn == "server" || cn.rfind("server.", 0) == 0) ok("signer_server", cn, "signed by the school's server (" + cn + ")");
        else if (!cn.empty()) bad("the signer is " + cn + ", not the school's server (\"server\" or \"server.*\")");
        const PkeyPtr key(X509_get_pubkey(certs[0].get()));
        const auto raw = base64_decode(*sig);
        if (!key || !raw) bad("the signature or the signer's key cannot be read");
        else if (verify_sha256(key.get(), message(*hash), *raw, &why)) ok("signature", "", "the server's signature verifies");
        else bad("the server's signature does not verify: " + why);
      }
    }
  } catch (const std::exception& e) {
    bad(std::string("the certificate could not be checked: ") + e.what());
  }
  openssl_error();  // drain
  r.ok = r.problems.empty();
  r.verdict = r.ok ? Verdict::kVerified : Verdict::kTampered;
  return r;
}

}  // namespace forklift::security
