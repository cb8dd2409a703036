#include "forklift/protocol/protocol.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <vector>

namespace forklift::dds {

std::string cab_partition(const std::string& cab_id) { return "cab." + cab_id; }
std::string worker_partition(const std::string& cab_id) { return "worker." + cab_id; }
std::string host_partition(const std::string& host_id) { return "host." + host_id; }
std::string instructor_partition(const std::string& cab_id) { return "instructor." + cab_id; }

bool valid_utf8(std::string_view text) {
  const auto* p = reinterpret_cast<const unsigned char*>(text.data());
  const auto* end = p + text.size();
  while (p < end) {
    const unsigned c = *p;
    int n = 0;
    unsigned cp = 0, min = 0;
    if (c < 0x80) { ++p; continue; }
    if ((c & 0xE0) == 0xC0) { n = 1; cp = c & 0x1F; min = 0x80; }
    else if ((c & 0xF0) == 0xE0) { n = 2; cp = c & 0x0F; min = 0x800; }
    else if ((c & 0xF8) == 0xF0) { n = 3; cp = c & 0x07; min = 0x10000; }
    else return false;
    if (end - p <= n) return false;
    for (int i = 1; i <= n; ++i) {
      if ((p[i] & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (p[i] & 0x3F);
    }
    if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    p += n + 1;
  }
  return true;
}

std::string guid_hex(const dds_guid_t& g) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (uint8_t b : g.v) { out += digits[b >> 4]; out += digits[b & 15]; }
  return out;
}

std::string participant_guid(dds_entity_t participant) {
  dds_guid_t g;
  if (dds_get_guid(participant, &g) != DDS_RETCODE_OK) throw std::runtime_error("DDS: no GUID for the participant");
  return guid_hex(g);
}

std::optional<Sender> sender_of(dds_entity_t reader, dds_instance_handle_t publication) {
  dds_builtintopic_endpoint_t* e = dds_get_matched_publication_data(reader, publication);
  if (!e) return std::nullopt;
  Sender s;
  s.participant = guid_hex(e->participant_key);
  uint32_t n = 0;
  char** ps = nullptr;
  if (e->qos && dds_qget_partition(e->qos, &n, &ps)) {
    for (uint32_t i = 0; i < n; ++i) { s.partitions.push_back(ps[i]); dds_free(ps[i]); }
    dds_free(ps);
  }
  // The default partition is also spelled as one empty name.
  if (s.partitions.size() == 1 && s.partitions[0].empty()) s.partitions.clear();
  dds_builtintopic_free_endpoint(e);
  return s;
}

DomainSettings DomainSettings::resolve(std::optional<int> domain_flag, const std::string& config_flag,
                                       const std::string& security_dir_flag, const std::string& identity) {
  DomainSettings s;
  if (domain_flag) {
    s.domain_id = static_cast<uint32_t>(*domain_flag);
  } else if (const char* env = std::getenv("FORKLIFT_DDS_DOMAIN")) {
    s.domain_id = static_cast<uint32_t>(std::strtoul(env, nullptr, 10));
  }
  if (!config_flag.empty()) {
    s.config_uri = "file://" + config_flag;
  } else if (const char* env = std::getenv("CYCLONEDDS_URI")) {
    s.config_uri = env;
  } else {
    s.config_uri = "file://" FORKLIFT_DDS_CONFIG;
  }
  // The shipped network configurations take their interface and peers from the environment
  // (protocol/config/lan.xml and the others): say which is missing in words, before Cyclone
  // refuses a nameless interface or an empty peer.
  if (s.config_uri.rfind("file://", 0) == 0) {
    std::string file = s.config_uri.substr(7);
    file = file.substr(0, file.find(','));  // a list: the file, then fragments
    std::ifstream in(file);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto unset = [](const char* name) { const char* v = std::getenv(name); return !v || !*v; };
    if (text.find("${FORKLIFT_DDS_INTERFACE") != std::string::npos && unset("FORKLIFT_DDS_INTERFACE") && unset("FORKLIFT_DDS_NETWORK"))
      throw std::runtime_error("the DDS configuration " + file +
                               " needs the network to use: set FORKLIFT_DDS_INTERFACE to its interface's name (such as eth0; "
                               "`ip -br addr` lists them) or FORKLIFT_DDS_NETWORK to an address on it (such as 10.20.0.0)");
    if (text.find("${FORKLIFT_DDS_PEER}") != std::string::npos && unset("FORKLIFT_DDS_PEER"))
      throw std::runtime_error("the DDS configuration " + file +
                               " finds the other machines by unicast: set FORKLIFT_DDS_PEER to the address or host name of the "
                               "machine this one must reach (the simulation PC for a cab, the server for a simulation PC)");
  }
  std::string dir = security_dir_flag;
  if (dir.empty())
    if (const char* env = std::getenv("FORKLIFT_SECURITY_DIR")) dir = env;
  if (!dir.empty() && !identity.empty()) {  // no identity: a program that takes no part in security
    s.security = SecurityFiles{dir, identity};
    s.security->check();
  }
  return s;
}

void SecurityFiles::check() const {
  for (const std::string& f : {ca(), governance(), crl(), certificate(), private_key(), permissions()})
    if (access(f.c_str(), R_OK) != 0)
      throw std::runtime_error("DDS Security: cannot read " + f + " (make it with scripts/forklift-pki.sh)");
  const std::string revoked = dir + "/identities/" + identity + "/REVOKED";
  if (access(revoked.c_str(), F_OK) == 0) throw std::runtime_error("DDS Security: identity " + identity + " is revoked");
}

namespace {

// The participant's security properties (DDS Security 1.1, section 9, plus Cyclone's CRL).
// Per participant rather than in the XML configuration, so that the server, its workers and a
// test's cabs can share one configuration file and each have its own identity.
void set_security(dds_qos_t* q, const SecurityFiles& f) {
  const std::string plugins = FORKLIFT_DDS_SECURITY_PLUGIN_DIR;
  const std::pair<const char*, std::string> props[] = {
      {"dds.sec.auth.library.path", plugins + "/libdds_security_auth.so"},
      {"dds.sec.auth.library.init", "init_authentication"},
      {"dds.sec.auth.library.finalize", "finalize_authentication"},
      {"dds.sec.crypto.library.path", plugins + "/libdds_security_crypto.so"},
      {"dds.sec.crypto.library.init", "init_crypto"},
      {"dds.sec.crypto.library.finalize", "finalize_crypto"},
      {"dds.sec.access.library.path", plugins + "/libdds_security_ac.so"},
      {"dds.sec.access.library.init", "init_access_control"},
      {"dds.sec.access.library.finalize", "finalize_access_control"},
      {"dds.sec.auth.identity_ca", "file:" + f.ca()},
      {"dds.sec.auth.identity_certificate", "file:" + f.certificate()},
      {"dds.sec.auth.private_key", "file:" + f.private_key()},
      {"org.eclipse.cyclonedds.sec.auth.crl", "file:" + f.crl()},
      {"dds.sec.access.permissions_ca", "file:" + f.ca()},
      {"dds.sec.access.governance", "file:" + f.governance()},
      {"dds.sec.access.permissions", "file:" + f.permissions()},
  };
  for (const auto& [name, value] : props) dds_qset_prop(q, name, value.c_str());
}

}  // namespace

dds_entity_t check(dds_entity_t e, const std::string& what) {
  if (e < 0) throw std::runtime_error("DDS: cannot create " + what + ": " + dds_strretcode(e));
  return e;
}

std::string endpoint_name(const char* topic, const std::string& partition) {
  return std::string(topic) + (partition.empty() ? " in the default partition" : " in partition " + partition);
}

dds_qos_t* make_qos(QosKind kind, const std::string& partition) {
  dds_qos_t* q = dds_create_qos();
  switch (kind) {
    case QosKind::kLatestReliable:
      // Keep the last 256, not 1: a scripted cab sends its rows up to a second ahead of their
      // time (100 at once when it starts), and each must arrive (the newest live one wins).
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 256);
      break;
    case QosKind::kLatestBestEffort:
      dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      break;
    case QosKind::kDurableReliable:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
      dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
      dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
      break;
    case QosKind::kHostStatus:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, DDS_MSECS(int64_t(kHostLeaseS * 1000)));
      break;
    case QosKind::kRequest:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 4);
      break;
    case QosKind::kInstructor:
      // Transient local: a server's writer made on the first action, before discovery has matched
      // the worker's reader, still reaches it; the worker acts on a session's samples once each.
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 16);
      dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
      break;
    case QosKind::kLatestDurable:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
      dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
      break;
  }
  if (!partition.empty()) dds_qset_partition1(q, partition.c_str());
  return q;
}

Participant::Participant(const DomainSettings& settings) {
  // Cyclone reads its configuration from CYCLONEDDS_URI when the domain is first created.
  setenv("CYCLONEDDS_URI", settings.config_uri.c_str(), 1);
  dds_qos_t* qos = dds_create_qos();
  if (settings.security) set_security(qos, *settings.security);
  handle_ = dds_create_participant(settings.domain_id, qos, nullptr);
  dds_delete_qos(qos);
  if (handle_ < 0 && settings.security)
    throw std::runtime_error("DDS Security: identity " + settings.security->identity +
                             " refused (certificate, key, permissions or governance invalid for this CA): " + dds_strretcode(handle_));
  check(handle_, "participant");
}

Participant::~Participant() { dds_delete(handle_); }

dds_entity_t Participant::find_or_create_topic(const char* name, const dds_topic_descriptor_t* desc) {
  // dds_create_topic returns the existing topic when called again with the same name and type.
  return check(dds_create_topic(handle_, desc, name, nullptr, nullptr), name);
}

WaitSet::WaitSet(Participant& p) {
  ws_ = check(dds_create_waitset(p.handle()), "waitset");
  guard_ = check(dds_create_guardcondition(p.handle()), "guard condition");
  dds_waitset_attach(ws_, guard_, guard_);
}

WaitSet::~WaitSet() {
  dds_delete(guard_);
  dds_delete(ws_);
}

void WaitSet::attach_reader(dds_entity_t reader) {
  const dds_entity_t cond = check(dds_create_readcondition(reader, DDS_ANY_STATE), "read condition");
  dds_waitset_attach(ws_, cond, reader);
}

void WaitSet::wake() { dds_set_guardcondition(guard_, true); }

bool WaitSet::wait(double timeout_s) {
  dds_attach_t xs[8];
  const dds_duration_t timeout = timeout_s > 0 ? static_cast<dds_duration_t>(timeout_s * 1e9) : 0;
  const dds_return_t n = dds_waitset_wait(ws_, xs, 8, timeout);
  if (n > 0) {
    bool triggered = false;
    dds_read_guardcondition(guard_, &triggered);
    if (triggered) dds_set_guardcondition(guard_, false);
  }
  return n > 0;
}

}  // namespace forklift::dds
