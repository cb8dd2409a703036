// Tamper-evidence for practical exams, on the server's side: the exam record as the hash chain
// covers it, the chain's anchor outside the database, appending an ended exam to the chain once it
// agrees with its signed log, the evidence forklift-menu verify checks, and whether an exam's
// evidence holds, which history and the certificate require of a pass
// (security/include/forklift/security/evidence.h has the formats and the checks;
// docs/exam-evidence.md the design).
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "forklift/store/store.h"

namespace forklift::server {

// The chain's anchor: a file of one line per chain entry (the "anchor line" of evidence.h), appended
// as each entry is chained, outside the database, so that entries deleted from the end of the
// database's chain are seen (docs/exam-evidence.md: keep it where the database's writers cannot
// write). Thread-safe: the supervisor appends, HTTP threads read.
class ChainAnchor {
 public:
  // Reads the file; a missing file is an empty anchor. A line that does not parse is the torn end
  // of a write a crash cut short and is skipped; lines out of seq order make problem() say so.
  explicit ChainAnchor(std::string path);
  const std::string& path() const { return path_; }
  std::string problem() const;  // why the file cannot be trusted; empty when it can
  bool exists() const;          // the file was there, or has been written
  std::optional<nlohmann::json> head() const;
  std::optional<nlohmann::json> line(int64_t seq) const;
  std::optional<nlohmann::json> line_of(const std::string& session) const;
  // Appends `entry`'s anchor line, which must follow the head, and flushes it to disk before it
  // returns. Throws std::runtime_error on an I/O error or an entry out of order.
  void append(const nlohmann::json& entry);
  // Held while an entry goes into the database and then the anchor, and while both are read for
  // evidence: a reader between the two writes would see an anchor ahead of the database's chain.
  std::unique_lock<std::mutex> hold_chain() const { return std::unique_lock<std::mutex>(chain_mu_); }

 private:
  mutable std::mutex chain_mu_;
  const std::string path_;
  mutable std::mutex mu_;
  std::vector<nlohmann::json> lines_;  // lines_[i] is entry i + 1's
  std::map<std::string, int64_t> seq_of_session_;
  std::string problem_;
  bool exists_ = false;
  bool torn_tail_ = false;  // the file does not end with a newline: the next line starts on a new one
};

// What the server checks and signs the chain with.
struct ChainKeys {
  std::string server_key_file, server_cert_file;  // both empty: entries unsigned (no --security)
  std::string ca_pem, crl_pem;                    // the school's CA and CRL, as text; empty if none
};
// From the school's DDS Security folder (empty: no keys) and the server's identity in it; reads
// ca.pem and crl.pem (if there is one) now, so that a revocation counts from the next call.
ChainKeys chain_keys(const std::string& security_dir, const std::string& identity);

// The exam as the store holds it now: session, pupil (id and name), cab, scenario, mode, examiner
// (id and name), mark, passed, faults by kind, events (seq, kind, worry), the practical exam
// record's id, and the session's audit rows (their count, the last audit id of the pupil they were
// read up to, and a hash of the rows). Given the record of its chain entry, the audit log and the
// pupil's name are read as they stood when it was chained (up to that audit id, and a name
// edited since taken back through the audit log's "pupil_edited" rows); a record chained before
// names and the audit log were covered is made in that older form.
nlohmann::json exam_record(store::Store& db, const store::Session& s, const nlohmann::json* chained = nullptr);

enum class ChainResult {
  kAdded,
  kAlreadyChained,
  kNotReady,     // no score yet, or not ended: try again later
  kNotSignable,  // not an exam, or no signed log (a worker without an identity)
  kRefused,      // the record disagrees with its signed log or with the audit log: never chained as it is
  kChainBroken,  // the database's chain is not the anchored one: nothing can be chained onto it
};
struct ChainOutcome {
  ChainResult result = ChainResult::kNotSignable;
  std::string why;  // for kRefused and kChainBroken, in words for the school's admin
};

// Appends an ended exam to the chain and its anchor, once its record agrees with its signed log
// (the worker's signature by "worker.<cab>" under the school CA, and the log's session, cab, mode,
// mark, passed and events) and with the audit row of its start (pupil and examiner): its record,
// its log's hash and the worker's signature, linked to the previous entry and signed with the
// server's key. Not ready while the store holds fewer events than the log names, unless `anyway`.
ChainOutcome chain_exam(store::Store& db, const std::string& session, ChainAnchor& anchor, const ChainKeys& keys,
                        bool anyway = false);

// Makes a refusal to chain visible to the school: the session log "chain_refused" (the evidence
// and verify show it) and an audit row "exam_chain_refused" on the exam's pupil.
void record_chain_refusal(store::Store& db, const std::string& session, const std::string& why);

// The server's check at start of its database's chain against the anchor: the whole chain walked
// (seqs, links, hashes, server signatures) and holding the anchored head. Entries beyond the head
// (the server stopped between its two writes) are anchored now, as is a chain found without an
// anchor file (a database from before anchors). Returns the problem, empty if none; each exam the
// anchor names past the chain's end then gets an audit row "exam_chain_cut_short".
std::string check_chain_at_start(store::Store& db, ChainAnchor& anchor, const ChainKeys& keys);

// What `forklift-menu verify` checks, for any practical exam: the current record, the stored log
// and its signature, the whole chain, the anchor's head and the session's anchor line, and why it
// is not chained if it is not. Throws store::StoreError(kNotFound) for a session that is no exam.
nlohmann::json exam_evidence(store::Store& db, const store::Session& s, const ChainAnchor& anchor);

struct ExamStanding {
  bool verified = false;
  std::string why;  // when not verified, in words for the school
};
// Whether an exam's evidence holds, as history and the certificate count a pass: chained, the
// database's chain without a gap and ending at (or past) the anchor's head, the exam's entry the
// anchored one with its hash and server signature, its record the current record, and its signed
// log agreeing with it. The other entries are not walked (forklift-menu verify walks them all), so
// this costs the same in a chain of any length.
ExamStanding exam_standing(store::Store& db, const store::Session& s, const ChainAnchor& anchor, const ChainKeys& keys);

}  // namespace forklift::server
