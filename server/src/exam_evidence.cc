#include "exam_evidence.h"

#include "forklift/security/evidence.h"

namespace forklift::server {

using nlohmann::json;

namespace {

// Events the worker published, as its log lists them: "e" (the evaluation's) and "w" (its own).
size_t logged_events(const std::string& log) {
  size_t n = 0;
  for (size_t at = 0; at < log.size();) {
    if (log.compare(at, 2, "e ") == 0 || log.compare(at, 2, "w ") == 0) ++n;
    const size_t nl = log.find('\n', at);
    at = nl == std::string::npos ? log.size() : nl + 1;
  }
  return n;
}

}  // namespace

json exam_record(store::Store& db, const store::Session& s) {
  json r = {{"session", s.public_id}, {"pupil_id", s.pupil_id}, {"cab", s.cab_id}, {"scenario", s.scenario},
            {"mode", s.mode}, {"state", s.state}, {"ended_at", s.ended_at},
            {"examiner_id", s.examiner_id ? json(*s.examiner_id) : json(nullptr)}, {"examiner", nullptr},
            {"mark", nullptr}, {"passed", nullptr}, {"counts", json::object()}, {"exam_id", nullptr}};
  if (s.examiner_id)
    if (const auto u = db.get_user(*s.examiner_id)) r["examiner"] = u->username;
  if (const auto sc = db.get_score(s.public_id)) {
    r["mark"] = sc->mark;
    r["passed"] = sc->passed;
    r["counts"] = sc->counts;
  }
  json events = json::array();
  for (const auto& e : db.list_events(s.public_id)) events.push_back({{"seq", e.seq}, {"kind", e.kind}, {"worry", e.worry_level}});
  r["events"] = events;
  if (const auto h = db.history(s.pupil_id, store::now_iso8601()))
    for (const auto& x : h->exams)
      if (x.session_public_id == s.public_id) {
        r["exam_id"] = x.id;
        r["exam_passed"] = x.passed;
        r["exam_mark"] = x.score;
      }
  return r;
}

ChainResult chain_exam(store::Store& db, const std::string& session, const std::string& server_key_file,
                       const std::string& server_cert_file, bool anyway) {
  const auto s = db.get_session(session);
  if (!s || s->mode != "exam") return ChainResult::kNotSignable;
  if (db.get_chain_entry(session)) return ChainResult::kAlreadyChained;
  const auto sig_text = db.get_session_log(session, "signature");
  if (!sig_text || sig_text->empty()) return ChainResult::kNotSignable;
  // The supervisor asks again every 50 ms while the score is on its way: the log is read only after.
  if (!store::is_terminal(s->state) || !db.get_score(session)) return ChainResult::kNotReady;
  const auto log = db.get_session_log(session, "control");
  if (!log) return ChainResult::kNotSignable;
  if (!anyway && db.list_events(session).size() < logged_events(*log)) return ChainResult::kNotReady;
  const json sig = json::parse(*sig_text);
  const auto last = db.last_chain_entry();
  const int64_t seq = last ? last->seq + 1 : 1;
  const std::string prev = last ? json::parse(last->entry).at("entry_hash").get<std::string>() : std::string(64, '0');
  const json entry = security::make_chain_entry(seq, prev, exam_record(db, *s), security::sha256_hex(*log),
                                                sig.at("signature").get<std::string>(), server_key_file, server_cert_file);
  db.append_chain_entry({seq, session, entry.dump()});
  return ChainResult::kAdded;
}

json exam_evidence(store::Store& db, const store::Session& s) {
  if (!db.get_chain_entry(s.public_id))
    throw store::StoreError(store::StoreError::kNotFound, "session " + s.public_id + " is not a chained exam");
  json chain = json::array();
  for (const auto& e : db.list_chain()) chain.push_back(json::parse(e.entry));
  const auto sig = db.get_session_log(s.public_id, "signature");
  json signature = nullptr;
  try {
    if (sig) signature = json::parse(*sig);
  } catch (const json::exception&) {
    signature = *sig;  // a damaged file is the verifier's finding, not the server's error
  }
  return {{"session", s.public_id}, {"record", exam_record(db, s)}, {"log", db.get_session_log(s.public_id, "control").value_or("")},
          {"signature", signature}, {"chain", chain}};
}

}  // namespace forklift::server
