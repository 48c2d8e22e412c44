#include "regolith/dds/qos.hpp"

#include <stdexcept>

namespace regolith::dds {

QosProfile QosProfile::state(TimeNs offered_deadline_ns) {
  QosProfile p;
  p.reliability = Reliability::kReliable;
  p.durability = Durability::kTransientLocal;
  p.depth = 1;
  p.deadline_ns = offered_deadline_ns;
  return p;
}

QosProfile QosProfile::stream(int depth) {
  QosProfile p;
  p.reliability = Reliability::kReliable;
  p.durability = Durability::kVolatile;
  p.depth = depth;
  return p;
}

QosProfile QosProfile::diagnostics() {
  return stream(10);
}

QosProfile QosProfile::reader(Reliability r, Durability d, int depth) {
  QosProfile p;
  p.reliability = r;
  p.durability = d;
  p.depth = depth;
  p.deadline_ns = 0;
  return p;
}

void QosProfile::validate() const {
  if (depth < 1) throw std::invalid_argument("QosProfile.depth: must be >= 1 (got " + std::to_string(depth) + ")");
  if (deadline_ns < 0)
    throw std::invalid_argument("QosProfile.deadline_ns: must be >= 0 (got " + std::to_string(deadline_ns) + ")");
  if (max_blocking_ns < 0)
    throw std::invalid_argument("QosProfile.max_blocking_ns: must be >= 0 (got " + std::to_string(max_blocking_ns) +
                                ")");
}

std::string QosProfile::describe() const {
  std::string s = reliability == Reliability::kReliable ? "reliable" : "best_effort";
  s += " keep_last(" + std::to_string(depth) + ")";
  s += durability == Durability::kTransientLocal ? " transient_local" : " volatile";
  if (deadline_ns > 0) s += " deadline " + std::to_string(deadline_ns / kNsPerMs) + " ms";
  return s;
}

Qos::Qos(const QosProfile& p, For role) {
  p.validate();
  qos_ = dds_create_qos();
  if (p.reliability == Reliability::kReliable)
    dds_qset_reliability(qos_, DDS_RELIABILITY_RELIABLE, p.max_blocking_ns);
  else
    dds_qset_reliability(qos_, DDS_RELIABILITY_BEST_EFFORT, 0);
  if (p.keep_all)
    dds_qset_history(qos_, DDS_HISTORY_KEEP_ALL, 0);
  else
    dds_qset_history(qos_, DDS_HISTORY_KEEP_LAST, p.depth);
  dds_qset_durability(
      qos_, p.durability == Durability::kTransientLocal ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  // XCDR1 only: what rmw_cyclonedds accepts (our types are @final without
  // @optional).
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(qos_, 1, &xcdr1);
  if (role == For::kWriter && p.deadline_ns > 0) dds_qset_deadline(qos_, p.deadline_ns);
}

Qos::~Qos() {
  if (qos_ != nullptr) dds_delete_qos(qos_);
}

}  // namespace regolith::dds
