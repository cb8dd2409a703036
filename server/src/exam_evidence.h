// Tamper-evidence for practical exams, on the server's side: the exam record as the hash chain
// covers it, appending an ended exam to the chain, and the evidence forklift-menu verify checks
// (security/include/forklift/security/evidence.h has the formats and the checks).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "forklift/store/store.h"

namespace forklift::server {

// The exam as the store holds it now: session, pupil, cab, scenario, examiner, mark, passed,
// faults by kind, events (seq, kind, worry) and the practical exam record's id.
nlohmann::json exam_record(store::Store& db, const store::Session& s);

enum class ChainResult {
  kAdded,
  kAlreadyChained,
  kNotReady,     // no score yet, or not ended: try again later
  kNotSignable,  // not an exam, or no signed log (a worker without an identity)
};

// Appends an ended exam to the chain: its record, its log's hash and the worker's signature,
// linked to the previous entry and signed with the server's key (both files empty: unsigned).
// Not ready while the store holds fewer events than the log names, unless `anyway` (the verifier
// will then report the difference).
ChainResult chain_exam(store::Store& db, const std::string& session, const std::string& server_key_file,
                       const std::string& server_cert_file, bool anyway = false);

// What `forklift-menu verify` checks: the current record, the stored log and its signature, and
// the whole chain. Throws store::StoreError(kNotFound) if the session has no chain entry.
nlohmann::json exam_evidence(store::Store& db, const store::Session& s);

}  // namespace forklift::server
