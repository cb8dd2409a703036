#include "exam_evidence.h"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "forklift/security/evidence.h"
#include "forklift/session/log_records.h"
#include "forklift/session/vocabulary.h"

namespace forklift::server {

using nlohmann::json;

namespace {

const store::Actor kServer{std::nullopt, "server"};

// Events the worker published, as its log lists them: "e" (the evaluation's) and "w" (its own);
// a torn line is the verifier's finding, not an event.
size_t logged_events(const std::string& log) { return read_log_facts(log, LogReading::kTolerant).events.size(); }

// Stored JSON text as JSON; text that does not parse as itself, for the verifier to report.
json parsed(const std::string& text) {
  json j = json::parse(text, nullptr, false);
  return j.is_discarded() ? json(text) : j;
}

// A report's problems as one sentence, the first few of them.
std::string problems_text(const std::vector<std::string>& problems) {
  constexpr size_t kShown = 3;
  std::string out;
  for (size_t i = 0; i < std::min(problems.size(), kShown); ++i) out += (i ? "; " : "") + problems[i];
  if (problems.size() > kShown) out += "; and " + std::to_string(problems.size() - kShown) + " more";
  return out;
}

// The session's rows of the audit log and the pupil's name, as they stood at audit id `last_id`.
struct SessionAudit {
  int64_t last_id = 0;  // the pupil's newest audit id read up to
  json rows = json::array();  // the session's rows (those naming it), oldest first
  std::string pupil_name;
  std::optional<size_t> started;  // the index in rows of its "session_started" row, if any
};

SessionAudit session_audit(store::Store& db, const store::Session& s, std::optional<int64_t> up_to) {
  constexpr int kPage = 500;
  std::vector<store::AuditRecord> all;  // the pupil's rows, newest first
  for (int offset = 0;; offset += kPage) {
    std::vector<store::AuditRecord> page = db.list_audit({s.pupil_id, std::nullopt}, kPage, offset);
    all.insert(all.end(), page.begin(), page.end());
    if (static_cast<int>(page.size()) < kPage) break;
  }
  SessionAudit a;
  a.last_id = up_to ? *up_to : all.empty() ? 0 : all.front().id;
  const auto p = db.get_pupil(s.pupil_id);
  a.pupil_name = p ? p->name : "";
  bool walked_back = true;  // the name so far is the current one taken back through audited edits
  const auto edited_name = [](const json& d, const char* side) {
    const json* v = d.is_object() && d.contains(side) && d[side].is_object() && d[side].contains("name") ? &d[side]["name"] : nullptr;
    return v && v->is_string() ? std::optional(v->get<std::string>()) : std::nullopt;
  };
  for (const store::AuditRecord& r : all) {
    const json d = json::parse(r.details, nullptr, false);
    if (r.id > a.last_id) {
      // An edit since, newest first: the name before it is the one the chain saw. A name changed
      // outside the API breaks the walk back (the edit's "after" is not the name found), and the
      // name found then stays, to differ from the chained one.
      if (r.action != "pupil_edited" || !walked_back) continue;
      const auto before = edited_name(d, "before"), after = edited_name(d, "after");
      if (before && after && *after == a.pupil_name) a.pupil_name = *before;
      else if (before && after) walked_back = false;
      continue;
    }
    if (!d.is_object() || d.value("session", json()) != s.public_id) continue;
    a.rows.push_back({{"id", r.id}, {"at", r.at}, {"actor", r.actor.name},
                      {"actor_user_id", r.actor.user_id ? json(*r.actor.user_id) : json(nullptr)},
                      {"pupil_id", r.pupil_id}, {"action", r.action}, {"details", d}});
  }
  std::reverse(a.rows.begin(), a.rows.end());
  for (size_t i = 0; i < a.rows.size(); ++i)
    if (a.rows[i]["action"] == "session_started") a.started = i;
  return a;
}

json make_record(store::Store& db, const store::Session& s, const SessionAudit* audit) {
  json r = {{"session", s.public_id}, {"pupil_id", s.pupil_id}, {"cab", s.cab_id}, {"scenario", s.scenario},
            {"mode", name(s.mode)}, {"state", name(s.state)}, {"ended_at", s.ended_at},
            {"examiner_id", s.examiner_id ? json(*s.examiner_id) : json(nullptr)}, {"examiner", nullptr},
            {"mark", nullptr}, {"passed", nullptr}, {"counts", json::object()}, {"exam_id", nullptr}};
  if (audit) {
    r["pupil"] = audit->pupil_name;
    r["audit"] = {{"rows", audit->rows.size()}, {"last_id", audit->last_id},
                  {"sha256", security::sha256_hex(audit->rows.dump(-1, ' ', false, json::error_handler_t::replace))}};
  }
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

// The audit row of the exam's start must name the pupil and the examiner the session names now:
// nothing in the signed log does.
std::vector<std::string> start_problems(const store::Session& s, const SessionAudit& a) {
  if (!a.started)
    return {"no audit row records this exam's start for pupil " + std::to_string(s.pupil_id) +
            ": the exam was moved to another pupil after it started, or its audit row was removed"};
  const json& by = a.rows[*a.started]["actor_user_id"];
  const json now = s.examiner_id ? json(*s.examiner_id) : json(nullptr);
  if (by != now)
    return {"the audit log says user " + by.dump() + " started this exam, but the session names examiner " +
            now.dump() + ": its examiner was changed after it started"};
  return {};
}

// Whether the database's chain ends where its anchor says (and has no gap): an entry added to a
// chain cut short would take a deleted entry's seq. Empty if it does.
std::string chain_head_problem(store::Store& db, const ChainAnchor& anchor) {
  if (std::string p = anchor.problem(); !p.empty()) return p;
  const auto last = db.last_chain_entry();
  const int64_t last_seq = last ? last->seq : 0;
  const int64_t count = db.count_chain_entries();
  if (count != last_seq)
    return "the database's exam chain has a gap: it holds " + std::to_string(count) + " entries up to entry " +
           std::to_string(last_seq) + ", so entries were deleted from it";
  const auto head = anchor.head();
  const int64_t head_seq = head ? (*head)["seq"].get<int64_t>() : 0;
  if (head_seq > last_seq)
    return "the database's exam chain ends at " + (last ? "entry " + std::to_string(last_seq) : std::string("no entry")) +
           " but its anchor (" + anchor.path() + ") records entry " + std::to_string(head_seq) + " (session " +
           (*head)["session"].get<std::string>() + "): entries were deleted from the end of the chain";
  if (last_seq > head_seq)
    return "the database's exam chain has entries past its anchor's head (entry " + std::to_string(head_seq) +
           " in " + anchor.path() + "), up to entry " + std::to_string(last_seq) +
           ": they are anchored when the server starts";
  if (last) {
    const json e = parsed(last->entry);
    if (!e.is_object() || e.value("entry_hash", json()) != (*head)["entry_hash"])
      return "the database's exam chain entry " + std::to_string(last_seq) + " is not the anchored one (" +
             anchor.path() + "): the chain was rewritten";
  }
  return "";
}

json anchor_json(const ChainAnchor& anchor, const std::string& session) {
  return {{"head", anchor.head().value_or(json(nullptr))}, {"entry", anchor.line_of(session).value_or(json(nullptr))}};
}

}  // namespace

ChainAnchor::ChainAnchor(std::string path) : path_(std::move(path)) {
  std::error_code ec;
  if (!std::filesystem::exists(path_, ec)) return;
  exists_ = true;
  std::string text;
  try {
    text = security::read_text_file(path_, "exam chain anchor");
  } catch (const std::exception& e) {
    problem_ = "the exam chain's anchor cannot be read: " + std::string(e.what());
    return;
  }
  torn_tail_ = !text.empty() && text.back() != '\n';
  std::istringstream in(text);
  int n = 0;
  for (std::string l; std::getline(in, l);) {
    ++n;
    const json j = json::parse(l, nullptr, false);
    if (!j.is_object() || !j.value("seq", json()).is_number_integer() || !j.value("session", json()).is_string() ||
        !j.value("entry_hash", json()).is_string())
      continue;  // torn by a crash mid-write: its entry is anchored again at the next start
    const int64_t seq = j["seq"].get<int64_t>();
    if (seq != static_cast<int64_t>(lines_.size()) + 1) {
      problem_ = "the exam chain's anchor " + path_ + " is damaged: its line " + std::to_string(n) + " is entry " +
                 std::to_string(seq) + ", expected entry " + std::to_string(lines_.size() + 1);
      return;
    }
    seq_of_session_[j["session"].get<std::string>()] = seq;
    lines_.push_back(j);
  }
}

std::string ChainAnchor::problem() const {
  std::lock_guard<std::mutex> lock(mu_);
  return problem_;
}

bool ChainAnchor::exists() const {
  std::lock_guard<std::mutex> lock(mu_);
  return exists_;
}

std::optional<json> ChainAnchor::head() const {
  std::lock_guard<std::mutex> lock(mu_);
  return lines_.empty() ? std::nullopt : std::optional(lines_.back());
}

std::optional<json> ChainAnchor::line(int64_t seq) const {
  std::lock_guard<std::mutex> lock(mu_);
  if (seq < 1 || seq > static_cast<int64_t>(lines_.size())) return std::nullopt;
  return lines_[seq - 1];
}

std::optional<json> ChainAnchor::line_of(const std::string& session) const {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = seq_of_session_.find(session);
  return it == seq_of_session_.end() ? std::nullopt : std::optional(lines_[it->second - 1]);
}

void ChainAnchor::append(const json& entry) {
  const json l = security::chain_anchor_line(entry);
  std::lock_guard<std::mutex> lock(mu_);
  if (!problem_.empty()) throw std::runtime_error(problem_);
  const int64_t seq = l["seq"].get<int64_t>();
  if (seq != static_cast<int64_t>(lines_.size()) + 1)
    throw std::runtime_error("the exam chain's anchor " + path_ + " ends at entry " + std::to_string(lines_.size()) +
                             ": entry " + std::to_string(seq) + " cannot follow it");
  std::string text(torn_tail_ ? 1 : 0, '\n');  // a torn line before it ends where this one starts
  text += l.dump();
  text += '\n';
  const int fd = open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot open the exam chain's anchor " + path_ + ": " + std::strerror(errno));
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t w = write(fd, text.data() + done, text.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      const std::string why = std::strerror(errno);
      close(fd);
      throw std::runtime_error("cannot write the exam chain's anchor " + path_ + ": " + why);
    }
    done += static_cast<size_t>(w);
  }
  const bool synced = fsync(fd) == 0;
  close(fd);
  if (!synced) throw std::runtime_error("cannot flush the exam chain's anchor " + path_ + " to disk: " + std::strerror(errno));
  exists_ = true;
  torn_tail_ = false;
  seq_of_session_[l["session"].get<std::string>()] = seq;
  lines_.push_back(l);
}

ChainKeys chain_keys(const std::string& security_dir, const std::string& identity) {
  ChainKeys k;
  if (security_dir.empty()) return k;
  k.server_key_file = security_dir + "/identities/" + identity + "/key.pem";
  k.server_cert_file = security_dir + "/identities/" + identity + "/cert.pem";
  k.ca_pem = security::read_text_file(security_dir + "/ca.pem", "school CA");
  if (std::filesystem::exists(security_dir + "/crl.pem"))
    k.crl_pem = security::read_text_file(security_dir + "/crl.pem", "school CRL");
  return k;
}

json exam_record(store::Store& db, const store::Session& s, const json* chained) {
  if (chained && !chained->contains("audit")) return make_record(db, s, nullptr);  // chained in the older form
  std::optional<int64_t> up_to;
  if (chained && (*chained)["audit"].is_object() && (*chained)["audit"].value("last_id", json()).is_number_integer())
    up_to = (*chained)["audit"]["last_id"].get<int64_t>();
  const SessionAudit a = session_audit(db, s, up_to);
  return make_record(db, s, &a);
}

ChainOutcome chain_exam(store::Store& db, const std::string& session, ChainAnchor& anchor, const ChainKeys& keys,
                        bool anyway) {
  const auto s = db.get_session(session);
  if (!s || s->mode != Mode::kExam) return {ChainResult::kNotSignable, "not a practical exam"};
  if (db.get_chain_entry(session)) return {ChainResult::kAlreadyChained, ""};
  const auto sig_text = db.get_session_log(session, "signature");
  if (!sig_text || sig_text->empty()) return {ChainResult::kNotSignable, "its worker left no signed log"};
  // The supervisor asks again every 50 ms while the score is on its way: the log is read only after.
  if (!is_terminal(s->state) || !db.get_score(session)) return {ChainResult::kNotReady, ""};
  const auto log = db.get_session_log(session, "control");
  if (!log) return {ChainResult::kNotSignable, "it has no control log"};
  if (!anyway && db.list_events(session).size() < logged_events(*log)) return {ChainResult::kNotReady, ""};
  if (std::string why = chain_head_problem(db, anchor); !why.empty()) return {ChainResult::kChainBroken, why};

  // The record must be the signed log's (the mark of record is the worker's), and name the pupil
  // and examiner its start was recorded with: else the database was changed since.
  const json sig = parsed(*sig_text);
  const SessionAudit audit = session_audit(db, *s, std::nullopt);
  const json record = make_record(db, *s, &audit);
  std::vector<std::string> problems = keys.ca_pem.empty()
      ? std::vector<std::string>{"the server has no school CA (--security) to check the worker's signature with"}
      : security::verify_record_against_log(record, *log, sig, keys.ca_pem, keys.crl_pem).problems;
  for (std::string& p : start_problems(*s, audit)) problems.push_back(std::move(p));
  if (!problems.empty())
    return {ChainResult::kRefused, "its record disagrees with the worker's signed log or the audit log: " +
                                       problems_text(problems)};

  const auto held = anchor.hold_chain();
  const auto last = db.last_chain_entry();
  const int64_t seq = last ? last->seq + 1 : 1;
  const std::string prev = last ? json::parse(last->entry).at("entry_hash").get<std::string>() : std::string(64, '0');
  const json entry = security::make_chain_entry(seq, prev, record, security::sha256_hex(*log),
                                                sig.at("signature").get<std::string>(), keys.server_key_file,
                                                keys.server_cert_file);
  db.append_chain_entry({seq, session, entry.dump()});
  anchor.append(entry);
  return {ChainResult::kAdded, ""};
}

void record_chain_refusal(store::Store& db, const std::string& session, const std::string& why) {
  const auto s = db.get_session(session);
  if (!s) return;
  db.batch([&] {
    db.put_session_log(session, "chain_refused", why);
    db.add_audit({0, store::now_iso8601(), kServer, s->pupil_id, "exam_chain_refused",
                  json{{"session", session}, {"reason", why}}.dump(-1, ' ', false, json::error_handler_t::replace)});
  });
}

std::string check_chain_at_start(store::Store& db, ChainAnchor& anchor, const ChainKeys& keys) {
  if (std::string p = anchor.problem(); !p.empty()) return p;
  json chain = json::array();
  for (const store::ChainEntry& e : db.list_chain()) chain.push_back(parsed(e.entry));
  const bool had_anchor = anchor.exists();
  const json a = {{"head", anchor.head().value_or(json(nullptr))}};
  const security::VerifyReport r =
      security::verify_chain(chain, a, keys.ca_pem, keys.crl_pem, {.require_server_signatures = !keys.server_key_file.empty()});
  if (!r.ok) {
    const std::string problem = "the database's exam chain is not the one anchored in " + anchor.path() + ": " +
                                problems_text(r.problems);
    // The exams whose entries were cut off, on their pupils' records.
    const auto head = anchor.head();
    const int64_t head_seq = head ? (*head)["seq"].get<int64_t>() : 0;
    for (int64_t seq = static_cast<int64_t>(chain.size()) + 1; seq <= head_seq; ++seq) {
      const std::string session = (*anchor.line(seq))["session"].get<std::string>();
      if (const auto s = db.get_session(session))
        db.add_audit({0, store::now_iso8601(), kServer, s->pupil_id, "exam_chain_cut_short",
                      json{{"session", session}, {"seq", seq}, {"problem", problem}}.dump()});
    }
    return problem;
  }
  // Entries past the head (walked and server-signed above) are anchored now.
  const int64_t head_seq = anchor.head() ? (*anchor.head())["seq"].get<int64_t>() : 0;
  for (const json& e : chain)
    if (e["seq"].get<int64_t>() > head_seq) anchor.append(e);
  if (!had_anchor && !chain.empty())
    spdlog::warn("no exam chain anchor at {}: anchored the {} entries the database holds", anchor.path(), chain.size());
  return "";
}

json exam_evidence(store::Store& db, const store::Session& s, const ChainAnchor& anchor) {
  if (s.mode != Mode::kExam)
    throw store::StoreError(store::StoreError::kNotFound, "session " + s.public_id + " is not a practical exam: it has no exam evidence");
  const auto held = anchor.hold_chain();  // the chain and its anchor as of one moment
  json chain = json::array();
  for (const auto& e : db.list_chain()) chain.push_back(parsed(e.entry));
  std::optional<json> chained;
  if (const auto mine = db.get_chain_entry(s.public_id)) {
    const json e = parsed(mine->entry);
    if (e.is_object() && e.contains("record")) chained = e["record"];
  }
  const auto sig = db.get_session_log(s.public_id, "signature");
  const json signature = sig ? parsed(*sig) : json(nullptr);  // a damaged file is the verifier's finding
  // Why it is not chained, for verify to say.
  json note = nullptr;
  if (!chained) {
    const auto refused = db.get_session_log(s.public_id, "chain_refused");
    note = !is_terminal(s.state) ? "the exam has not ended"
           : refused                    ? "the server refused to chain it: " + *refused
           : !sig                       ? "its worker left no signed log"
                                        : "the server has not chained it yet";
  }
  return {{"session", s.public_id}, {"record", exam_record(db, s, chained ? &*chained : nullptr)},
          {"log", db.get_session_log(s.public_id, "control").value_or("")}, {"signature", signature},
          {"chain", chain}, {"anchor", anchor_json(anchor, s.public_id)}, {"not_chained_because", note}};
}

ExamStanding exam_standing(store::Store& db, const store::Session& s, const ChainAnchor& anchor, const ChainKeys& keys) {
  if (s.mode != Mode::kExam) return {false, "it is not a practical exam"};
  if (keys.ca_pem.empty()) return {false, "this server has no school CA (--security) to check exam evidence with"};
  const auto held = anchor.hold_chain();
  const auto mine = db.get_chain_entry(s.public_id);
  if (!mine) {
    const auto refused = db.get_session_log(s.public_id, "chain_refused");
    return {false, "its record is not in the exam chain" + (refused ? ": the server refused it, as " + *refused : std::string())};
  }
  if (std::string why = chain_head_problem(db, anchor); !why.empty()) return {false, why};
  const json entry = parsed(mine->entry);
  const json record = entry.is_object() ? entry.value("record", json()) : json();
  const auto sig = db.get_session_log(s.public_id, "signature");
  const json line = anchor.line(mine->seq).value_or(json(nullptr));
  const json evidence = {{"session", s.public_id},
                         {"record", exam_record(db, s, record.is_object() ? &record : nullptr)},
                         {"log", db.get_session_log(s.public_id, "control").value_or("")},
                         {"signature", sig ? parsed(*sig) : json(nullptr)},
                         {"chain", json::array({entry})},
                         {"chain_from", mine->seq},
                         {"anchor", {{"head", line}, {"entry", line}}}};
  const security::VerifyReport r = security::verify_exam_evidence(
      evidence, keys.ca_pem, keys.crl_pem, {.require_server_signatures = true, .require_anchor = true});
  if (!r.ok) return {false, "its evidence does not verify: " + problems_text(r.problems)};
  return {true, ""};
}

}  // namespace forklift::server
