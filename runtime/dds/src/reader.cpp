#include "regolith/dds/reader.hpp"

namespace regolith::dds {

Subscription::Subscription(Participant& p, std::string_view topic, const dds_topic_descriptor_t* desc,
                           const QosProfile& qos)
    : participant_(&p), topic_(p.ros_name(topic)) {
  const dds_entity_t tp = p.topic(topic, desc);
  const Qos q(qos, Qos::For::kReader);
  reader_ = dds_create_reader(p.handle(), tp, q.get(), nullptr);
  check(reader_, "dds_create_reader for " + topic_ + " (" + qos.describe() + ")");
  readcond_ = dds_create_readcondition(reader_, DDS_ANY_STATE);
  waitset_ = dds_create_waitset(p.handle());
  if (readcond_ < 0 || waitset_ < 0 || dds_waitset_attach(waitset_, readcond_, 0) < 0) {
    (void)dds_delete(reader_);
    if (waitset_ > 0) (void)dds_delete(waitset_);
    throw DdsError("waitset for " + topic_ + ": " + dds_strretcode(readcond_ < 0 ? readcond_ : waitset_));
  }
  try {
    p.add_reader(reader_);  // one of the node's subscriptions in the ROS graph
  } catch (...) {
    p.remove_reader(reader_);
    (void)dds_delete(waitset_);
    (void)dds_delete(reader_);
    throw;
  }
}

Subscription::~Subscription() {
  if (reader_ > 0) participant_->remove_reader(reader_);
  if (waitset_ > 0) (void)dds_delete(waitset_);
  if (reader_ > 0) (void)dds_delete(reader_);  // also deletes the read condition
}

bool Subscription::wait(TimeNs timeout_ns) {
  const dds_return_t rc = dds_waitset_wait(waitset_, nullptr, 0, timeout_ns > 0 ? timeout_ns : 0);
  check(rc, "dds_waitset_wait on " + topic_);
  return rc > 0;
}

std::uint32_t Subscription::matched_writers() const {
  dds_subscription_matched_status_t st{};
  if (dds_get_subscription_matched_status(reader_, &st) < 0) return 0;
  return st.current_count;
}

}  // namespace regolith::dds
