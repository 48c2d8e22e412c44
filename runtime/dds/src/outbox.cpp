#include "regolith/dds/outbox.hpp"

namespace regolith::dds {

dds_return_t check(dds_return_t rc, std::string_view what) {
  if (rc < 0) throw DdsError(std::string(what) + ": " + dds_strretcode(rc));
  return rc;
}

OutboxBase::OutboxBase(dds_entity_t participant, dds_entity_t topic, std::string ros_topic, std::string_view ros_type,
                       const QosProfile& qos, std::shared_ptr<Waker> waker)
    : waker_(std::move(waker)), topic_(std::move(ros_topic)), ros_type_(ros_type) {
  const Qos q(qos, Qos::For::kWriter);
  dds_listener_t* listener = dds_create_listener(this);
  dds_lset_offered_deadline_missed(listener, &OutboxBase::on_deadline_missed);
  writer_ = dds_create_writer(participant, topic, q.get(), listener);
  dds_delete_listener(listener);
  check(writer_, "dds_create_writer for " + topic_ + " (" + std::string(ros_type) + ", " + qos.describe() + ")");
}

OutboxBase::~OutboxBase() {
  // Deleting the writer first guarantees no listener call runs on a dead
  // object. A writer that died with its participant yields an error code here,
  // which is fine.
  if (writer_ > 0) (void)dds_delete(writer_);
}

void OutboxBase::on_deadline_missed(dds_entity_t, dds_offered_deadline_missed_status_t st, void* arg) {
  auto* self = static_cast<OutboxBase*>(arg);
  self->deadline_missed_.fetch_add(st.total_count_change, std::memory_order_relaxed);
}

bool OutboxBase::write_sample(const void* sample, const SourceClock& source_clock) {
  const dds_return_t rc = source_clock ? dds_write_ts(writer_, sample, source_clock()) : dds_write(writer_, sample);
  if (rc < 0) {
    write_errors_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  published_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

std::uint32_t OutboxBase::matched_readers() const {
  dds_publication_matched_status_t st{};
  if (dds_get_publication_matched_status(writer_, &st) < 0) return 0;
  return st.current_count;
}

OutboxStats OutboxBase::stats() const {
  OutboxStats s;
  s.topic = topic_;
  s.ros_type = std::string(ros_type_);
  s.committed = committed();
  s.published = published();
  s.dropped = dropped();
  s.write_errors = write_errors();
  s.deadline_missed = deadline_missed();
  s.matched_readers = matched_readers();
  return s;
}

}  // namespace regolith::dds
