// Tamper-evidence for licence exam records. The sim worker signs each session's control log (<log>.sig);
// the server appends every exam to a hash chain, optionally server-signed; anyone holding the school CA's
// certificate can then check one session's evidence end to end.
//
//   log signature: {"format":"forklift-exam-log-signature/1","session","cab","log_sha256","signature",
//                   "signer_certificate"}, signing "forklift-exam-log/1\n" session "\n" cab "\n" log_sha256 "\n"
//   chain entry:   {"seq" (from 1),"session","record","log_sha256","log_signature","prev_hash" (64 zeros first),
//                   "entry_hash","server_signature" (signs the ASCII entry_hash) | null,"server_certificate" | null}
//                  entry_hash = sha256_hex(prev_hash "\n" record.dump() "\n" log_sha256 "\n" log_signature "\n")
//   evidence:      {"session","record","log" (control log text),"signature" (log signature),"chain" (all entries)}
//
// Keys are ECDSA P-256 (RSA is accepted too) in unencrypted PEM files; certificates are X.509 PEM issued
// by the school's CA. Signatures are over SHA-256 (OpenSSL EVP_DigestSign), carried in base64.
// Functions that read key or certificate files throw std::runtime_error naming the file and the reason;
// verify_exam_evidence never throws: every fault, malformed input included, is a line in its report.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace forklift::security {

// Lower-case hex SHA-256 of `bytes`.
std::string sha256_hex(std::string_view bytes);

// The log signature object (format "forklift-exam-log-signature/1") for one session's control log, signed
// with the worker's key; the certificate file's certificates are embedded as PEM.
nlohmann::json sign_exam_log(const std::string& session, const std::string& cab, const std::string& log_text,
                             const std::string& key_pem_file, const std::string& cert_pem_file);

// One hash-chain entry for `record` (whose "session" must be a string) after the entry whose entry_hash is
// `prev_hash` (64 zeros for seq 1). An empty `server_key_file` leaves the entry unsigned (nulls).
nlohmann::json make_chain_entry(int64_t seq, const std::string& prev_hash, const nlohmann::json& record,
                                const std::string& log_sha256, const std::string& log_signature_b64,
                                const std::string& server_key_file, const std::string& server_cert_file);

// The subject common name of the first certificate in `cert_pem`; throws if there is none or several.
std::string certificate_common_name(const std::string& cert_pem);

// True if the first certificate in `cert_pem` (any further ones are untrusted intermediates) chains to a
// certificate in `ca_pem`, is valid now and, if `crl_pem` is not empty, is not revoked by it. On false,
// `why` (if given) says why. Never throws: unreadable PEM is a false.
bool certificate_issued_by(const std::string& cert_pem, const std::string& ca_pem, const std::string& crl_pem,
                           std::string* why);

struct VerifyReport {
  bool ok = false;                    // problems.empty()
  std::vector<std::string> passed;    // one line per check that held
  std::vector<std::string> problems;  // one line per check that failed, naming what differs
};

// Checks one session's evidence {"session","record","log","signature","chain"} against the school CA (and
// its CRL, if given): the log's signature and signer, the log against the record, and the chain.
// With require_server_signatures, an entry the server did not sign is a problem: without the
// server's key, a rewritten chain re-hashed from the start would otherwise pass.
VerifyReport verify_exam_evidence(const nlohmann::json& evidence, const std::string& ca_pem,
                                  const std::string& crl_pem = "", bool require_server_signatures = false);

}  // namespace forklift::security
