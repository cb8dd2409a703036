// Exam records and what they justify: an exam with its corrections (a correction is a new,
// audited record; nothing changes a finished exam), the licence, issued only on a passed theory
// exam and a passed practical exam on an exam course whose evidence verifies, with its
// certificate; the certificate's verification, open to anyone with its number, and its
// revocation.
#include <cmath>

#include "api.h"
#include "certificates.h"
#include "exam_results.h"
#include "forklift/security/certificate.h"
#include "routes.h"

namespace forklift::server {

using store::Role;

namespace {

constexpr size_t kMaxReason = 1000;  // characters of a correction's or revocation's reason

std::string reason_field(const json& b) {
  const std::string reason = field<std::string>(b, "reason", std::string());
  if (reason.find_first_not_of(" \t\r\n") == std::string::npos) throw ApiError(400, "bad_request", "'reason' is required: say why");
  if (reason.size() > kMaxReason) throw ApiError(400, "bad_request", "'reason' is longer than 1000 characters");
  return reason;
}

// The exam record `id` and its pupil, if `p` may see them.
std::pair<store::ExamRecord, store::Pupil> visible_exam(Context& ctx, const Principal& p, int64_t id) {
  const auto e = ctx.db().get_exam(id);
  if (!e) throw ApiError(404, "not_found", "no exam " + std::to_string(id));
  return {*e, visible_pupil(ctx, p, e->pupil_id)};
}

// The exam as history gives it (with its corrections).
json exam_now(Context& ctx, const store::Pupil& pupil, int64_t exam_id) {
  const auto h = ctx.db().history(pupil.id, store::now_iso8601());
  for (const auto& r : exam_results(ctx, *h))
    if (r.record && r.record->id == exam_id) return exam_result_json(ctx, r);
  throw ApiError(404, "not_found", "no exam " + std::to_string(exam_id));
}

// The certificate of that number, its number as stored.
std::optional<store::CertificateRecord> certificate_numbered(Context& ctx, const std::string& typed) {
  if (typed.size() > 64) return std::nullopt;
  return ctx.db().find_certificate(canonical_certificate_number(typed));
}

}  // namespace

void exam_routes(Routes& svr, Context& ctx) {
  svr.Get(R"(/api/exams/(\d+))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const auto [e, pupil] = visible_exam(ctx, p, path_id(req));
    send_json(res, 200, exam_now(ctx, pupil, e.id));
  }));

  // A correction of a finished exam: {"reason", "passed"?, "score"?, "note"?}, by an examiner or an
  // administrator. A new record beside the original, which stays as it was; audited.
  svr.Post(R"(/api/exams/(\d+)/corrections)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kExaminer});
    const auto [e, pupil] = visible_exam(ctx, p, path_id(req));
    const json b = body_json(req);  // reason, passed, score and note only, each of its type (ExamCorrection)
    const std::string reason = reason_field(b);
    json correction = json::object();
    if (b.contains("passed")) correction["passed"] = b["passed"];
    if (b.contains("score")) {
      const double score = number_field<double>(b["score"], "score");
      const double top = e.kind == ExamKind::kTheory ? 1.0 : 100.0;
      if (!(score >= 0 && score <= top))
        throw ApiError(400, "bad_request", "'score' must be in [0, " + std::string(e.kind == ExamKind::kTheory ? "1]" : "100]"));
      correction["score"] = score;
    }
    if (b.contains("note")) {
      correction["note"] = field<std::string>(b, "note");
    }
    if (correction.empty()) throw ApiError(400, "bad_request", "a correction gives at least one of passed, score or note");
    ctx.db().batch([&] {
      store::ExamCorrection c;
      c.exam_id = e.id;
      c.corrected_by = p.user_id;
      c.reason = reason;
      c.correction = correction.dump();
      const int64_t id = ctx.db().add_exam_correction(c);
      audit(ctx.db(), p, pupil.id, "exam_corrected",
            {{"exam_id", e.id}, {"correction_id", id}, {"reason", reason}, {"correction", correction},
             {"original", {{"kind", name(e.kind)}, {"score", e.score}, {"passed", e.passed}, {"taken_at", e.taken_at}}}});
    });
    res.set_header("Location", "/api/exams/" + std::to_string(e.id));  // the exam, which lists its corrections
    send_json(res, 201, exam_now(ctx, pupil, e.id));
  }));

  // A licence, issued only on a passed practical exam taken on an exam course whose evidence
  // verifies and what the school's licence rules ask beside it (a recent theory pass, marked
  // training sessions: certificates.h), refused with each missing item named; with it, the
  // certificate, numbered and signed. Re-evaluation
  // falls due three years after the evaluation (OSHA 1910.178(l)(4)(iii)).
  svr.Post(R"(/api/pupils/(\d+)/licence)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kExaminer});
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    // The certificate's language: {"language"} when given (LicenceRequest), else the pupil's.
    const std::optional<std::string> asked = req.body.empty() ? std::nullopt : language_field(ctx, body_json(req));
    const std::string language = asked ? *asked : ctx.words->supported(ctx.db().pupil_language(pupil.id));
    const ChainKeys keys = ctx.fleet->chain_keys();
    json licence, certificate;
    ctx.db().batch([&] {  // read inside, so that the exams cited are the ones standing when it is issued
      const auto h = ctx.db().history(pupil.id, store::now_iso8601());
      const std::vector<ExamResult> results = exam_results(ctx, *h);
      const LicenceBasis basis = licence_basis(ctx, pupil, *h, results, store::now_iso8601());
      if (!basis.why_not.empty()) throw ApiError(409, "not_certified", basis.why_not);
      if (keys.server_key_file.empty())  // a practical exam verifies only under security: a school's server misconfigured since
        throw ApiError(409, "security_required",
                       "a licence comes with a certificate the server signs: start the server with --security DIR (scripts/forklift-pki.sh)");
      const std::string now = store::now_iso8601();
      store::LicenceRecord l;
      l.pupil_id = pupil.id;
      l.issued_at = now;
      l.issued_by = p.username;
      l.id = ctx.db().add_licence(pupil.id, now, p.username);
      l.reevaluation_due = store::add_years_iso8601(now, 3);
      store::CertificateRecord c;
      c.number = new_certificate_number(ctx.school_name);
      c.pupil_id = pupil.id;
      c.licence_id = l.id;
      c.issued_at = now;
      c.issued_by = p.user_id;
      c.record = certificate_record(ctx, pupil, basis, l, p.user_id, c.number, ctx.school_name, language).dump(-1, ' ', false,
                                                                                                           json::error_handler_t::replace);
      c.signature = security::sign_certificate(c.record, keys.server_key_file, keys.server_cert_file).dump();
      ctx.db().add_certificate(c);
      licence = licence_json(l);
      licence["certificate"] = c.number;
      audit(ctx.db(), p, pupil.id, "licence_issued", licence);
    });
    res.set_header("Location", "/api/pupils/" + std::to_string(pupil.id) + "/certificate");
    send_json(res, 201, licence);
  }));

  // The pupil's certificate, the latest issued, with what its check finds: for staff of the
  // pupil's school and the pupil. None before the licence is issued (409 not_certified).
  svr.Get(R"(/api/pupils/(\d+)/certificate)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    const store::Pupil pupil = visible_pupil(ctx, p, path_id(req));
    const auto all = ctx.db().list_certificates(pupil.id);
    if (all.empty()) {
      const auto h = ctx.db().history(pupil.id, store::now_iso8601());
      const LicenceBasis basis = licence_basis(ctx, pupil, *h, exam_results(ctx, *h), store::now_iso8601());
      throw ApiError(409, "not_certified",
                     h->licence ? "the licence of " + pupil.name + " was issued before licences came with a numbered certificate: an "
                                      "examiner issues it again to make one"
                     : !basis.why_not.empty() ? basis.why_not + "; and no licence has been issued"
                                              : "no licence has been issued to " + pupil.name +
                                                    " yet: the certificate is made when an examiner issues the licence");
    }
    send_json(res, 200, certificate_json(ctx, all.back(), check_certificate(ctx, all.back())));
  }));

  // Anyone with the number, no login: whether the certificate is valid, revoked, or does not
  // verify, with what it says. Look-ups of numbers that do not exist are limited per address, as
  // logins are, so that numbers cannot be tried one after another.
  svr.Get(R"(/api/certificates/([A-Za-z0-9 _-]{1,64}))", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const std::string typed = req.matches[1];
    // Counted by address alone (under both of the throttle's keys): one guesser cannot lock out the rest.
    auto attempt = ctx.certificate_lookups->attempt(ctx.db(), req.remote_addr, req.remote_addr);
    if (const int wait_s = attempt.retry_after_s()) {
      res.set_header("Retry-After", std::to_string(wait_s));
      throw ApiError(429, "too_many_attempts", "too many look-ups of unknown certificate numbers from this address: try again in " +
                                                   std::to_string(wait_s) + " s");
    }
    const auto c = certificate_numbered(ctx, typed);
    if (!c) throw ApiError(404, "not_found", "no certificate is numbered " + canonical_certificate_number(typed));
    attempt.succeeded();
    send_json(res, 200, certificate_json(ctx, *c, check_certificate(ctx, *c)));
  }));

  // Revokes a certificate: {"reason"}, by an examiner or an administrator of the pupil's school.
  // Kept for ever, and audited; the verification then says "revoked".
  svr.Post(R"(/api/certificates/([A-Za-z0-9 _-]{1,64})/revoke)", guarded([&](const httplib::Request& req, httplib::Response& res) {
    const Principal p = authenticate(ctx, req);
    require_role(p, {Role::kAdmin, Role::kExaminer});
    const auto c = certificate_numbered(ctx, req.matches[1]);
    if (!c) throw ApiError(404, "not_found", "no certificate is numbered " + canonical_certificate_number(req.matches[1]));
    const store::Pupil pupil = visible_pupil(ctx, p, c->pupil_id);
    const std::string reason = reason_field(body_json(req));
    if (ctx.db().certificate_revocation(c->id)) throw ApiError(409, "already_revoked", "certificate " + c->number + " is revoked already");
    ctx.db().batch([&] {
      store::CertificateRevocation r;
      r.certificate_id = c->id;
      r.revoked_by = p.user_id;
      r.reason = reason;
      const int64_t id = ctx.db().revoke_certificate(r);
      audit(ctx.db(), p, pupil.id, "certificate_revoked", {{"certificate", c->number}, {"revocation_id", id}, {"reason", reason}});
    });
    send_json(res, 200, certificate_json(ctx, *c, check_certificate(ctx, *c)));
  }));
}

}  // namespace forklift::server
