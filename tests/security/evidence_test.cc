// Tamper-evidence for exam records: a school PKI made with the openssl CLI in a temporary folder, a realistic
// control log and record, a 3-exam chain; the untouched evidence verifies and each kind of tampering is caught
// by the check that names it.
#include "forklift/security/evidence.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sec = forklift::security;
using nlohmann::json;

namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path);
}

// openssl's own configuration for this test: CA and leaf extensions, and `openssl ca` for the CRL.
const char* kPkiConfig = R"([req]
distinguished_name = dn
prompt = no
[dn]
CN = placeholder
[v3_ca]
basicConstraints = critical,CA:TRUE
keyUsage = critical,keyCertSign,cRLSign
subjectKeyIdentifier = hash
[v3_leaf]
basicConstraints = critical,CA:FALSE
keyUsage = critical,digitalSignature
subjectKeyIdentifier = hash
authorityKeyIdentifier = keyid
[ca]
default_ca = school
[school]
database = index.txt
crlnumber = crlnumber
default_md = sha256
default_crl_days = 30
)";

struct Event {
  int64_t tick;
  std::string kind;
  int worry;
};

const std::vector<Event> kEvents = {{1607, "travel_forks_low", 1},
                                    {6789, "off_route", 3},
                                    {12854, "speed_open_aisle", 3},
                                    {23916, "deadman_stop", 0},
                                    {26000, "parked_forks_raised", 5}};

std::string Hex(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%a", v);
  return buf;
}

// A control log as forklift-worker writes it (sim/session/src/session_log.cc).
std::string ControlLog(const std::string& session, const std::string& cab, double mark, bool passed) {
  std::string state;
  for (int i = 0; i < 32; ++i) {
    if (i) state += ' ';
    state += Hex(i % 5 == 0 ? 0.0 : 0.25 * i - 1.3);
  }
  std::string s = "forklift-control-log 1\nsession " + session + "\ncab " + cab +
                  "\ntruck /work/main/data/trucks/linde_e16c.json\ntick 0x1.0624dd2f1a9fcp-10\n"
                  "integrator cvode 0x1.3a92a30553261p-12 2\ninit " +
                  state + "\nscenario /work/main/data/scenarios/exam_yard.json\nmode exam\n";
  uint32_t seq = 0;
  for (const Event& e : kEvents) {
    for (int k = 0; k < 2; ++k) {
      ++seq;
      s += "i " + std::to_string(e.tick - 40 + 20 * k) + " " + std::to_string(seq) + " " + Hex(500.0 + seq) +
           " 0x0p+0 " + Hex(-0.131 * k) + " 0x0p+0 " + Hex(0.05 * k) + " 0x0p+0\n";
    }
    if (e.kind == "deadman_stop") s += "dm " + std::to_string(e.tick - 1) + " 1\n";
    s += "e " + std::to_string(e.tick) + " " + e.kind + " " + std::to_string(e.worry) + "\n";
  }
  char score[96];
  std::snprintf(score, sizeof score, "score %a %d %d ", mark, passed ? 1 : 0, 18);
  s += std::string(score) + "duration\nend 26000\nfinal " + state + "\n";
  return s;
}

json Record(const std::string& session, const std::string& cab, double mark, bool passed) {
  json events = json::array();
  json counts = json::object();
  int seq = 0;
  for (const Event& e : kEvents) {
    events.push_back({{"seq", ++seq}, {"kind", e.kind}, {"worry", e.worry}});
    counts[e.kind] = counts.value(e.kind, 0) + 1;
  }
  return {{"session", session},
          {"pupil_id", 7},
          {"cab", cab},
          {"scenario", "exam_yard"},
          {"mode", "exam"},
          {"examiner", "E. Smith"},
          {"examiner_id", 3},
          {"mark", mark},
          {"passed", passed},
          {"counts", counts},
          {"events", events},
          {"exam_id", 11},
          {"ended_at", "2026-11-23T10:30:00Z"}};
}

// entry_hash as the format defines it, written out here rather than taken from the library.
std::string EntryHash(const json& e) {
  return sec::sha256_hex(e["prev_hash"].get<std::string>() + "\n" + e["record"].dump() + "\n" +
                         e["log_sha256"].get<std::string>() + "\n" + e["log_signature"].get<std::string>() + "\n");
}

// Re-links and re-hashes every entry after an edit, as someone without the server's key could.
void Rehash(json& chain) {
  std::string prev(64, '0');
  for (json& e : chain) {
    e["prev_hash"] = prev;
    e["entry_hash"] = EntryHash(e);
    prev = e["entry_hash"].get<std::string>();
  }
}

std::string Report(const sec::VerifyReport& r) {
  std::string s = r.ok ? "ok\n" : "NOT ok\n";
  for (const auto& p : r.passed) s += "  passed: " + p + "\n";
  for (const auto& p : r.problems) s += "  problem: " + p + "\n";
  return s;
}

// Not ok, and some problem line contains `needle`.
::testing::AssertionResult HasProblem(const sec::VerifyReport& r, const std::string& needle) {
  if (r.ok)
    return ::testing::AssertionFailure() << "verified, expected a problem with '" << needle << "'\n" << Report(r);
  for (const auto& p : r.problems)
    if (p.find(needle) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "no problem mentions '" << needle << "'\n" << Report(r);
}

::testing::AssertionResult Verified(const sec::VerifyReport& r) {
  if (r.ok && r.problems.empty()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << Report(r);
}

// How Evidence() builds the evidence: which files sign session s-000002's log, and the chain.
struct Options {
  std::string worker = "worker";  // <worker>.key and <worker>.pem
  bool server_signed = false;
  std::string server = "server";
  std::string session = "s-000002";  // the exam the evidence is for
  bool chained = true;               // false: that exam ended but was never chained
};

class EvidenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    try {
      MakePki();
    } catch (const std::exception& e) {
      pki_error_ = e.what();
    }
  }
  static void TearDownTestSuite() {
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }
  void SetUp() override { ASSERT_TRUE(pki_error_.empty()) << "making the test PKI: " << pki_error_; }

  static std::string Path(const std::string& name) { return dir_ + "/" + name; }

  static void Run(const std::string& command) {
    const std::string full = "cd '" + dir_ + "' && " + command + " >>openssl.log 2>&1";
    if (std::system(full.c_str()) != 0)
      throw std::runtime_error(command + " failed:\n" + ReadFile(Path("openssl.log")));
  }

  static void MakeCa(const std::string& name, const std::string& cn) {
    Run("openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out " + name + ".key");
    Run("openssl req -config pki.cnf -x509 -new -key " + name + ".key -subj '/CN=" + cn +
        "' -extensions v3_ca -days 30 -out " + name + ".pem");
  }

  // A leaf certificate `name`.pem for `cn`, with its key `name`.key, issued by the CA `ca`.
  static void Issue(const std::string& name, const std::string& cn, const std::string& ca, int serial,
                    const std::string& keygen = "") {
    Run(keygen.empty() ? "openssl ecparam -name prime256v1 -genkey -noout -out " + name + ".key"
                       : keygen + " -out " + name + ".key");
    Run("openssl req -config pki.cnf -new -key " + name + ".key -subj '/CN=" + cn + "' -out " + name + ".csr");
    Run("openssl x509 -req -in " + name + ".csr -CA " + ca + ".pem -CAkey " + ca + ".key -set_serial " +
        std::to_string(serial) + " -days 30 -extfile pki.cnf -extensions v3_leaf -out " + name + ".pem");
  }

  static void MakePki() {
    const char* tmp = std::getenv("TMPDIR");
    std::string templ = std::string(tmp && *tmp ? tmp : "/tmp") + "/forklift-security-XXXXXX";
    if (!mkdtemp(templ.data())) throw std::runtime_error("mkdtemp failed");
    dir_ = templ;
    WriteFile(Path("pki.cnf"), kPkiConfig);
    WriteFile(Path("index.txt"), "");
    WriteFile(Path("crlnumber"), "01\n");
    MakeCa("ca", "Forklift School CA");
    Issue("worker", "worker.cab1", "ca", 101);
    Issue("worker2", "worker.cab2", "ca", 102);
    Issue("server", "server", "ca", 103);
    Issue("revoked", "worker.cab1", "ca", 104);
    MakeCa("rogue_ca", "Forklift School CA");  // same name, different key
    Issue("rogue_worker", "worker.cab1", "rogue_ca", 101);
    Run("openssl ca -config pki.cnf -revoke revoked.pem -keyfile ca.key -cert ca.pem");
    Run("openssl ca -config pki.cnf -gencrl -keyfile ca.key -cert ca.pem -out crl.pem");
    ca_pem_ = ReadFile(Path("ca.pem"));
    crl_pem_ = ReadFile(Path("crl.pem"));
  }

  // Evidence for s-000002 (or o.session), the middle of three exams (s-000003 on cab2).
  static json Evidence(const Options& o = {}) {
    struct Exam {
      std::string session, cab, worker;
      double mark;
      bool passed;
    };
    const std::vector<Exam> exams = {{"s-000001", "cab1", "worker", 64.5, true},
                                     {"s-000002", "cab1", o.worker, 71.35, true},
                                     {"s-000003", "cab2", "worker2", 38.2, false}};
    json chain = json::array();
    json evidence;
    std::string prev(64, '0');
    for (size_t i = 0; i < exams.size(); ++i) {
      const Exam& x = exams[i];
      const std::string log = ControlLog(x.session, x.cab, x.mark, x.passed);
      const json sig = sec::sign_exam_log(x.session, x.cab, log, Path(x.worker + ".key"), Path(x.worker + ".pem"));
      const json record = Record(x.session, x.cab, x.mark, x.passed);
      if (x.session == o.session)
        evidence = {{"session", x.session}, {"record", record}, {"log", log}, {"signature", sig}};
      if (x.session == o.session && !o.chained) continue;
      chain.push_back(sec::make_chain_entry(static_cast<int64_t>(chain.size() + 1), prev, record, sig["log_sha256"],
                                            sig["signature"], o.server_signed ? Path(o.server + ".key") : "",
                                            Path(o.server + ".pem")));
      prev = chain.back()["entry_hash"].get<std::string>();
    }
    evidence["chain"] = chain;
    return evidence;
  }

  static sec::VerifyReport Verify(const json& evidence, const std::string& crl = "") {
    return sec::verify_exam_evidence(evidence, ca_pem_, crl);
  }
  // As forklift-menu verify checks: every entry server-signed, an anchor required.
  static sec::VerifyReport Strict(const json& evidence) {
    return sec::verify_exam_evidence(evidence, ca_pem_, "", {.require_server_signatures = true, .require_anchor = true});
  }
  // Server-signed evidence for `session` with the anchor the server keeps beside the whole chain.
  static json Anchored(const std::string& session = "s-000002", bool chained = true) {
    json ev = Evidence({.server_signed = true, .session = session, .chained = chained});
    json entry = nullptr;
    for (const json& e : ev["chain"])
      if (e["session"] == session) entry = sec::chain_anchor_line(e);
    ev["anchor"] = {{"head", sec::chain_anchor_line(ev["chain"].back())}, {"entry", entry}};
    return ev;
  }

  static inline std::string dir_;
  static inline std::string pki_error_;
  static inline std::string ca_pem_;
  static inline std::string crl_pem_;
};

TEST_F(EvidenceTest, Sha256HexMatchesKnownDigests) {
  EXPECT_EQ(sec::sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sec::sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

// The signature object has the fixed format, and openssl's own CLI verifies it over the documented message.
TEST_F(EvidenceTest, LogSignatureHasTheFixedFormatAndOpensslVerifiesIt) {
  const std::string log = ControlLog("s-000001", "cab1", 64.5, true);
  const json sig = sec::sign_exam_log("s-000001", "cab1", log, Path("worker.key"), Path("worker.pem"));
  EXPECT_EQ(sig["format"], "forklift-exam-log-signature/1");
  EXPECT_EQ(sig["session"], "s-000001");
  EXPECT_EQ(sig["cab"], "cab1");
  EXPECT_EQ(sig["log_sha256"], sec::sha256_hex(log));
  EXPECT_EQ(sig.size(), 6u) << sig.dump(2);
  EXPECT_EQ(sec::certificate_common_name(sig["signer_certificate"]), "worker.cab1");

  WriteFile(Path("message.txt"), "forklift-exam-log/1\ns-000001\ncab1\n" + sec::sha256_hex(log) + "\n");
  WriteFile(Path("sig.b64"), sig["signature"].get<std::string>());
  WriteFile(Path("signer.pem"), sig["signer_certificate"].get<std::string>());
  Run("openssl base64 -d -A -in sig.b64 -out sig.der");
  Run("openssl x509 -in signer.pem -pubkey -noout -out signer_pub.pem");
  EXPECT_NO_THROW(Run("openssl dgst -sha256 -verify signer_pub.pem -signature sig.der message.txt"));
  // ...and the same signature does not fit another cab's message.
  WriteFile(Path("message.txt"), "forklift-exam-log/1\ns-000001\ncab2\n" + sec::sha256_hex(log) + "\n");
  EXPECT_THROW(Run("openssl dgst -sha256 -verify signer_pub.pem -signature sig.der message.txt"), std::runtime_error);
}

TEST_F(EvidenceTest, ChainEntriesFollowTheFormulaAndServerSignaturesVerifyWithOpenssl) {
  const json chain = Evidence({.server_signed = true})["chain"];
  ASSERT_EQ(chain.size(), 3u);
  std::string prev(64, '0');
  for (size_t i = 0; i < chain.size(); ++i) {
    const json& e = chain[i];
    EXPECT_EQ(e["seq"], i + 1);
    EXPECT_EQ(e["session"], e["record"]["session"]);
    EXPECT_EQ(e["prev_hash"], prev);
    EXPECT_EQ(e["entry_hash"], EntryHash(e));
    prev = e["entry_hash"].get<std::string>();
    ASSERT_TRUE(e["server_signature"].is_string());
    EXPECT_EQ(sec::certificate_common_name(e["server_certificate"]), "server");
  }
  WriteFile(Path("hash.txt"), chain[1]["entry_hash"].get<std::string>());
  WriteFile(Path("ssig.b64"), chain[1]["server_signature"].get<std::string>());
  Run("openssl base64 -d -A -in ssig.b64 -out ssig.der");
  Run("openssl x509 -in server.pem -pubkey -noout -out server_pub.pem");
  EXPECT_NO_THROW(Run("openssl dgst -sha256 -verify server_pub.pem -signature ssig.der hash.txt"));

  const json unsigned_chain = Evidence()["chain"];
  EXPECT_TRUE(unsigned_chain[0]["server_signature"].is_null());
  EXPECT_TRUE(unsigned_chain[0]["server_certificate"].is_null());
}

TEST_F(EvidenceTest, CertificateNamesAndIssuers) {
  const std::string worker = ReadFile(Path("worker.pem"));
  EXPECT_EQ(sec::certificate_common_name(worker), "worker.cab1");
  EXPECT_EQ(sec::certificate_common_name(ReadFile(Path("server.pem"))), "server");
  EXPECT_THROW(sec::certificate_common_name("not a certificate"), std::runtime_error);

  std::string why;
  EXPECT_TRUE(sec::certificate_issued_by(worker, ca_pem_, "", &why)) << why;
  EXPECT_TRUE(sec::certificate_issued_by(worker, ca_pem_, crl_pem_, &why)) << why;
  EXPECT_FALSE(sec::certificate_issued_by(ReadFile(Path("rogue_worker.pem")), ca_pem_, "", &why));
  EXPECT_NE(why.find("issuer"), std::string::npos) << why;
  EXPECT_TRUE(sec::certificate_issued_by(ReadFile(Path("revoked.pem")), ca_pem_, "", &why)) << why;
  EXPECT_FALSE(sec::certificate_issued_by(ReadFile(Path("revoked.pem")), ca_pem_, crl_pem_, &why));
  EXPECT_NE(why.find("revoked"), std::string::npos) << why;
  EXPECT_FALSE(sec::certificate_issued_by("garbage", ca_pem_, "", &why));
  EXPECT_FALSE(sec::certificate_issued_by(worker, "garbage", "", &why));
  EXPECT_FALSE(sec::certificate_issued_by(worker, ca_pem_, "garbage", &why));
  EXPECT_TRUE(sec::certificate_issued_by(worker, ca_pem_, "", nullptr));
}

TEST_F(EvidenceTest, UntouchedEvidenceVerifies) {
  const sec::VerifyReport r = Verify(Evidence());
  ASSERT_TRUE(Verified(r));
  // One passed line per check, so a report can be read by an examiner.
  const std::string all = Report(r);
  for (const char* check : {"issued by the school CA", "\"worker.cab1\"", "log SHA-256", "log signature verifies",
                            "log header session", "log score mark", "events match", "each entry_hash recomputes",
                            "exactly one chain entry", "record equals the current record", "log_signature equal"})
    EXPECT_NE(all.find(check), std::string::npos) << check << "\n" << all;
}

TEST_F(EvidenceTest, UntouchedServerSignedEvidenceVerifiesWithTheCrl) {
  const sec::VerifyReport r = Verify(Evidence({.server_signed = true}), crl_pem_);
  ASSERT_TRUE(Verified(r));
  EXPECT_NE(Report(r).find("all 3 server signatures verify"), std::string::npos) << Report(r);
  EXPECT_NE(Report(r).find("not revoked"), std::string::npos) << Report(r);
}

TEST_F(EvidenceTest, RsaWorkerKeyIsAccepted) {
  Issue("rsa_worker", "worker.cab1", "ca", 105, "openssl genpkey -algorithm RSA -pkeyopt rsa_keygen_bits:2048");
  ASSERT_TRUE(Verified(Verify(Evidence({.worker = "rsa_worker", .server_signed = true}))));
}

// Every single-byte change anywhere in the log is caught by the log's hash.
TEST_F(EvidenceTest, OneChangedLogByteAnywhereIsDetected) {
  const json good = Evidence();
  const std::string log = good["log"];
  ASSERT_GT(log.size(), 1000u);
  for (size_t i = 0; i < log.size(); ++i) {
    json bad = good;
    std::string changed = log;
    changed[i] = static_cast<char>(changed[i] ^ 0x01);
    bad["log"] = changed;
    const sec::VerifyReport r = Verify(bad);
    ASSERT_TRUE(HasProblem(r, "the log is not the one signed")) << "byte " << i << " changed";
  }
}

TEST_F(EvidenceTest, RecordMarkChangedByOneIsDetected) {
  json bad = Evidence();
  bad["record"]["mark"] = bad["record"]["mark"].get<double>() + 1;
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(
      r, "log score mark 71.349999999999994 differs from the record's mark 72.349999999999994"));
  EXPECT_TRUE(HasProblem(r, "record differs from the current record in: mark"));
}

// Changing the mark in the chain too, and re-hashing it, still leaves the signed log disagreeing.
TEST_F(EvidenceTest, RecordMarkChangedEverywhereStillDisagreesWithTheSignedLog) {
  json bad = Evidence();
  bad["record"]["mark"] = 72.35;
  bad["chain"][1]["record"]["mark"] = 72.35;
  Rehash(bad["chain"]);
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(r, "differs from the record's mark"));
  EXPECT_EQ(r.problems.size(), 1u) << Report(r);
}

TEST_F(EvidenceTest, PassedFlippedIsDetected) {
  json bad = Evidence();
  bad["record"]["passed"] = false;
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(r, "log score says passed but the record's passed is false"));
  EXPECT_TRUE(HasProblem(r, "record differs from the current record in: passed"));
}

TEST_F(EvidenceTest, EventRemovedFromTheRecordIsDetected) {
  json bad = Evidence();
  bad["record"]["events"].erase(1);
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(
      HasProblem(r, "event 2 differs: the log has \"off_route\" worry 3, the record \"speed_open_aisle\" worry 3"));
  EXPECT_TRUE(HasProblem(r, "log has 5 events, the record 4"));
}

TEST_F(EvidenceTest, EventWorryChangedIsDetected) {
  json bad = Evidence();
  bad["record"]["events"][4]["worry"] = 1;
  EXPECT_TRUE(HasProblem(Verify(bad), "event 5 differs: the log has \"parked_forks_raised\" worry 5"));
}

// Nothing in the log says who examined: only the chain's copy of the record catches this.
TEST_F(EvidenceTest, ExaminerChangedIsDetectedByTheChainRecord) {
  json bad = Evidence();
  bad["record"]["examiner"] = "A. Friend";
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(r, "chain entry 2's record differs from the current record in: examiner"));
  EXPECT_EQ(r.problems.size(), 1u) << Report(r);
}

TEST_F(EvidenceTest, EarlierChainEntryChangedIsAHashMismatch) {
  json bad = Evidence({.server_signed = true});
  bad["chain"][0]["record"]["mark"] = 90.0;
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(r, "chain entry 1 (session \"s-000001\")'s entry_hash does not recompute"));
  EXPECT_EQ(r.problems.size(), 1u) << Report(r);
}

// A freshly made entry in place of an earlier one hashes correctly itself, but the next entry no longer links.
TEST_F(EvidenceTest, ReplacedOrRemovedEarlierEntryBreaksTheLinks) {
  json bad = Evidence();
  json record = bad["chain"][0]["record"];
  record["mark"] = 90.0;
  bad["chain"][0] = sec::make_chain_entry(1, std::string(64, '0'), record, bad["chain"][0]["log_sha256"],
                                          bad["chain"][0]["log_signature"], "", "");
  sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(r, "chain entry 2 (session \"s-000002\")'s prev_hash"));
  EXPECT_TRUE(HasProblem(
      r, "does not link to the entry_hash " + bad["chain"][0]["entry_hash"].get<std::string>() + " of entry 1"));
  EXPECT_EQ(r.problems.size(), 1u) << Report(r);

  json removed = Evidence();
  removed["chain"].erase(0);
  removed["chain"][0]["seq"] = 1;
  removed["chain"][1]["seq"] = 2;
  r = Verify(removed);
  EXPECT_TRUE(HasProblem(r, "chain entry 1 (session \"s-000002\")'s prev_hash"));
  EXPECT_TRUE(HasProblem(r, "is not 64 zeros"));
}

// Re-hashing the whole chain hides the edit from the hashes, but not from the server's signatures.
TEST_F(EvidenceTest, RehashedChainWithoutTheServerKeyIsASignatureMismatch) {
  json bad = Evidence({.server_signed = true});
  bad["chain"][0]["record"]["mark"] = 90.0;
  Rehash(bad["chain"]);
  const sec::VerifyReport r = Verify(bad);
  for (const char* e : {"chain entry 1 (session \"s-000001\")", "chain entry 2 (session \"s-000002\")",
                        "chain entry 3 (session \"s-000003\")"})
    EXPECT_TRUE(HasProblem(r, std::string(e) + "'s server_signature does not verify over its entry_hash"));
  for (const std::string& p : r.problems) EXPECT_EQ(p.find("does not recompute"), std::string::npos) << p;
  // Without server signatures the same rewrite is only caught if it touches this session's own facts.
  json unsigned_bad = Evidence();
  unsigned_bad["chain"][0]["record"]["mark"] = 90.0;
  Rehash(unsigned_bad["chain"]);
  EXPECT_TRUE(Verified(Verify(unsigned_bad)));
  // ...which is why a secured school's verifier requires every entry to be server-signed.
  const sec::VerifyReport strict = sec::verify_exam_evidence(unsigned_bad, ca_pem_, "", {.require_server_signatures = true});
  EXPECT_TRUE(HasProblem(strict, "chain entry 1 (session \"s-000001\") is not server-signed")) << Report(strict);
  EXPECT_TRUE(Verified(sec::verify_exam_evidence(Evidence({.server_signed = true}), ca_pem_, "", {.require_server_signatures = true})));
}

TEST_F(EvidenceTest, LogSignedByTheRogueCaIsDetected) {
  const sec::VerifyReport r = Verify(Evidence({.worker = "rogue_worker"}));
  EXPECT_TRUE(
      HasProblem(r, "signer certificate is not accepted by the school CA: unable to get local issuer certificate"));
  EXPECT_EQ(r.problems.size(), 1u) << Report(r);
}

TEST_F(EvidenceTest, WorkerCertificateForAnotherCabIsDetected) {
  const sec::VerifyReport r = Verify(Evidence({.worker = "worker2"}));
  EXPECT_TRUE(HasProblem(r, "signer certificate's common name is \"worker.cab2\", expected \"worker.cab1\""));
  EXPECT_EQ(r.problems.size(), 1u) << Report(r);
}

TEST_F(EvidenceTest, RevokedWorkerCertificateIsDetectedWithTheCrl) {
  const json evidence = Evidence({.worker = "revoked"});
  EXPECT_TRUE(Verified(Verify(evidence)));  // without the CRL nothing is wrong with it
  const sec::VerifyReport r = Verify(evidence, crl_pem_);
  EXPECT_TRUE(HasProblem(r, "signer certificate is not accepted by the school CA: certificate revoked"));
  EXPECT_EQ(r.problems.size(), 1u) << Report(r);
  EXPECT_TRUE(HasProblem(Verify(evidence, "not a CRL"), "the CRL PEM holds no CRL"));
}

TEST_F(EvidenceTest, ServerCertificateMustBeTheServers) {
  const sec::VerifyReport r = Verify(Evidence({.server_signed = true, .server = "worker"}));
  EXPECT_TRUE(
      HasProblem(r, "chain entry 1 (session \"s-000001\")'s server certificate has common name \"worker.cab1\""));
  const sec::VerifyReport rogue = Verify(Evidence({.server_signed = true, .server = "rogue_worker"}));
  EXPECT_TRUE(HasProblem(rogue, "server certificate is not accepted by the school CA"));
}

TEST_F(EvidenceTest, LogSignatureIsBoundToSessionAndCab) {
  json bad = Evidence();
  bad["signature"]["session"] = "s-000001";
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(r, "signature is for session \"s-000001\""));
  EXPECT_TRUE(HasProblem(r, "log signature does not verify"));
}

TEST_F(EvidenceTest, LogHeaderForAnotherSessionIsDetected) {
  // A genuinely signed log of another session, presented with this session's record.
  json bad = Evidence();
  const std::string log = ControlLog("s-000009", "cab1", 71.35, true);
  bad["log"] = log;
  bad["signature"] = sec::sign_exam_log("s-000002", "cab1", log, Path("worker.key"), Path("worker.pem"));
  const sec::VerifyReport r = Verify(bad);
  EXPECT_TRUE(HasProblem(r, "log header session is \"s-000009\" but the record's session is \"s-000002\""));
}

TEST_F(EvidenceTest, SessionWithTwoChainEntriesIsDetected) {
  json bad = Evidence();
  json again = bad["chain"][1];
  bad["chain"].push_back(sec::make_chain_entry(4, bad["chain"][2]["entry_hash"], again["record"], again["log_sha256"],
                                               again["log_signature"], "", ""));
  EXPECT_TRUE(HasProblem(Verify(bad), "session \"s-000002\" has 2 chain entries (2, 4), expected exactly one"));
  json none = Evidence();
  none["chain"].erase(1);
  Rehash(none["chain"]);
  EXPECT_TRUE(HasProblem(Verify(none), "session \"s-000002\" has no chain entry"));
}

TEST_F(EvidenceTest, ChainEntryWithAnotherLogIsDetected) {
  json bad = Evidence();
  bad["chain"][1]["log_sha256"] = bad["chain"][0]["log_sha256"];
  Rehash(bad["chain"]);
  EXPECT_TRUE(HasProblem(Verify(bad), "chain entry 2's log_sha256"));
}

// The anchor line is the entry's own seq, session, hash and server signature, in a fixed format.
TEST_F(EvidenceTest, AnchorLineHasTheFixedFormat) {
  const json chain = Evidence({.server_signed = true})["chain"];
  const json line = sec::chain_anchor_line(chain[1]);
  EXPECT_EQ(line, (json{{"format", "forklift-exam-chain-anchor/1"}, {"seq", 2}, {"session", "s-000002"},
                        {"entry_hash", chain[1]["entry_hash"]}, {"server_signature", chain[1]["server_signature"]}}));
  EXPECT_THROW(sec::chain_anchor_line(json::object()), std::runtime_error);
}

TEST_F(EvidenceTest, AnchoredEvidenceVerifiesStrictlyAndWithoutAnAnchorDoesNot) {
  const sec::VerifyReport r = Strict(Anchored());
  ASSERT_TRUE(Verified(r));
  EXPECT_EQ(r.verdict, sec::Verdict::kVerified);
  for (const char* check : {"the chain holds the anchor's head, entry 3 (session \"s-000003\")",
                            "session \"s-000002\"'s chain entry 2 is the anchored one",
                            "the anchor's head is signed by the server's key", "seqs without a gap"})
    EXPECT_NE(Report(r).find(check), std::string::npos) << check << "\n" << Report(r);
  const sec::VerifyReport none = Strict(Evidence({.server_signed = true}));
  EXPECT_TRUE(HasProblem(none, "evidence has no chain anchor"));
  EXPECT_EQ(none.verdict, sec::Verdict::kTampered);
}

// The database's last entry deleted (around the no-delete trigger): the chain that is left links and
// hashes, but the anchor outside the database still names the entry.
TEST_F(EvidenceTest, ChainCutShortAtItsEndIsTampering) {
  json ev = Anchored();
  ev["chain"].erase(2);
  const sec::VerifyReport r = Strict(ev);
  EXPECT_TRUE(HasProblem(r, "the chain is cut short: the anchor (kept outside the database) records entry 3 (session "
                            "\"s-000003\") but the chain ends at entry 2: 1 entry was deleted from its end"));
  EXPECT_EQ(r.verdict, sec::Verdict::kTampered);
  EXPECT_NE(Report(r).find("the anchor's head is signed by the server's key"), std::string::npos) << Report(r);
}

// The exam's own entry was the last: it is not "not chained" but deleted.
TEST_F(EvidenceTest, ExamWhoseEntryWasDeletedIsTamperingNotNotChained) {
  json ev = Anchored("s-000003");
  ev["chain"].erase(2);
  const sec::VerifyReport r = Strict(ev);
  EXPECT_TRUE(HasProblem(r, "the anchor records session \"s-000003\" as chain entry 3, but the chain has no entry for "
                            "it: its entry was deleted"));
  EXPECT_EQ(r.verdict, sec::Verdict::kTampered) << Report(r);
}

TEST_F(EvidenceTest, GapInTheChainIsTampering) {
  json ev = Anchored("s-000003");
  ev["chain"].erase(1);
  const sec::VerifyReport r = Strict(ev);
  EXPECT_TRUE(HasProblem(r, "chain: entry 2 is missing (a gap: the chain goes from entry 1 to entry 3)"));
  EXPECT_EQ(r.verdict, sec::Verdict::kTampered);
}

// An exam that ended but was never chained (the server refused it, or stopped first), beside a
// whole chain and anchor, is told apart from tampering...
TEST_F(EvidenceTest, ExamNeverChainedIsNotChained) {
  const json ev = Anchored("s-000002", /*chained=*/false);
  ASSERT_EQ(ev["chain"].size(), 2u);
  const sec::VerifyReport r = Strict(ev);
  EXPECT_TRUE(HasProblem(r, "session \"s-000002\" has no chain entry: it is not a chained exam"));
  EXPECT_EQ(r.verdict, sec::Verdict::kNotChained) << Report(r);
  // ...unless the chain beside it was cut short too.
  json cut = ev;
  cut["chain"].erase(1);
  EXPECT_EQ(Strict(cut).verdict, sec::Verdict::kTampered);
}

// A chain rewritten from some entry on, re-signed or not, is not the anchored one.
TEST_F(EvidenceTest, ChainThatIsNotTheAnchoredOneIsDetected) {
  json ev = Anchored();
  ev["anchor"]["head"]["entry_hash"] = std::string(64, 'a');
  const sec::VerifyReport r = Strict(ev);
  EXPECT_TRUE(HasProblem(r, "chain entry 3 is not the one anchored"));
  EXPECT_TRUE(HasProblem(r, "the anchor's head's server_signature does not verify with the server's key"));
  json other = Anchored();
  other["anchor"]["entry"] = other["anchor"]["head"];  // the line of another session
  EXPECT_TRUE(HasProblem(Strict(other), "the anchor's line for session \"s-000002\" is for session \"s-000003\""));
  json garbage = Anchored();
  garbage["anchor"]["head"] = json{{"seq", "3"}};
  EXPECT_TRUE(HasProblem(Strict(garbage), "the anchor's head is not an anchor line"));
  json unlisted = Anchored();
  unlisted["anchor"]["entry"] = nullptr;
  EXPECT_TRUE(HasProblem(Strict(unlisted), "the anchor has no line for session \"s-000002\"'s chain entry 2"));
}

// The server checks one exam with its own entry alone: its hash, signature and anchored line.
TEST_F(EvidenceTest, OneEntryOfTheChainVerifiesAgainstItsAnchorLine) {
  json ev = Anchored();
  const json entry = ev["chain"][1];
  const json line = sec::chain_anchor_line(entry);
  ev["chain"] = json::array({entry});
  ev["chain_from"] = 2;
  ev["anchor"] = {{"head", line}, {"entry", line}};
  ASSERT_TRUE(Verified(Strict(ev)));
  json moved = ev;
  moved["chain_from"] = 1;
  EXPECT_TRUE(HasProblem(Strict(moved), "is not 64 zeros"));
  json edited = ev;
  edited["record"]["pupil_id"] = 8;
  EXPECT_TRUE(HasProblem(Strict(edited), "chain entry 2's record differs from the current record in: pupil_id"));
  json rehashed = ev;
  rehashed["chain"][0]["record"]["pupil_id"] = 8;
  rehashed["record"]["pupil_id"] = 8;
  rehashed["chain"][0]["entry_hash"] = EntryHash(rehashed["chain"][0]);
  const sec::VerifyReport r = Strict(rehashed);
  EXPECT_TRUE(HasProblem(r, "chain entry 2 is not the one anchored"));
  EXPECT_TRUE(HasProblem(r, "server_signature does not verify"));
}

TEST_F(EvidenceTest, RecordAgainstItsSignedLogAlone) {
  const std::string log = ControlLog("s-000001", "cab1", 64.5, true);
  const json sig = sec::sign_exam_log("s-000001", "cab1", log, Path("worker.key"), Path("worker.pem"));
  const json record = Record("s-000001", "cab1", 64.5, true);
  EXPECT_TRUE(Verified(sec::verify_record_against_log(record, log, sig, ca_pem_)));
  json training = record;
  training["mode"] = "training";
  EXPECT_TRUE(HasProblem(sec::verify_record_against_log(training, log, sig, ca_pem_),
                         "log header mode is \"exam\" but the record's mode is \"training\""));
  json failed = record;
  failed["passed"] = false;
  EXPECT_TRUE(HasProblem(sec::verify_record_against_log(failed, log, sig, ca_pem_), "log score says passed"));
  const json other_cab = sec::sign_exam_log("s-000001", "cab1", log, Path("worker2.key"), Path("worker2.pem"));
  EXPECT_TRUE(HasProblem(sec::verify_record_against_log(record, log, other_cab, ca_pem_),
                         "signer certificate's common name is \"worker.cab2\", expected \"worker.cab1\""));
  const json rogue = sec::sign_exam_log("s-000001", "cab1", log, Path("rogue_worker.key"), Path("rogue_worker.pem"));
  EXPECT_TRUE(HasProblem(sec::verify_record_against_log(record, log, rogue, ca_pem_), "not accepted by the school CA"));
  const json revoked = sec::sign_exam_log("s-000001", "cab1", log, Path("revoked.key"), Path("revoked.pem"));
  EXPECT_TRUE(HasProblem(sec::verify_record_against_log(record, log, revoked, ca_pem_, crl_pem_), "revoked"));
  for (const json& bad : {json("garbage"), json(nullptr), json::object()})
    EXPECT_FALSE(sec::verify_record_against_log(record, log, bad, ca_pem_).ok) << bad;
  EXPECT_FALSE(sec::verify_record_against_log(json::array(), log, sig, ca_pem_).ok);
}

// The server's start-up check: the whole chain against its anchor's head alone.
TEST_F(EvidenceTest, WholeChainAgainstItsAnchorHead) {
  const json chain = Evidence({.server_signed = true})["chain"];
  const sec::VerifyOptions signed_only{.require_server_signatures = true};
  const json head = {{"head", sec::chain_anchor_line(chain[2])}};
  EXPECT_TRUE(Verified(sec::verify_chain(chain, head, ca_pem_, "", signed_only)));
  json cut = chain;
  cut.erase(2);
  EXPECT_TRUE(HasProblem(sec::verify_chain(cut, head, ca_pem_, "", signed_only), "the chain is cut short"));
  // Entries past the head (written just before a crash, before their anchor line) are no problem.
  const sec::VerifyReport ahead = sec::verify_chain(chain, {{"head", sec::chain_anchor_line(chain[1])}}, ca_pem_, "", signed_only);
  EXPECT_TRUE(Verified(ahead));
  EXPECT_NE(Report(ahead).find("entry 3 is newer than the anchor"), std::string::npos) << Report(ahead);
  EXPECT_TRUE(Verified(sec::verify_chain(chain, {{"head", nullptr}}, ca_pem_, "", signed_only)));
  EXPECT_TRUE(HasProblem(sec::verify_chain(chain, {{"head", nullptr}}, ca_pem_, "", {.require_anchor = true}),
                         "the chain is not anchored"));
  EXPECT_FALSE(sec::verify_chain("not a chain", json::object(), ca_pem_).ok);
  // A new school's: nothing chained, nothing anchored. Emptied with its anchor kept: cut short.
  EXPECT_TRUE(Verified(sec::verify_chain(json::array(), {{"head", nullptr}}, ca_pem_, "", {.require_anchor = true})));
  EXPECT_TRUE(HasProblem(sec::verify_chain(json::array(), head, ca_pem_), "but the chain ends at no entry: 3 entries were deleted"));
}

TEST_F(EvidenceTest, GarbageShapesAreProblemsNotCrashes) {
  const json good = Evidence({.server_signed = true});
  std::vector<json> cases = {nullptr, 42, "evidence", json::array(), json::object(), json::array({good})};
  for (const char* key : {"session", "record", "log", "signature", "chain"}) {
    for (const json& value : {json(), json(7), json("x"), json::array(), json::object()}) {
      json c = good;
      if (value.is_null())
        c.erase(key);
      else
        c[key] = value;
      if (c != good) cases.push_back(c);
    }
  }
  auto with = [&good](const json::json_pointer& at, const json& value) {
    json c = good;
    c[at] = value;
    return c;
  };
  using P = json::json_pointer;
  for (const auto& [at, value] : std::vector<std::pair<std::string, json>>{
           {"/record/session", 5},
           {"/record/cab", nullptr},
           {"/record/mark", "71.35"},
           {"/record/mark", nullptr},
           {"/record/passed", "yes"},
           {"/record/events", json::object()},
           {"/record/events/0", 1},
           {"/record/events/0/kind", 1},
           {"/record/events/0/worry", 1.5},
           {"/signature/format", "other/2"},
           {"/signature/signature", "!!!not base64!!!"},
           {"/signature/signature", "AAAA"},
           {"/signature/signature", ""},
           {"/signature/signer_certificate", "-----BEGIN CERTIFICATE-----\ngarbage\n-----END CERTIFICATE-----\n"},
           {"/signature/log_sha256", 5},
           {"/signature/cab", "cab1\nx"},
           {"/chain/0", 1},
           {"/chain/1", nullptr},
           {"/chain/1/seq", "2"},
           {"/chain/1/record", "{}"},
           {"/chain/1/prev_hash", 0},
           {"/chain/2/entry_hash", json::array()},
           {"/chain/0/server_signature", 5},
           {"/chain/0/server_signature", "AAAA"},
           {"/chain/0/server_certificate", nullptr},
           {"/chain/0/server_certificate", "garbage"},
           {"/chain/1/record/session", "s-000001"},
           {"/chain/0/record/examiner", std::string("\xff\xfe bad UTF-8")},
           {"/log", ""},
           {"/log", "score nan 1 0 x"},
           {"/log", "e 1 2\nscore 0x1p+0 2 3 x\nsession\ncab a\ncab b"},
           {"/log", std::string(1, '\0')}})
    cases.push_back(with(P(at), value));
  json erased = good;
  erased["chain"][1].erase("log_signature");
  cases.push_back(erased);

  for (size_t i = 0; i < cases.size(); ++i) {
    sec::VerifyReport r;
    ASSERT_NO_THROW(r = Verify(cases[i], crl_pem_)) << "case " << i;
    EXPECT_FALSE(r.ok) << "case " << i << "\n" << Report(r);
    EXPECT_FALSE(r.problems.empty()) << "case " << i;
  }
  // A chain rewritten at every entry is reported, but not line by line without end.
  json long_chain = good;
  for (int i = 0; i < 200; ++i) long_chain["chain"].push_back(good["chain"][0]);
  const sec::VerifyReport r = Verify(long_chain);
  EXPECT_FALSE(r.ok);
  EXPECT_LT(r.problems.size(), 30u);
  EXPECT_TRUE(HasProblem(r, "further chain problems not listed"));
}

TEST_F(EvidenceTest, UnreadableOrMismatchedKeyFilesThrow) {
  const std::string log = ControlLog("s-000001", "cab1", 64.5, true);
  auto message_of = [&](const std::string& key, const std::string& cert) {
    try {
      sec::sign_exam_log("s-000001", "cab1", log, key, cert);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("(no exception)");
  };
  WriteFile(Path("garbage.pem"), "this is not PEM\n");
  EXPECT_NE(message_of(Path("missing.key"), Path("worker.pem")).find("cannot read worker key file"), std::string::npos);
  EXPECT_NE(message_of(Path("garbage.pem"), Path("worker.pem")).find("is not an unencrypted PEM private key"),
            std::string::npos);
  EXPECT_NE(message_of(Path("worker.key"), Path("missing.pem")).find("cannot read worker certificate file"),
            std::string::npos);
  EXPECT_NE(message_of(Path("worker.key"), Path("garbage.pem")).find("holds no PEM certificate"), std::string::npos);
  EXPECT_NE(message_of(Path("worker.key"), Path("worker2.pem")).find("does not match the certificate"),
            std::string::npos);
  Run("openssl pkey -in worker.key -aes256 -passout pass:secret -out encrypted.key");
  EXPECT_NE(message_of(Path("encrypted.key"), Path("worker.pem")).find("is not an unencrypted PEM private key"),
            std::string::npos);

  const std::string zeros(64, '0');
  const std::string sha = sec::sha256_hex(log);
  const json record = Record("s-000001", "cab1", 64.5, true);
  EXPECT_THROW(sec::make_chain_entry(1, zeros, record, sha, "AAAA", Path("garbage.pem"), Path("server.pem")),
               std::runtime_error);
  EXPECT_THROW(sec::make_chain_entry(1, zeros, record, sha, "AAAA", Path("server.key"), Path("worker.pem")),
               std::runtime_error);
  EXPECT_THROW(sec::make_chain_entry(1, "abc", record, sha, "AAAA", "", ""), std::runtime_error);
  EXPECT_THROW(sec::make_chain_entry(0, zeros, record, sha, "AAAA", "", ""), std::runtime_error);
  EXPECT_THROW(sec::make_chain_entry(1, zeros, json::object(), sha, "AAAA", "", ""), std::runtime_error);
  EXPECT_THROW(sec::make_chain_entry(1, zeros, record, "xyz", "AAAA", "", ""), std::runtime_error);
  EXPECT_NO_THROW(sec::make_chain_entry(1, zeros, record, sha, "AAAA", Path("server.key"), Path("server.pem")));
}

}  // namespace

// A log a worker host ships settles a mark only with its session's own worker's signature: the
// right worker's verifies; another cab's worker, the server's key, a foreign CA, a revoked
// certificate, another session's signature and one changed byte are each refused with the reason.
TEST_F(EvidenceTest, AShippedLogCountsOnlyWithItsSessionsOwnWorkersSignature) {
  const std::string log = ControlLog("s-000005", "cab1", 88.0, true);
  auto signed_by = [&](const std::string& who, const std::string& session = "s-000005") {
    return sec::sign_exam_log(session, "cab1", log, Path(who + ".key"), Path(who + ".pem"));
  };
  auto check = [&](const json& sig, const std::string& text, const std::string& crl = "") {
    return sec::verify_log_signature("s-000005", "cab1", text, sig, ca_pem_, crl);
  };
  EXPECT_TRUE(Verified(check(signed_by("worker"), log, crl_pem_)));
  EXPECT_TRUE(HasProblem(check(signed_by("worker2"), log), "common name is \"worker.cab2\", expected \"worker.cab1\""));
  EXPECT_TRUE(HasProblem(check(signed_by("server"), log), "common name is \"server\", expected \"worker.cab1\""));
  EXPECT_TRUE(HasProblem(check(signed_by("rogue_worker"), log), "not accepted by the school CA"));
  EXPECT_TRUE(HasProblem(check(signed_by("revoked"), log, crl_pem_), "certificate revoked"));
  EXPECT_TRUE(HasProblem(check(signed_by("worker", "s-000004"), log), "signature is for session \"s-000004\""));
  std::string changed = log;
  changed[changed.size() / 2] ^= 1;
  EXPECT_TRUE(HasProblem(check(signed_by("worker"), changed), "the log is not the one signed"));
  EXPECT_TRUE(HasProblem(check(json::array(), log), "the log signature is not a JSON object"));
}
