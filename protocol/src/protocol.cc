#include "forklift/protocol.h"

#include <cstdlib>
#include <vector>

namespace forklift::dds {

std::string cab_partition(const std::string& cab_id) { return "cab." + cab_id; }

DomainSettings DomainSettings::resolve(std::optional<int> domain_flag, const std::string& config_flag) {
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
  return s;
}

dds_entity_t check(dds_entity_t e, const char* what) {
  if (e < 0) throw std::runtime_error(std::string("DDS: cannot create ") + what + ": " + dds_strretcode(e));
  return e;
}

dds_qos_t* make_qos(QosKind kind, const std::string& partition) {
  dds_qos_t* q = dds_create_qos();
  switch (kind) {
    case QosKind::kLatestReliable:
      dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
      dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
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
  }
  if (!partition.empty()) dds_qset_partition1(q, partition.c_str());
  return q;
}

Participant::Participant(const DomainSettings& settings) {
  // Cyclone reads its configuration from CYCLONEDDS_URI when the domain is first created.
  setenv("CYCLONEDDS_URI", settings.config_uri.c_str(), 1);
  handle_ = check(dds_create_participant(settings.domain_id, nullptr, nullptr), "participant");
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
