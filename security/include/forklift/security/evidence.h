// Tamper-evidence for licence exam records. The sim worker signs each session's control log (<log>.sig);
// the server appends every exam to a hash chain, optionally server-signed, and anchors each new head in a
// file outside the database; anyone holding the school CA's certificate can then check one session's
// evidence end to end (docs/exam-evidence.md says what each part guards against).
//
//   log signature: {"format":"forklift-exam-log-signature/1","session","cab","log_sha256","signature",
//                   "signer_certificate"}, signing "forklift-exam-log/1\n" session "\n" cab "\n" log_sha256 "\n"
//   chain entry:   {"seq" (from 1),"session","record","log_sha256","log_signature","prev_hash" (64 zeros first),
//                   "entry_hash","server_signature" (signs the ASCII entry_hash) | null,"server_certificate" | null}
//                  entry_hash = sha256_hex(prev_hash "\n" record.dump() "\n" log_sha256 "\n" log_signature "\n")
//   anchor line:   {"format":"forklift-exam-chain-anchor/1","seq","session","entry_hash","server_signature"}, one
//                  per chain entry, in seq order: the entry's own hash and server signature, kept where the
//                  database's writer cannot reach, so that a chain cut short is told from a whole one
//   evidence:      {"session","record","log" (control log text),"signature" (log signature),"chain" (all entries,
//                   or from "chain_from" on),"anchor":{"head": the newest anchor line | null,
//                   "entry": the session's anchor line | null}}
//
// Keys are ECDSA P-256 (RSA is accepted too) in unencrypted PEM files; certificates are X.509 PEM issued
// by the school's CA. Signatures are over SHA-256 (OpenSSL EVP_DigestSign), carried in base64.
// Functions that read key or certificate files throw std::runtime_error naming the file and the reason;
// the verify_ functions never throw: every fault, malformed input included, is a line in their report.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>
#include <utility>

#include <nlohmann/json.hpp>

namespace forklift::security {

// The whole of a file these checks read (a CA, a CRL, an anchor); throws std::runtime_error
// naming `what` and the path.
std::string read_text_file(const std::string& path, const std::string& what);

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

// The anchor line of a chain entry (made by make_chain_entry); throws if the entry lacks its fields.
nlohmann::json chain_anchor_line(const nlohmann::json& entry);

enum class Verdict {
  kVerified,    // no problem
  kNotChained,  // the session has no chain entry, and neither the chain nor its anchor shows a sign of tampering
  kTampered,    // anything else: a changed record or log, a broken, cut short or rewritten chain
};

struct VerifyReport {
  bool ok = false;                    // problems.empty()
  Verdict verdict = Verdict::kTampered;
  std::vector<std::string> passed;    // one line per check that held
  // A certificate's checks that held as (what, the value it names), for words in another language
  // (verify_certificate_signature alone): "record_signed" (the SHA-256), "signer_ca", "signer_server"
  // (the signer's name), "signature".
  std::vector<std::pair<std::string, std::string>> passed_codes;
  std::vector<std::string> problems;  // one line per check that failed, naming what differs
};

struct VerifyOptions {
  // An entry the server did not sign is a problem: without the server's key, a rewritten chain
  // re-hashed from the start would otherwise pass.
  bool require_server_signatures = false;
  // Evidence without an anchor, or a chain with no anchored head, is a problem: without it, a chain
  // whose last entries were deleted cannot be told from a whole one.
  bool require_anchor = false;
};

// Checks one session's evidence against the school CA (and its CRL, if given): the log's signature
// and signer, the log against the record, the chain (its seqs without a gap, links, hashes and server
// signatures) and the anchor (the chain holds the anchored head, and the session's anchored entry).
// A "chain_from" k > 1 gives the chain from seq k on: the links before it are not checked, so the
// anchor's lines must then fall inside it.
VerifyReport verify_exam_evidence(const nlohmann::json& evidence, const std::string& ca_pem,
                                  const std::string& crl_pem = "", VerifyOptions options = {});

// The checks of an exam record against its signed log alone, which need no chain: the signature
// ("signature") verifies with a certificate of the school CA for the record's cab's worker
// ("worker.<cab>") over the log's hash, and the log says the record's session, cab, mode, mark,
// passed and events. The server runs them before it chains an exam.
VerifyReport verify_record_against_log(const nlohmann::json& record, const std::string& log,
                                       const nlohmann::json& signature, const std::string& ca_pem,
                                       const std::string& crl_pem = "");

// The checks of one session's log against its signature alone: the signature names `session` and
// `cab`, is over this log's SHA-256 and verifies with a certificate of the school CA (not revoked
// by the CRL when one is given) whose common name is the cab's worker ("worker.<cab>"). The server
// runs them on every log a worker host brings back, training as well as exam: a host relays the
// worker's files, it cannot author them under another identity.
VerifyReport verify_log_signature(const std::string& session, const std::string& cab, const std::string& log,
                                  const nlohmann::json& signature, const std::string& ca_pem,
                                  const std::string& crl_pem = "");

// The checks of a whole chain (from seq 1) and its anchor {"head": line | null}, with no session in
// view: the server's check of its database's chain at start.
VerifyReport verify_chain(const nlohmann::json& chain, const nlohmann::json& anchor, const std::string& ca_pem,
                          const std::string& crl_pem = "", VerifyOptions options = {});

}  // namespace forklift::security
