#include "certificates.h"

#include <sodium.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <regex>

#include "api.h"
#include "catalogue.h"
#include "forklift/security/certificate.h"
#include "forklift/security/evidence.h"

namespace forklift::server {

using nlohmann::json;

namespace {

constexpr const char* kRecordFormat = "forklift-certificate/1";
// Crockford's base32: no I, L, O or U, so that a number read aloud or retyped is not misread.
constexpr const char* kBase32 = "0123456789ABCDEFGHJKMNPQRSTVWXYZ";
constexpr int kRandomBits = 80;  // 2^80 numbers: trying them one by one at any rate finds none
// OSHA 29 CFR 1910.178(l)(4)(iii): an evaluation of each operator's performance at least once
// every three years.
constexpr int kReevaluationYears = 3;
constexpr const char* kReevaluationRule =
    "29 CFR 1910.178(l)(4)(iii): an evaluation of the operator's performance at least once every three years";

json parsed(const std::string& text) { return json::parse(text, nullptr, false); }

// A person a certificate names, who must have a full name on their account.
json named_person(Context& ctx, std::optional<int64_t> user_id, const std::string& role) {
  const json p = person_json(ctx.db(), user_id);
  if (p.is_null()) throw ApiError(409, "full_name_missing", "the " + role + " is not recorded: the certificate cannot name them");
  if (p["name"].is_null())
    throw ApiError(409, "full_name_missing",
                   "the " + role + " (user " + p["username"].dump() + ", id " + p["id"].dump() +
                       ") has no full name on their account, and a certificate names people by their full names: an "
                       "administrator sets it (PATCH /api/users/" + p["id"].dump() + " {\"full_name\": ...})");
  return p;
}

std::string course_title(const json& course, const std::string& scenario) {
  if (course.is_object()) {
    for (const char* key : {"title", "name"})
      if (course.contains(key) && course[key].is_string()) return course[key].get<std::string>();
  }
  return scenario;
}

}  // namespace

std::string new_certificate_number(const std::string& school_name) {
  std::string prefix;
  bool word_start = true;
  for (char c : school_name) {
    const bool letter = std::isalpha(static_cast<unsigned char>(c)) != 0;
    if (letter && word_start && prefix.size() < 4) prefix += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    word_start = !std::isalnum(static_cast<unsigned char>(c));
  }
  if (prefix.empty()) prefix = "FL";
  unsigned char raw[kRandomBits / 8];
  randombytes_buf(raw, sizeof raw);
  std::string number = prefix;
  int bits = 0, acc = 0, n = 0;
  for (unsigned char b : raw) {
    acc = (acc << 8) | b;
    bits += 8;
    while (bits >= 5) {
      if (n % 4 == 0) number += '-';
      number += kBase32[(acc >> (bits - 5)) & 31];
      bits -= 5;
      ++n;
    }
  }
  return number;
}

std::string canonical_certificate_number(const std::string& typed) {
  std::string out;
  for (char c : typed) {
    if (std::isspace(static_cast<unsigned char>(c))) continue;
    char u = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (u == 'O') u = '0';
    if (u == 'I' || u == 'L') u = '1';
    out += u;
  }
  // The prefix is the school's initials, letters that the mapping above must leave alone.
  const size_t dash = typed.find('-');
  if (dash != std::string::npos) {
    std::string prefix;
    for (char c : typed.substr(0, dash))
      if (!std::isspace(static_cast<unsigned char>(c))) prefix += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    const size_t mine = out.find('-');
    if (mine != std::string::npos) out = prefix + out.substr(mine);
  }
  return out;
}

std::string exam_row_sha256(const store::ExamRecord& e) {
  const json row = {{"id", e.id}, {"pupil_id", e.pupil_id}, {"kind", name(e.kind)},
                    {"session", e.session_public_id ? json(*e.session_public_id) : json(nullptr)}, {"score", e.score},
                    {"passed", e.passed}, {"examiner_id", e.examiner_id ? json(*e.examiner_id) : json(nullptr)},
                    {"taken_at", e.taken_at}, {"details", e.details}};
  return security::sha256_hex(row.dump(-1, ' ', false, json::error_handler_t::replace));
}

namespace {

// The truck class a session ran on, in words: the OSHA class data/theory/certification.json gives
// its truck, else the truck's own name.
std::string truck_class(Context& ctx, const store::Session& s) {
  const json truck = scenario_setup(scenario_as_run(ctx.db(), ctx.data_dir, s)).first;
  if (!truck.is_string()) return "the simulator's default truck";
  const json t = truck_json(ctx.data_dir, truck.get<std::string>());
  return t["osha_class"].is_string() ? t["osha_class"].get<std::string>() : t["title"].get<std::string>();
}

// The catalogue's `key` in `lang`, or `english` (the data files' words) in English or where the
// catalogue has no such key (a school's own scenario or truck).
std::string worded(Context& ctx, const std::string& lang, const std::string& key, const std::string& english) {
  return lang == i18n::kSourceLanguage || !ctx.words->has(lang, key) ? english : ctx.words->text(lang, key);
}

// A truck class's words (certification.json's in English) in `lang`: the catalogue's of the same
// truck, found by its English words.
std::string truck_class_in(Context& ctx, const std::string& lang, const std::string& english) {
  if (lang == i18n::kSourceLanguage) return english;
  for (const auto& [key, text] : ctx.words->flat(i18n::kSourceLanguage))
    if ((key.rfind("certificate:truck_classes.", 0) == 0 || key == "certificate:default_truck") && text == english)
      return ctx.words->text(lang, key);
  return english;
}

// A scenario's title in `lang`: the catalogue's; the paper's manoeuvres (data/manoeuvres/,
// "manoeuvre_4") by their number; else its name in words.
std::string scenario_title(Context& ctx, const std::string& lang, const std::string& scenario) {
  if (const std::string key = "words:scenarios." + scenario; ctx.words->has(lang, key)) return ctx.words->text(lang, key);
  if (std::smatch m; std::regex_match(scenario, m, std::regex("manoeuvre_([0-9]+)")))
    return ctx.words->text(lang, "words:manoeuvre", {{"number", m[1].str()}});
  std::string words = scenario;
  std::replace(words.begin(), words.end(), '_', ' ');
  return words;
}

std::string plural(size_t n, const std::string& one) { return std::to_string(n) + " " + one + (n == 1 ? "" : "s"); }

}  // namespace

LicenceBasis licence_basis(Context& ctx, const store::Pupil& pupil, const store::PupilHistory& h,
                           const std::vector<ExamResult>& results, const std::string& now) {
  const LicenceRules& rules = *ctx.licence_rules;
  LicenceBasis b;
  std::map<std::string, const ExamResult*> by_course;  // the latest counted exam of each course (results are oldest first)
  std::vector<std::string> not_counted;
  for (const auto& r : results) {
    if (r.kind == ExamKind::kTheory && r.counts) b.theory = &r;
    if (r.kind != ExamKind::kPractical) continue;
    if (r.counts) by_course[r.session ? r.session->scenario : std::string()] = &r;
    else if (r.record && r.record->passed) {
      std::string why = r.not_counted;
      for (const Reason& x : r.reasons) why += (why.empty() ? "" : "; ") + x.text;
      not_counted.push_back((r.session ? "session " + r.session->public_id : "exam " + std::to_string(r.record->id)) + ": " + why);
    }
  }
  for (const auto& [course, r] : by_course) b.practical.push_back(r);
  if (!b.practical.empty() && b.practical.back()->session) b.truck_class = truck_class(ctx, *b.practical.back()->session);

  if (!b.theory) {
    b.missing.push_back("has not passed the theory exam");
  } else if (rules.theory_within_months > 0 && b.theory->taken_at < store::add_months_iso8601(now, -rules.theory_within_months)) {
    b.missing.push_back("passed the theory exam on " + b.theory->taken_at.substr(0, 10) + ", more than " +
                        plural(rules.theory_within_months, "month") + " ago (the school's rules ask for a pass within " +
                        plural(rules.theory_within_months, "month") + "): a new theory exam is needed");
    b.theory = nullptr;
  }
  if (b.practical.empty()) {
    std::string item = "has not passed a practical exam on an exam course";
    if (!not_counted.empty()) {
      item += " (a passed practical exam that does not count: ";
      for (size_t i = 0; i < not_counted.size(); ++i) item += (i ? "; " : "") + not_counted[i];
      item += ")";
    }
    b.missing.push_back(item);
  }
  for (const store::Session& s : h.sessions) {
    const std::optional<double> mark = store::mark_of(s);
    if (s.mode != Mode::kTraining || !mark) continue;
    if (!b.truck_class.empty() && truck_class(ctx, s) != b.truck_class) continue;
    b.training.push_back({s.public_id, s.created_at, s.scenario, *mark});
  }
  if (b.training.size() < static_cast<size_t>(rules.training_sessions))
    b.missing.push_back("has " + std::to_string(b.training.size()) + " of the " + plural(rules.training_sessions, "marked training session") +
                        " the school's rules ask for" + (b.truck_class.empty() ? "" : " on the practical exam's truck (" + b.truck_class + ")") +
                        ": a session counts when it ends with a mark, its task done or its course run");
  if (!b.missing.empty()) {
    b.why_not = pupil.name + " cannot be licensed yet: ";
    for (size_t i = 0; i < b.missing.size(); ++i) b.why_not += (i ? "; " : "") + b.missing[i];
  }
  return b;
}

json certificate_record(Context& ctx, const store::Pupil& pupil, const LicenceBasis& basis, const store::LicenceRecord& licence, int64_t issued_by, const std::string& number,
                        const std::string& school, const std::string& lang) {
  store::Store& db = ctx.db();
  const ExamResult& t = *basis.theory;
  const json td = t.details.is_object() ? t.details : json::object();
  json theory = {{"exam_id", t.record->id}, {"kind", name(ExamKind::kTheory)}, {"taken_at", t.taken_at}, {"score", t.record->score},
                 {"passed", true}, {"correct", td.value("correct", json(nullptr))}, {"total", td.value("total", json(nullptr))},
                 {"pass_mark", td.value("pass_mark", json(nullptr))},
                 {"examiner", named_person(ctx, t.record->examiner_id, "supervisor of the theory exam")},
                 {"record_sha256", exam_row_sha256(*t.record)}};
  json practical = json::array();
  std::string evaluated_at;
  for (const ExamResult* p : basis.practical) {
    const auto entry = db.get_chain_entry(p->session->public_id);
    const json e = entry ? parsed(entry->entry) : json();
    const json truck = scenario_setup(scenario_as_run(db, ctx.data_dir, *p->session)).first;
    json truck_words = nullptr;
    if (truck.is_string()) {
      const std::string stem = truck.get<std::string>();
      truck_words = truck_json(ctx.data_dir, stem);
      truck_words["title"] = worded(ctx, lang, "certificate:trucks." + stem, truck_words["title"]);
      if (truck_words["osha_class"].is_string())
        truck_words["osha_class"] = worded(ctx, lang, "certificate:truck_classes." + stem, truck_words["osha_class"]);
    }
    practical.push_back({{"exam_id", p->record->id}, {"kind", name(ExamKind::kPractical)}, {"taken_at", p->taken_at}, {"score", p->record->score},
                         {"passed", true}, {"session", p->session->public_id}, {"scenario", p->session->scenario},
                         {"course", worded(ctx, lang, "words:scenarios." + p->session->scenario, course_title(p->course, p->session->scenario))},
                         {"truck", truck_words},
                         {"examiner", named_person(ctx, p->record->examiner_id, "examiner of practical exam " + p->session->public_id)},
                         {"chain", {{"seq", entry ? json(entry->seq) : json(nullptr)},
                                    {"entry_hash", e.is_object() ? e.value("entry_hash", json(nullptr)) : json(nullptr)}}},
                         {"record_sha256", exam_row_sha256(*p->record)}});
    evaluated_at = std::max(evaluated_at, p->taken_at);
  }
  json list = json::array();
  for (const TrainedSession& t : basis.training)
    list.push_back({{"session", t.session}, {"at", t.at}, {"scenario", t.scenario}, {"mark", t.mark},
                    {"title", scenario_title(ctx, lang, t.scenario)}});
  const json training = {{"sessions", basis.training.size()}, {"truck_class", truck_class_in(ctx, lang, basis.truck_class)},
                         {"first_at", basis.training.empty() ? json(nullptr) : json(basis.training.front().at)},
                         {"last_at", basis.training.empty() ? json(nullptr) : json(basis.training.back().at)}, {"list", list}};
  json statement = nullptr;
  try {
    // Only what the record holds: no word of training when none is listed.
    const std::string which = basis.training.empty() ? "statement_without_training" : "statement";
    statement = read_json_file(ctx.data_dir + "/theory/certification.json").value(which, json(nullptr));
    if (statement.is_string()) statement = worded(ctx, lang, "certificate:" + which, statement.get<std::string>());
  } catch (const std::exception&) {
  }
  return {{"format", kRecordFormat}, {"number", number}, {"language", lang}, {"school", school}, {"pupil", {{"id", pupil.id}, {"name", pupil.name}}},
          {"licence", {{"id", licence.id}, {"issued_at", licence.issued_at},
                       {"issued_by", named_person(ctx, issued_by, "person issuing the licence")}}},
          {"evaluated_at", evaluated_at},
          {"reevaluation_due", store::add_years_iso8601(evaluated_at, kReevaluationYears)}, {"reevaluation_rule", kReevaluationRule},
          {"theory", theory}, {"practical", practical}, {"training", training}, {"statement", statement},
          {"issued_at", licence.issued_at}};
}

CertificateCheck check_certificate(Context& ctx, const store::CertificateRecord& c) {
  store::Store& db = ctx.db();
  CertificateCheck out;
  out.revocation = db.certificate_revocation(c.id);
  auto problem = [&](const std::string& p) { out.problems.push_back(p); };
  out.record = parsed(c.record);
  // The checks that held in the certificate's words; a problem in the words that name it.
  const std::string lang = ctx.words->supported(out.record.is_object() ? out.record.value("language", "en") : "en");
  // The signature: the record is the one the school's server signed.
  ChainKeys keys;
  try {
    keys = ctx.fleet->chain_keys();
  } catch (const std::exception& e) {
    problem(std::string("the school's CA cannot be read: ") + e.what());
  }
  if (keys.ca_pem.empty()) {
    problem("this server has no school CA (--security) to check the certificate's signature with");
  } else {
    const security::VerifyReport r = security::verify_certificate_signature(c.record, parsed(c.signature), keys.ca_pem, keys.crl_pem);
    for (size_t i = 0; i < r.passed.size(); ++i) {
      const auto& [code, value] = r.passed_codes.at(i);
      const std::string key = "certificate:check." + code;
      out.checks.push_back(lang == i18n::kSourceLanguage || !ctx.words->has(lang, key)
                               ? r.passed[i]
                               : ctx.words->text(lang, key, {{"hash", value}, {"name", value}}));
    }
    for (const auto& l : r.problems) problem(l);
  }
  const json& rec = out.record;
  if (!rec.is_object() || rec.value("format", "") != kRecordFormat) {
    problem("the record is not a certificate record (" + std::string(kRecordFormat) + ")");
  } else {
    if (rec.value("number", "") != c.number) problem("the record's number is not the certificate's");
    if (!rec.contains("pupil") || !rec["pupil"].is_object() || rec["pupil"].value("id", json()) != json(c.pupil_id))
      problem("the record names another pupil than the certificate's");
    // Each exam it cites must be the exam recorded, passed still, and a practical one's evidence must hold.
    std::vector<json> cited;
    if (rec.contains("theory") && rec["theory"].is_object()) cited.push_back(rec["theory"]);
    if (rec.contains("practical") && rec["practical"].is_array())
      for (const json& p : rec["practical"]) cited.push_back(p);
    if (cited.size() < 2) problem("the record does not cite a theory and a practical exam");
    std::optional<ChainKeys> chain_keys;
    if (!keys.ca_pem.empty()) chain_keys = keys;
    for (const json& x : cited) {
      const std::string label = x.value("kind", "?") + " exam " + x.value("exam_id", json()).dump();
      const auto e = x.value("exam_id", json()).is_number_integer() ? db.get_exam(x["exam_id"].get<int64_t>()) : std::nullopt;
      if (!e) { problem(label + " is not in the school's records"); continue; }
      if (e->pupil_id != c.pupil_id || name(e->kind) != x.value("kind", "")) { problem(label + " is another pupil's or another kind"); continue; }
      if (exam_row_sha256(*e) != x.value("record_sha256", "")) {
        problem(label + " was changed since the certificate was issued: its record is not the one cited");
        continue;
      }
      if (!e->passed) { problem(label + " is not a pass"); continue; }
      bool withdrawn_pass = false;
      for (const auto& corr : db.list_exam_corrections(e->id)) {
        const json j = parsed(corr.correction);
        if (j.is_object() && j.contains("passed") && j["passed"].is_boolean()) withdrawn_pass = !j["passed"].get<bool>();
      }
      if (withdrawn_pass) { problem(label + "'s pass was withdrawn by a correction"); continue; }
      if (e->kind == ExamKind::kPractical) {
        const auto s = e->session_public_id ? db.get_session(*e->session_public_id) : std::nullopt;
        if (!s) { problem(label + " has no exam session"); continue; }
        if (exam_course(scenario_as_run(db, ctx.data_dir, *s)).is_null()) { problem(label + " was not taken on an exam course"); continue; }
        if (!chain_keys) continue;  // said above
        const ExamStanding st = exam_standing(db, *s, ctx.fleet->chain_anchor(), *chain_keys);
        if (!st.verified) { problem(label + "'s evidence does not verify: " + st.why); continue; }
        const auto entry = db.get_chain_entry(s->public_id);
        const json ej = entry ? parsed(entry->entry) : json();
        if (!x.contains("chain") || !ej.is_object() || x["chain"].value("entry_hash", json()) != ej.value("entry_hash", json())) {
          problem(label + "'s entry in the exam chain is not the one cited");
          continue;
        }
      }
      const std::string english = label + " is the exam recorded, passed, " +
                                  (e->kind == ExamKind::kPractical ? "with its evidence verified" : "as cited");
      out.checks.push_back(lang == i18n::kSourceLanguage
                               ? english
                               : ctx.words->text(lang, e->kind == ExamKind::kPractical ? "certificate:check.exam_verified" : "certificate:check.exam_cited",
                                                 {{"kind", ctx.words->text(lang, "certificate:kind." + x.value("kind", "theory"))},
                                                  {"id", x.value("exam_id", json())}}));
    }
  }
  out.status = out.revocation ? "revoked" : out.problems.empty() ? "valid" : "does_not_verify";
  return out;
}

json certificate_json(Context& ctx, const store::CertificateRecord& c, const CertificateCheck& check) {
  json revocation = nullptr;
  if (check.revocation) {
    const json by = person_json(ctx.db(), check.revocation->revoked_by);
    revocation = {{"at", check.revocation->at}, {"reason", check.revocation->reason}, {"by", by["name"].is_null() ? by["username"] : by["name"]}};
  }
  return {{"number", c.number}, {"status", check.status}, {"checks", check.checks}, {"problems", check.problems},
          {"revocation", revocation}, {"certificate", check.record.is_object() ? check.record : json(nullptr)},
          {"verify_page", "verify.html?number=" + c.number}, {"verify_api", "/api/certificates/" + c.number},
          {"verify_url", ctx.public_url.empty() ? json(nullptr) : json(ctx.public_url + "/verify.html?number=" + c.number)}};
}

}  // namespace forklift::server
