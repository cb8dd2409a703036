// The signature on a certificate of training and evaluation. The server signs
// the certificate's record, as it stores it, with its key; anyone holding the school CA's
// certificate (and its CRL) can check that the record is the one the school's server signed.
//
//   certificate signature: {"format":"forklift-certificate-signature/1","record_sha256",
//                           "server_signature","server_certificate"}, signing
//                          "forklift-certificate/1\n" record_sha256 "\n", where record_sha256 is
//                          the SHA-256 of the record's text exactly as stored
//
// Keys and certificates as in evidence.h: the server's identity (common name "server" or
// "server.*") under the school CA.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "forklift/security/evidence.h"

namespace forklift::security {

// The signature object for `record_text`, signed with the server's key; the certificate file's
// certificates are embedded as PEM. Throws std::runtime_error naming a file that cannot be read
// or a key that does not match its certificate.
nlohmann::json sign_certificate(const std::string& record_text, const std::string& server_key_file,
                                const std::string& server_cert_file);

// Whether `signature` signs `record_text`: its format and hash, the server's certificate
// (accepted by the school CA, not revoked by the CRL when one is given, named "server" or
// "server.*") and the signature over the hash. Never throws: every fault is a line in the report.
VerifyReport verify_certificate_signature(const std::string& record_text, const nlohmann::json& signature,
                                          const std::string& ca_pem, const std::string& crl_pem = "");

}  // namespace forklift::security
