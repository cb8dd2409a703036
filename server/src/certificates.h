// Certificates of training and evaluation: made when a licence is issued, from
// the exams that justify it, signed with the server's key and kept for ever; checked by anyone who
// has the number (GET /api/certificates/{number}, menu/web/verify.html). docs/exam-evidence.md
// has the design.
//
// A certificate's record (JSON, signed as stored; forklift/security/certificate.h):
//   {"format": "forklift-certificate/1", "number", "language", "school", "pupil": {"id", "name"},
//    "licence": {"id", "issued_at", "issued_by": person}, "evaluated_at", "reevaluation_due",
//    "reevaluation_rule", "theory": citation, "practical": [citation...],
//    "training": {"sessions", "truck_class", "first_at", "last_at", "list": [{"session", "at", "scenario", "mark", "title"}...]},
//    "statement", "issued_at"}
//   person:   {"id", "username", "name"} (the account's full name)
//   citation: {"exam_id", "kind", "taken_at", "score", "passed", "examiner": person, "record_sha256"}
//             (the exam record's row hashed as it was), a theory exam's with "correct", "total",
//             "pass_mark", a practical exam's with "session", "scenario", "course", "truck" and
//             "chain": {"seq", "entry_hash"} (its entry in the exam chain)
//   "language" (data/i18n/'s: "en", "es") is what the statement, course, truck and training titles
//   are worded in, and what its pages and checks are shown in; a record from before has none: "en".
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "context.h"
#include "exam_results.h"

namespace forklift::server {

// A new number: the school's initials (up to 4 letters; "FL" if it has none) and 80 random bits
// in Crockford's base32, in groups of four ("WS-7KQ2-M9XD-4HRT-PW3B"): too many to try one by one.
std::string new_certificate_number(const std::string& school_name);
// A number as someone typed it (small letters, spaces, O for 0, I or L for 1) as it is stored.
std::string canonical_certificate_number(const std::string& typed);

// The hash a certificate cites an exam record by: its row, every field, as stored.
std::string exam_row_sha256(const store::ExamRecord& e);

// What a licence rests on, and what is missing in words (empty when nothing is): a passed
// practical exam on an exam course whose evidence verifies (ExamResult::counts), and what the
// school's rules (LicenceRules) ask beside it: a theory pass recent enough, and marked training
// sessions on the practical exam's truck class.
struct TrainedSession {
  std::string session, at, scenario;  // its public id, when it was started, the scenario's name
  double mark = 0;
};
struct LicenceBasis {
  const ExamResult* theory = nullptr;
  std::vector<const ExamResult*> practical;  // the latest counted exam of each course
  std::vector<TrainedSession> training;      // the marked training sessions that count, oldest first
  std::string truck_class;                   // of the practical exams (empty before one counts)
  std::vector<std::string> missing;          // each item the record lacks, in words
  // "<pupil> cannot be licensed yet: <items>", or empty.
  std::string why_not;
};
LicenceBasis licence_basis(Context& ctx, const store::Pupil& pupil, const store::PupilHistory& h,
                           const std::vector<ExamResult>& results, const std::string& now);

// The record of a new certificate for `pupil`'s licence (issued by user `issued_by`), citing
// `basis`, in `language` (one of ctx.words'): the record says which, and its statement, course,
// truck and training are worded in it (English: the data files' words). Throws ApiError 409
// "full_name_missing" when a person it names has no full name on their account.
nlohmann::json certificate_record(Context& ctx, const store::Pupil& pupil, const LicenceBasis& basis,
                                  const store::LicenceRecord& licence, int64_t issued_by,
                                  const std::string& number, const std::string& school, const std::string& language);

// What a check of a stored certificate finds: "valid", "revoked" (whatever else holds), or
// "does_not_verify" (the record is not the one the school's server signed, or an exam it cites
// is not the exam recorded, its evidence does not verify or its pass was withdrawn).
struct CertificateCheck {
  std::string status;
  std::vector<std::string> checks;    // what held, in the certificate's language
  std::vector<std::string> problems;  // what did not
  nlohmann::json record;              // as stored, parsed (null if it does not parse)
  std::optional<store::CertificateRevocation> revocation;
};
CertificateCheck check_certificate(Context& ctx, const store::CertificateRecord& c);

// What the pages and the verification endpoint show: the number, the status and why, the record,
// the revocation (with who, when and why), and where to verify it: "verify_url" on the school's
// public address (ServerConfig::public_url; null without one: the page then uses its own).
nlohmann::json certificate_json(Context& ctx, const store::CertificateRecord& c, const CertificateCheck& check);

}  // namespace forklift::server
