#include "forklift/security/evidence.h"

#include "forklift/session/log_records.h"
#include "forklift/session/vocabulary.h"

#include <openssl/crypto.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <stdexcept>

#include "crypto.h"

namespace forklift::security {

using nlohmann::json;

namespace {

using namespace detail;

constexpr const char* kSignatureFormat = "forklift-exam-log-signature/1";
constexpr const char* kAnchorFormat = "forklift-exam-chain-anchor/1";
const std::string kFirstPrevHash(64, '0');
constexpr int kMaxChainProblems = 20;  // a rewritten chain would otherwise list every entry

std::string log_message(const std::string& session, const std::string& cab, const std::string& log_sha256) {
  return "forklift-exam-log/1\n" + session + "\n" + cab + "\n" + log_sha256 + "\n";
}

// dump() sorts object keys, which makes it the canonical form both sides hash.
std::string entry_hash_of(const std::string& prev_hash, const json& record, const std::string& log_sha256,
                          const std::string& log_signature) {
  return sha256_hex(prev_hash + "\n" + record.dump() + "\n" + log_sha256 + "\n" + log_signature + "\n");
}

// A string for a report line: quoted and escaped, so that odd bytes cannot forge a line.
std::string show(const std::string& s) {
  const std::string q = json(s).dump(-1, ' ', false, json::error_handler_t::replace);
  return q.size() <= 90 ? q : q.substr(0, 80) + "...\"";
}

std::string count(size_t n, const std::string& one, const std::string& many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// A mark as a person reads it, with every digit that tells two doubles apart (the check compares
// bits), never a hex float.
std::string show_double(double v) {
  char buf[80];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const json* field(const json& obj, const char* key) {
  if (!obj.is_object()) return nullptr;
  const auto it = obj.find(key);
  return it == obj.end() ? nullptr : &*it;
}

const std::string* string_field(const json& obj, const char* key) {
  const json* f = field(obj, key);
  return f && f->is_string() ? f->get_ptr<const std::string*>() : nullptr;
}

// The top-level keys in which two records differ, for a report line.
std::string differing_keys(const json& a, const json& b) {
  if (!a.is_object() || !b.is_object()) return "its whole value";
  std::string keys;
  auto note = [&keys](const std::string& k) { keys += (keys.empty() ? "" : ", ") + k; };
  for (const auto& [k, v] : a.items())
    if (!b.contains(k) || b.at(k) != v) note(k);
  for (const auto& [k, v] : b.items())
    if (!a.contains(k)) note(k);
  return keys.empty() ? "nothing visible" : keys;
}

class Verifier {
 public:
  Verifier(const std::string& ca_pem, const std::string& crl_pem, VerifyOptions options)
      : ca_(ca_pem), crl_(crl_pem), options_(options) {}

  VerifyReport report;

  void run(const json& ev) {
    if (!ev.is_object()) return problem(std::string("evidence is not a JSON object but ") + ev.type_name());
    const std::string* session = string_field(ev, "session");
    const json* record = field(ev, "record");
    const std::string* log = string_field(ev, "log");
    const json* sig = field(ev, "signature");
    const json* chain = field(ev, "chain");
    const json* from = field(ev, "chain_from");
    if (!session) problem("evidence has no string \"session\"");
    if (record && !record->is_object()) record = nullptr;
    if (!record) problem("evidence has no object \"record\"");
    if (!log) problem("evidence has no string \"log\" (the control log)");
    if (sig && !sig->is_object()) sig = nullptr;
    if (!sig) problem("evidence has no object \"signature\" (the log signature)");
    if (chain && !chain->is_array()) chain = nullptr;
    if (!chain) chain_problem("evidence has no array \"chain\"");
    int64_t first_seq = 1;
    if (from && (!from->is_number_integer() || *from < 1))
      chain_problem("evidence's \"chain_from\" is " + from->dump() + ", not a seq (1 or more)");
    else if (from)
      first_seq = from->get<int64_t>();

    if (record) read_record_ids(*record);
    if (session && rec_session_ && *session != *rec_session_)
      problem("evidence is for session " + show(*session) + " but its record is session " + show(*rec_session_));

    if (sig) check_signature(*sig, log);
    if (log && record) check_log(*log, *record);
    if (chain) check_chain(*chain, first_seq, field(ev, "anchor"), session ? session : rec_session_, record);
  }

  // The record against its signed log alone (verify_record_against_log).
  void run_log(const json& record, const std::string& log, const json& sig) {
    if (!record.is_object()) return problem("the record is not a JSON object");
    read_record_ids(record);
    if (!sig.is_object()) problem("the log signature is not a JSON object");
    else check_signature(sig, &log);
    check_log(log, record);
  }

  // A log against its signature, for a known session and cab (verify_log_signature).
  void run_signature(const std::string& session, const std::string& cab, const std::string& log, const json& sig) {
    rec_session_ = &session;
    rec_cab_ = &cab;
    if (!sig.is_object()) return problem("the log signature is not a JSON object");
    check_signature(sig, &log);
  }

  // The chain and its anchor, with no session in view (verify_chain).
  void run_chain(const json& chain, const json& anchor) {
    if (!chain.is_array()) return chain_problem("the chain is not a JSON array");
    check_chain(chain, 1, &anchor, nullptr, nullptr);
  }

  void problem(const std::string& line) { report.problems.push_back(line); }

  void finish() {
    report.ok = report.problems.empty();
    report.verdict = report.ok                           ? Verdict::kVerified
                     : not_chained_ && !chain_tampered_ ? Verdict::kNotChained
                                                         : Verdict::kTampered;
  }

 private:
  void pass(const std::string& line) { report.passed.push_back(line); }

  void read_record_ids(const json& record) {
    rec_session_ = string_field(record, "session");
    rec_cab_ = string_field(record, "cab");
    if (!rec_session_) problem("record has no string \"session\"");
    if (!rec_cab_) problem("record has no string \"cab\"");
  }

  void check_signature(const json& sig, const std::string* log) {
    const std::string* format = string_field(sig, "format");
    if (!format || *format != kSignatureFormat)
      problem("signature format is " + (format ? show(*format) : std::string("missing")) + ", expected " +
              show(kSignatureFormat));
    const std::string* s_session = string_field(sig, "session");
    const std::string* s_cab = string_field(sig, "cab");
    sig_sha_ = string_field(sig, "log_sha256");
    sig_b64_ = string_field(sig, "signature");
    const std::string* s_cert = string_field(sig, "signer_certificate");
    for (const auto& [name, value] : {std::pair{"session", s_session},
                                      {"cab", s_cab},
                                      {"log_sha256", sig_sha_},
                                      {"signature", sig_b64_},
                                      {"signer_certificate", s_cert}})
      if (!value) problem(std::string("signature has no string \"") + name + "\"");

    if (s_session && s_cab && rec_session_ && rec_cab_) {
      if (*s_session == *rec_session_ && *s_cab == *rec_cab_)
        pass("signature names the record's session " + show(*s_session) + " and cab " + show(*s_cab));
      else
        problem("signature is for session " + show(*s_session) + " on cab " + show(*s_cab) +
                " but the record is session " + show(*rec_session_) + " on cab " + show(*rec_cab_));
    }

    std::vector<X509Ptr> certs = s_cert ? parse_certificates(*s_cert) : std::vector<X509Ptr>();
    if (s_cert && certs.empty()) problem("signer_certificate is not a PEM certificate");
    if (!certs.empty()) {
      std::string why;
      if (chains_to_ca(certs, ca_, crl_, &why))
        pass(std::string("signer certificate is issued by the school CA") +
             (crl_.empty() ? "" : " and not revoked by its CRL"));
      else
        problem("signer certificate is not accepted by the school CA: " + why);
      if (rec_cab_) {
        const std::string want = "worker." + *rec_cab_;
        try {
          const std::string cn = common_name(certs[0].get());
          if (cn == want)
            pass("signer certificate's common name " + show(cn) + " is the record's cab's worker");
          else
            problem("signer certificate's common name is " + show(cn) + ", expected " + show(want) +
                    " for the record's cab");
        } catch (const std::exception& e) {
          problem(std::string("signer certificate: ") + e.what() + ", expected " + show(want));
        }
      }
    }

    if (log && sig_sha_) {
      const std::string h = sha256_hex(*log);
      if (h == *sig_sha_)
        pass("log SHA-256 " + h + " equals the signature's log_sha256");
      else
        problem("log SHA-256 is " + h + " but the signature's log_sha256 is " + show(*sig_sha_) +
                ": the log is not the one signed");
    }

    if (s_session && s_cab && sig_sha_ && sig_b64_ && !certs.empty()) {
      const std::optional<std::string> der = base64_decode(*sig_b64_);
      EVP_PKEY* key = X509_get0_pubkey(certs[0].get());
      std::string why;
      if (!der)
        problem("log signature is not base64");
      else if (!key)
        problem("signer certificate's public key is unreadable: " + openssl_error());
      else if (s_session->find('\n') != std::string::npos || s_cab->find('\n') != std::string::npos)
        problem("signature's session or cab contains a line break, which would make the signed message ambiguous");
      else if (verify_sha256(key, log_message(*s_session, *s_cab, *sig_sha_), *der, &why))
        pass("log signature verifies with the signer certificate's key over its session, cab and log SHA-256");
      else
        problem("log signature does not verify with the signer certificate's key over session " + show(*s_session) +
                ", cab " + show(*s_cab) + " and log_sha256 " + show(*sig_sha_) + ": " + why);
    }
  }

  void check_log(const std::string& text, const json& record) {
    // The session log's own reader (forklift/session/log_records.h), tolerant: this log is the one
    // under suspicion, and its repeats and torn lines are findings.
    const LogFacts f = read_log_facts(text, LogReading::kTolerant);
    for (const std::string& m : f.malformed) problem(m);

    // Header: exactly one session and one cab line, the record's.
    bool header_ok = true;
    auto header = [&](const char* key, const std::vector<std::string>& values, const std::string* want) {
      if (values.size() != 1) {
        problem("log has " + std::to_string(values.size()) + " \"" + key + "\" header lines, expected one");
        header_ok = false;
      } else if (want && values[0] != *want) {
        problem(std::string("log header ") + key + " is " + show(values[0]) + " but the record's " + key + " is " +
                show(*want));
        header_ok = false;
      }
    };
    header("session", f.sessions, rec_session_);
    header("cab", f.cabs, rec_cab_);
    // A log from before the mode line was written is a training log, as the typed reader has it.
    const std::vector<std::string> modes = f.modes.empty() ? std::vector<std::string>{name(Mode::kTraining)} : f.modes;
    const std::string* rec_mode = string_field(record, "mode");
    header("mode", modes, rec_mode);
    if (header_ok && rec_session_ && rec_cab_)
      pass("log header session " + show(*rec_session_) + ", cab " + show(*rec_cab_) +
           (rec_mode ? " and mode " + show(*rec_mode) : std::string()) + " match the record");

    // Score: the mark exactly (the log writes it in %a) and pass/fail.
    const json* mark = field(record, "mark");
    const json* passed = field(record, "passed");
    std::optional<bool> rec_passed;
    if (passed && passed->is_boolean())
      rec_passed = passed->get<bool>();
    else if (passed && passed->is_number_integer() && (*passed == 0 || *passed == 1))
      rec_passed = *passed == 1;
    if (!mark || !mark->is_number()) problem("record has no numeric \"mark\"");
    if (!rec_passed) problem("record has no boolean \"passed\"");
    if (f.scores.size() != 1) {
      problem("log has " + std::to_string(f.scores.size()) + " score lines, expected one");
    } else if (mark && mark->is_number() && rec_passed) {
      const ScoreRecord& s = f.scores[0];
      const double rec_mark = mark->get<double>();
      bool ok = true;
      if (s.mark != rec_mark) {
        problem("log score mark " + show_double(s.mark) + " differs from the record's mark " + show_double(rec_mark));
        ok = false;
      }
      if (s.passed != *rec_passed) {
        problem(std::string("log score says ") + (s.passed ? "passed" : "failed") + " but the record's passed is " +
                (*rec_passed ? "true" : "false"));
        ok = false;
      }
      if (ok)
        pass("log score mark " + show_double(s.mark) + " and passed " + (s.passed ? "true" : "false") +
             " match the record");
    }

    // Events: the same (kind, worry) in the same order.
    const json* events = field(record, "events");
    if (!events || !events->is_array()) return problem("record has no array \"events\"");
    std::vector<EventRecord> rec_events;
    for (size_t i = 0; i < events->size(); ++i) {
      const json& e = (*events)[i];
      const std::string* kind = string_field(e, "kind");
      const json* worry = field(e, "worry");
      if (!kind || !worry || !worry->is_number_integer())
        return problem("record event " + std::to_string(i + 1) + " has no string \"kind\" and integer \"worry\"");
      rec_events.push_back({0, *kind, worry->get<long long>(), false});
    }
    bool same = rec_events.size() == f.events.size();
    for (size_t i = 0; i < std::min(rec_events.size(), f.events.size()); ++i) {
      const EventRecord& l = f.events[i];
      const EventRecord& r = rec_events[i];
      if (l.kind != r.kind || l.worry_level != r.worry_level) {
        problem("event " + std::to_string(i + 1) + " differs: the log has " + show(l.kind) + " worry " +
                std::to_string(l.worry_level) + ", the record " + show(r.kind) + " worry " +
                std::to_string(r.worry_level));
        same = false;
        break;  // after one difference, the rest is shifted and says nothing new
      }
    }
    if (rec_events.size() != f.events.size())
      problem("log has " + std::to_string(f.events.size()) + " events, the record " +
              std::to_string(rec_events.size()));
    if (same)
      pass("log's " + std::to_string(f.events.size()) + " events match the record's events (kind, worry, order)");
  }

  // A fault of the chain or of its anchor: evidence of tampering whatever the session's own entry says.
  void chain_problem(const std::string& line) {
    chain_tampered_ = true;
    if (++chain_problems_ <= kMaxChainProblems) problem(line);
  }

  // The server certificate of a chain entry: issued by the CA, named "server" or "server.*". Cached by PEM,
  // since one certificate signs many entries.
  struct ServerCert {
    std::string problem;  // empty when accepted
    PkeyPtr key;          // null when unreadable
  };
  const ServerCert& server_cert(const std::string& pem) {
    const auto found = server_certs_.find(pem);
    if (found != server_certs_.end()) return found->second;
    ServerCert& c = server_certs_[pem];
    std::vector<X509Ptr> certs = parse_certificates(pem);
    if (certs.empty()) {
      c.problem = "is not a PEM certificate";
      return c;
    }
    c.key.reset(X509_get_pubkey(certs[0].get()));
    std::string why;
    if (!chains_to_ca(certs, ca_, crl_, &why)) c.problem = "is not accepted by the school CA: " + why;
    try {
      const std::string cn = common_name(certs[0].get());
      if (cn != "server" && cn.rfind("server.", 0) != 0)
        c.problem += (c.problem.empty() ? "" : "; ") + std::string("has common name ") + show(cn) +
                     ", not \"server\" or \"server.*\"";
    } catch (const std::exception& e) {
      c.problem += (c.problem.empty() ? "" : "; ") + std::string(e.what());
    }
    if (!c.key) c.problem += (c.problem.empty() ? "" : "; ") + std::string("has an unreadable public key");
    openssl_error();  // drain
    if (c.problem.empty() && !accepted_server_key_) accepted_server_key_ = c.key.get();
    return c;
  }

  // What one entry's own fields say, for the walk along the chain.
  struct Entry {
    std::string label;  // "chain entry N (session "s-...")"
    const std::string* session = nullptr;
    const std::string* hash = nullptr;
  };

  // Entry `e`'s fields, record, hash and server signature; `prev` is the entry_hash it must link to
  // (nullptr when unknown).
  Entry check_entry(const json& e, const std::string& label, const std::string* prev, int64_t prev_seq,
                    bool first_of_chain, bool& links_ok, bool& signatures_ok, size_t& signed_entries) {
    Entry out{label};
    if (!e.is_object()) {
      chain_problem(label + " is not a JSON object");
      links_ok = false;
      return out;
    }
    const std::string* e_session = string_field(e, "session");
    const json* e_record = field(e, "record");
    if (e_record && !e_record->is_object()) e_record = nullptr;
    const std::string* e_sha = string_field(e, "log_sha256");
    const std::string* e_sig = string_field(e, "log_signature");
    const std::string* e_prev = string_field(e, "prev_hash");
    const std::string* e_hash = string_field(e, "entry_hash");
    out.session = e_session;
    out.hash = e_hash;
    std::string missing;
    for (const auto& [name, ok] : {std::pair{"session", e_session != nullptr},
                                   {"record (object)", e_record != nullptr},
                                   {"log_sha256", e_sha != nullptr},
                                   {"log_signature", e_sig != nullptr},
                                   {"prev_hash", e_prev != nullptr},
                                   {"entry_hash", e_hash != nullptr}})
      if (!ok) missing += (missing.empty() ? "" : ", ") + std::string(name);
    if (!missing.empty()) {
      chain_problem(label + " lacks " + missing);
      links_ok = false;
    }
    const std::string named = out.label = label + (e_session ? " (session " + show(*e_session) + ")" : "");
    if (e_session && e_record) {
      const std::string* r = string_field(*e_record, "session");
      if (!r || *r != *e_session) {
        chain_problem(named + "'s record is for session " + (r ? show(*r) : std::string("(none)")));
        links_ok = false;
      }
    }
    if (e_prev && first_of_chain && *e_prev != kFirstPrevHash) {
      chain_problem(named + "'s prev_hash " + show(*e_prev) + " is not 64 zeros");
      links_ok = false;
    } else if (e_prev && prev && *e_prev != *prev) {
      chain_problem(named + "'s prev_hash " + show(*e_prev) + " does not link to the entry_hash " + *prev +
                    " of entry " + std::to_string(prev_seq));
      links_ok = false;
    }
    if (e_prev && e_record && e_sha && e_sig && e_hash) {
      try {
        const std::string computed = entry_hash_of(*e_prev, *e_record, *e_sha, *e_sig);
        if (computed != *e_hash) {
          chain_problem(named + "'s entry_hash does not recompute (stored " + show(*e_hash) + ", computed " + computed +
                        "): its record, log_sha256 or log_signature was changed");
          links_ok = false;
        }
      } catch (const std::exception& x) {  // invalid UTF-8 in the record
        chain_problem(named + "'s record cannot be hashed: " + x.what());
        links_ok = false;
      }
    }

    const json* ss = field(e, "server_signature");
    if (!ss || ss->is_null()) {
      // Unsigned entries can be re-hashed by anyone with the database: a secured school signs all.
      if (options_.require_server_signatures) {
        chain_problem(named + " is not server-signed");
        signatures_ok = false;
      }
      return out;
    }
    ++signed_entries;
    const std::string* pem = string_field(e, "server_certificate");
    const std::optional<std::string> der = ss->is_string() ? base64_decode(ss->get<std::string>()) : std::nullopt;
    std::string why;
    if (!der) {
      chain_problem(named + "'s server_signature is not a base64 string");
      signatures_ok = false;
    } else if (!pem) {
      chain_problem(named + " is server-signed but has no string server_certificate");
      signatures_ok = false;
    } else if (const ServerCert& c = server_cert(*pem); !c.problem.empty()) {
      chain_problem(named + "'s server certificate " + c.problem);
      signatures_ok = false;
      if (c.key && e_hash && !verify_sha256(c.key.get(), *e_hash, *der, &why))
        chain_problem(named + "'s server_signature does not verify over its entry_hash either: " + why);
    } else if (!e_hash) {
      signatures_ok = false;  // already reported as lacking
    } else if (!verify_sha256(c.key.get(), *e_hash, *der, &why)) {
      chain_problem(named + "'s server_signature does not verify over its entry_hash " + show(*e_hash) + ": " + why);
      signatures_ok = false;
    }
    return out;
  }

  // The chain from seq `first_seq` on; `session` and `record` (either may be null) the exam in view.
  void check_chain(const json& chain, int64_t first_seq, const json* anchor, const std::string* session,
                   const json* record) {
    bool links_ok = true, signatures_ok = true;
    size_t signed_entries = 0;
    std::vector<size_t> mine;  // the session's entries
    std::optional<std::string> prev = first_seq == 1 ? std::optional(kFirstPrevHash) : std::nullopt;
    int64_t expected = first_seq;  // the seq the next entry must have
    int64_t prev_seq = first_seq - 1;
    for (size_t i = 0; i < chain.size(); ++i) {
      const json& e = chain[i];
      const json* seq = field(e, "seq");
      const bool numbered = seq && seq->is_number_integer();
      const int64_t n = numbered ? seq->get<int64_t>() : 0;
      if (numbered && n > expected) {
        // A gap: entries were deleted from the middle (or the end, before entries added since).
        chain_problem("chain: " + entries_from(expected, n - 1) + " missing (a gap: the chain " +
                      (i == 0 ? "starts at entry " + std::to_string(n)
                              : "goes from entry " + std::to_string(expected - 1) + " to entry " + std::to_string(n)) +
                      ")");
        links_ok = false;
      } else if (!numbered || n != expected) {
        chain_problem("chain entry " + std::to_string(i + 1) + " in order has seq " +
                      (seq ? seq->dump() : std::string("missing")) + ", expected " + std::to_string(expected));
        links_ok = false;
      }
      const int64_t at = numbered && n > expected ? n : expected;
      expected = at + 1;
      const Entry x = check_entry(e, "chain entry " + std::to_string(at), prev ? &*prev : nullptr, prev_seq,
                                  i == 0 && first_seq == 1, links_ok, signatures_ok, signed_entries);
      prev_seq = at;
      if (x.session && session && *x.session == *session) mine.push_back(i);
      if (x.hash) seq_of_.emplace(at, i);
      prev = x.hash ? std::optional(*x.hash) : std::nullopt;
    }
    last_seq_ = chain.empty() ? first_seq - 1 : expected - 1;
    if (chain_problems_ > kMaxChainProblems)
      problem("chain: " + std::to_string(chain_problems_ - kMaxChainProblems) + " further chain problems not listed");

    const std::string span = first_seq == 1 ? "chain of " + count(chain.size(), "entry", "entries")
                                            : "chain entries " + std::to_string(first_seq) + " to " +
                                                  std::to_string(last_seq_);
    // An empty chain is a new school's (the session's missing entry is its own problem).
    if (!chain.empty() && links_ok)
      pass(span + ": seqs without a gap, each prev_hash links and each entry_hash recomputes");
    if (signed_entries == 0 && !chain.empty())
      pass("chain: no entry is server-signed, so there is no server signature to check");
    else if (signed_entries && signatures_ok)
      pass("chain: all " + count(signed_entries, "server signature", "server signatures") +
           " verify with server certificates issued by the school CA");

    check_anchor(anchor, chain, first_seq, session, mine);
    if (session) check_session_entry(chain, *session, record, mine);
  }

  // The anchor kept outside the database: the chain must hold its head (else it was cut short or
  // rewritten) and the session's anchored entry (else that entry was deleted).
  void check_anchor(const json* anchor, const json& chain, int64_t first_seq, const std::string* session,
                    const std::vector<size_t>& mine) {
    if (!anchor || anchor->is_null()) {
      if (options_.require_anchor)
        chain_problem("evidence has no chain anchor: a chain whose last entries were deleted cannot be told from a "
                      "whole one");
      return;
    }
    if (!anchor->is_object()) return chain_problem("the chain anchor is not a JSON object");
    const json* head = field(*anchor, "head");
    if (!head || head->is_null()) {
      if (options_.require_anchor && !chain.empty())
        chain_problem("the anchor records no chain entry, but the chain has " +
                      count(chain.size(), "entry", "entries") + ": the chain is not anchored");
    } else if (const auto h = anchored(*head, "the anchor's head")) {
      if (h->seq > last_seq_) {
        chain_problem("the chain is cut short: the anchor (kept outside the database) records entry " +
                      std::to_string(h->seq) + " (session " + show(h->session) + ") but the chain ends at " +
                      (last_seq_ < 1 ? std::string("no entry") : "entry " + std::to_string(last_seq_)) + ": " +
                      count(static_cast<size_t>(h->seq - std::max<int64_t>(last_seq_, 0)), "entry was", "entries were") +
                      " deleted from its end");
      } else if (match_anchored(chain, *h, first_seq, "the anchor's head")) {
        pass("the chain holds the anchor's head, entry " + std::to_string(h->seq) + " (session " + show(h->session) +
             ")" +
             (last_seq_ > h->seq ? "; " + entries_from(h->seq + 1, last_seq_) +
                                       " newer than the anchor, which the server writes just after each entry"
                                 : std::string()));
      }
      check_anchor_signature(*h);
    }

    if (!session) return;
    const json* entry = field(*anchor, "entry");
    if (entry && !entry->is_null()) {
      const auto a = anchored(*entry, "the anchor's line for session " + show(*session));
      if (!a) return;
      if (a->session != *session)
        return chain_problem("the anchor's line for session " + show(*session) + " is for session " + show(a->session));
      if (mine.empty())
        return chain_problem("the anchor records session " + show(*session) + " as chain entry " +
                             std::to_string(a->seq) + ", but the chain has no entry for it: its entry was deleted");
      if (match_anchored(chain, *a, first_seq, "the anchor's line for session " + show(*session)))
        pass("session " + show(*session) + "'s chain entry " + std::to_string(a->seq) + " is the anchored one");
    } else if (mine.size() == 1 && head && head->is_object()) {
      const json& e = chain[mine[0]];
      const json* seq = field(e, "seq");
      const json* head_seq = field(*head, "seq");
      if (seq && head_seq && seq->is_number_integer() && head_seq->is_number_integer() && *seq <= *head_seq)
        chain_problem("the anchor has no line for session " + show(*session) + "'s chain entry " + seq->dump() +
                      ", though it anchors the entries up to " + head_seq->dump());
    }
  }

  // "entry 4 is" or "entries 4 to 6 are".
  static std::string entries_from(int64_t first, int64_t last) {
    return first == last ? "entry " + std::to_string(first) + " is"
                         : "entries " + std::to_string(first) + " to " + std::to_string(last) + " are";
  }

  struct Anchored {
    int64_t seq = 0;
    std::string session, entry_hash;
    const json* signature = nullptr;
  };
  std::optional<Anchored> anchored(const json& line, const std::string& what) {
    const std::string* format = string_field(line, "format");
    const json* seq = field(line, "seq");
    const std::string* session = string_field(line, "session");
    const std::string* hash = string_field(line, "entry_hash");
    if (!format || *format != kAnchorFormat || !seq || !seq->is_number_integer() || *seq < 1 || !session || !hash) {
      chain_problem(what + " is not an anchor line (" + kAnchorFormat + ": seq, session, entry_hash)");
      return std::nullopt;
    }
    return Anchored{seq->get<int64_t>(), *session, *hash, field(line, "server_signature")};
  }

  // The chain's entry at the anchored seq has the anchored hash and session; a fault is reported.
  bool match_anchored(const json& chain, const Anchored& a, int64_t first_seq, const std::string& what) {
    if (a.seq < first_seq) return true;  // before the part of the chain given: its links vouch for nothing here
    const auto at = seq_of_.find(a.seq);
    if (at == seq_of_.end()) {
      chain_problem(what + " is entry " + std::to_string(a.seq) + ", which the chain lacks");
      return false;
    }
    const json& e = chain[at->second];
    const std::string* hash = string_field(e, "entry_hash");
    const std::string* session = string_field(e, "session");
    if (hash && *hash == a.entry_hash && session && *session == a.session) return true;
    chain_problem("chain entry " + std::to_string(a.seq) + " is not the one anchored (" + what + ": session " +
                  show(a.session) + ", entry_hash " + show(a.entry_hash) + "): the chain was rewritten");
    return false;
  }

  // The anchored head carries the server's signature of its entry_hash, checkable with the chain's
  // server certificate even when the entry itself was deleted.
  void check_anchor_signature(const Anchored& h) {
    if (!h.signature || h.signature->is_null()) {
      if (options_.require_server_signatures) chain_problem("the anchor's head is not server-signed");
      return;
    }
    const std::optional<std::string> der =
        h.signature->is_string() ? base64_decode(h.signature->get<std::string>()) : std::nullopt;
    std::string why;
    if (!der)
      chain_problem("the anchor's head's server_signature is not a base64 string");
    else if (!accepted_server_key_)
      pass("the anchor's head is signed, but no server certificate in the chain can check it");
    else if (verify_sha256(accepted_server_key_, h.entry_hash, *der, &why))
      pass("the anchor's head is signed by the server's key");
    else
      chain_problem("the anchor's head's server_signature does not verify with the server's key: " + why);
  }

  static std::string seq_text(const json& e) {
    const json* seq = field(e, "seq");
    return seq ? seq->dump() : "(none)";
  }

  void check_session_entry(const json& chain, const std::string& session, const json* record,
                           const std::vector<size_t>& mine) {
    if (mine.empty()) {
      not_chained_ = true;
      return problem("session " + show(session) + " has no chain entry: it is not a chained exam");
    }
    if (mine.size() > 1) {
      std::string seqs;
      for (size_t i : mine) seqs += (seqs.empty() ? "" : ", ") + seq_text(chain[i]);
      return chain_problem("session " + show(session) + " has " + std::to_string(mine.size()) + " chain entries (" +
                           seqs + "), expected exactly one");
    }
    const json& e = chain[mine[0]];
    const std::string label = "chain entry " + seq_text(e);
    pass("session " + show(session) + " has exactly one chain entry (seq " + seq_text(e) + ")");
    const json* e_record = field(e, "record");
    if (record && e_record) {
      if (*e_record == *record)
        pass(label + "'s record equals the current record");
      else
        problem(label + "'s record differs from the current record in: " + differing_keys(*e_record, *record));
    }
    const std::string* e_sha = string_field(e, "log_sha256");
    const std::string* e_sig = string_field(e, "log_signature");
    if (e_sha && sig_sha_ && e_sig && sig_b64_) {
      if (*e_sha == *sig_sha_ && *e_sig == *sig_b64_) {
        pass(label + "'s log_sha256 and log_signature equal the signature file's");
      } else {
        if (*e_sha != *sig_sha_)
          problem(label + "'s log_sha256 " + show(*e_sha) + " differs from the signature file's " + show(*sig_sha_));
        if (*e_sig != *sig_b64_) problem(label + "'s log_signature differs from the signature file's");
      }
    }
  }

  const std::string& ca_;
  const std::string& crl_;
  const VerifyOptions options_;
  const std::string* rec_session_ = nullptr;
  const std::string* rec_cab_ = nullptr;
  const std::string* sig_sha_ = nullptr;
  const std::string* sig_b64_ = nullptr;
  int chain_problems_ = 0;
  bool chain_tampered_ = false;
  bool not_chained_ = false;
  int64_t last_seq_ = 0;                // the seq of the chain's last entry (0: none)
  std::map<int64_t, size_t> seq_of_;    // chain index by seq
  EVP_PKEY* accepted_server_key_ = nullptr;  // owned by server_certs_
  std::map<std::string, ServerCert> server_certs_;
};

}  // namespace

std::string read_text_file(const std::string& path, const std::string& what) { return read_file(path, what); }

std::string sha256_hex(std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), md, &len, EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 failed: " + openssl_error());
  static const char digits[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(2 * len);
  for (unsigned int i = 0; i < len; ++i) {
    hex += digits[md[i] >> 4];
    hex += digits[md[i] & 15];
  }
  return hex;
}

json sign_exam_log(const std::string& session, const std::string& cab, const std::string& log_text,
                   const std::string& key_pem_file, const std::string& cert_pem_file) {
  // The message is newline-separated: a newline inside a field could shift it into the next one.
  if (session.empty() || cab.empty() || session.find('\n') != std::string::npos || cab.find('\n') != std::string::npos)
    throw std::runtime_error("sign_exam_log: session and cab must be non-empty single lines");
  const Signer s = load_signer(key_pem_file, cert_pem_file, "worker");
  const std::string log_sha256 = sha256_hex(log_text);
  const std::string signature = sign_sha256(s.key.get(), log_message(session, cab, log_sha256));
  return {{"format", kSignatureFormat},
          {"session", session},
          {"cab", cab},
          {"log_sha256", log_sha256},
          {"signature", base64_encode(signature)},
          {"signer_certificate", to_pem(s.certs)}};
}

json make_chain_entry(int64_t seq, const std::string& prev_hash, const json& record, const std::string& log_sha256,
                      const std::string& log_signature_b64, const std::string& server_key_file,
                      const std::string& server_cert_file) {
  if (seq < 1) throw std::runtime_error("make_chain_entry: seq must be 1 or more, not " + std::to_string(seq));
  if (!is_hex_sha256(prev_hash))
    throw std::runtime_error("make_chain_entry: prev_hash is not 64 lower-case hex digits");
  if (seq == 1 && prev_hash != kFirstPrevHash)
    throw std::runtime_error("make_chain_entry: seq 1 needs a prev_hash of 64 zeros");
  const std::string* session = string_field(record, "session");
  if (!session) throw std::runtime_error("make_chain_entry: the record has no string \"session\"");
  if (!is_hex_sha256(log_sha256))
    throw std::runtime_error("make_chain_entry: log_sha256 is not 64 lower-case hex digits");
  if (!base64_decode(log_signature_b64)) throw std::runtime_error("make_chain_entry: log_signature is not base64");
  std::string entry_hash;
  try {
    entry_hash = entry_hash_of(prev_hash, record, log_sha256, log_signature_b64);
  } catch (const json::exception& e) {
    throw std::runtime_error(std::string("make_chain_entry: the record cannot be serialised: ") + e.what());
  }
  json entry = {{"seq", seq},
                {"session", *session},
                {"record", record},
                {"log_sha256", log_sha256},
                {"log_signature", log_signature_b64},
                {"prev_hash", prev_hash},
                {"entry_hash", entry_hash},
                {"server_signature", nullptr},
                {"server_certificate", nullptr}};
  if (!server_key_file.empty()) {
    const Signer s = load_signer(server_key_file, server_cert_file, "server");
    entry["server_signature"] = base64_encode(sign_sha256(s.key.get(), entry_hash));
    entry["server_certificate"] = to_pem(s.certs);
  }
  return entry;
}

std::string certificate_common_name(const std::string& cert_pem) {
  const std::vector<X509Ptr> certs = parse_certificates(cert_pem);
  if (certs.empty()) throw std::runtime_error("certificate_common_name: not a PEM certificate");
  return common_name(certs[0].get());
}

bool certificate_issued_by(const std::string& cert_pem, const std::string& ca_pem, const std::string& crl_pem,
                           std::string* why) {
  try {
    const std::vector<X509Ptr> certs = parse_certificates(cert_pem);
    if (certs.empty()) {
      if (why) *why = "not a PEM certificate";
      return false;
    }
    return chains_to_ca(certs, ca_pem, crl_pem, why);
  } catch (const std::exception& e) {
    if (why) *why = e.what();
    return false;
  }
}

json chain_anchor_line(const json& entry) {
  const json* seq = field(entry, "seq");
  const std::string* session = string_field(entry, "session");
  const std::string* hash = string_field(entry, "entry_hash");
  const json* signature = field(entry, "server_signature");
  if (!seq || !seq->is_number_integer() || !session || !hash || !signature)
    throw std::runtime_error("chain_anchor_line: the entry lacks its seq, session, entry_hash or server_signature");
  return {{"format", kAnchorFormat}, {"seq", *seq}, {"session", *session}, {"entry_hash", *hash},
          {"server_signature", *signature}};
}

namespace {

// Runs one of the Verifier's checks, so that nothing escapes as an exception.
template <typename Check>
VerifyReport verified(const std::string& ca_pem, const std::string& crl_pem, VerifyOptions options, Check check) {
  Verifier v(ca_pem, crl_pem, options);
  try {
    check(v);
  } catch (const std::exception& e) {  // out of memory and the like: still a report, never a throw
    v.problem(std::string("evidence could not be checked: ") + e.what());
  }
  v.finish();
  return std::move(v.report);
}

}  // namespace

VerifyReport verify_exam_evidence(const json& evidence, const std::string& ca_pem, const std::string& crl_pem,
                                  VerifyOptions options) {
  return verified(ca_pem, crl_pem, options, [&](Verifier& v) { v.run(evidence); });
}

VerifyReport verify_record_against_log(const json& record, const std::string& log, const json& signature,
                                       const std::string& ca_pem, const std::string& crl_pem) {
  return verified(ca_pem, crl_pem, {}, [&](Verifier& v) { v.run_log(record, log, signature); });
}

VerifyReport verify_log_signature(const std::string& session, const std::string& cab, const std::string& log,
                                  const json& signature, const std::string& ca_pem, const std::string& crl_pem) {
  return verified(ca_pem, crl_pem, {}, [&](Verifier& v) { v.run_signature(session, cab, log, signature); });
}

VerifyReport verify_chain(const json& chain, const json& anchor, const std::string& ca_pem, const std::string& crl_pem,
                          VerifyOptions options) {
  return verified(ca_pem, crl_pem, options, [&](Verifier& v) { v.run_chain(chain, anchor); });
}

}  // namespace forklift::security
