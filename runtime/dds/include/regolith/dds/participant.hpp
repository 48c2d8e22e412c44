#pragma once
// One DDS domain participant per process, with the robot namespace, the topic
// cache and the publisher thread that drains every Outbox created through it.
#include <array>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <dds/dds.h>

#include "regolith/dds/discovery.hpp"
#include "regolith/dds/naming.hpp"
#include "regolith/dds/outbox.hpp"
#include "regolith/dds/qos.hpp"
#include "regolith/dds/types.hpp"

namespace regolith::dds {

/// The ROS 2 convention: the ROS_DOMAIN_ID environment variable, 0 when it is unset or empty;
/// ConfigError naming it when it is not an integer in 0..232 (domain_id_from_environment()).
int default_domain_id();
/// `requested` when it is >= 0 (a --domain option given), else default_domain_id().
inline std::uint32_t resolve_domain_id(int requested) {
  return static_cast<std::uint32_t>(requested >= 0 ? requested : default_domain_id());
}

struct ParticipantConfig {
  std::uint32_t domain_id = 0;  ///< DDS domain (= ROS_DOMAIN_ID), 0..232
  std::string ns;               ///< robot namespace, e.g. "rover1" ("" = none)
  void validate() const;        ///< throws std::invalid_argument naming the field
};

class Participant {
 public:
  /// Creates the DDS participant. Throws std::invalid_argument for a bad config, ConfigError for
  /// a ROS 2 discovery variable ROS 2 would refuse, and DdsError when Cyclone refuses (e.g. a
  /// malformed CYCLONEDDS_URI). A discovery range other than Cyclone's default (LOCALHOST, OFF,
  /// static peers) is the configuration of the process's DDS domain, made by the first
  /// participant on it (rmw_cyclonedds's XML before CYCLONEDDS_URI's) and kept while any lives;
  /// another participant on that domain asking for another range is a DdsError.
  /// The discovery range is that of the ROS 2 environment (discovery_from_environment()).
  explicit Participant(ParticipantConfig cfg);
  Participant(ParticipantConfig cfg, DiscoveryOptions discovery);
  /// Stops the publisher thread (writing what is pending) and deletes every DDS
  /// entity.
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  dds_entity_t handle() const { return participant_; }
  std::uint32_t domain_id() const { return cfg_.domain_id; }
  /// The discovery range in effect (given, or from the environment).
  const DiscoveryOptions& discovery() const { return discovery_; }
  const std::string& ns() const { return cfg_.ns; }
  /// "joint_states" -> "/rover1/joint_states"; "/diagnostics" ->
  /// "/diagnostics".
  std::string ros_name(std::string_view topic) const { return ros_topic_name(cfg_.ns, topic); }
  /// "joint_states" -> "rt/rover1/joint_states"; "/diagnostics" ->
  /// "rt/diagnostics".
  std::string wire_name(std::string_view topic) const { return wire_topic_name(cfg_.ns, topic); }

  /// The DDS topic for `topic` (relative or absolute ROS name) and `desc`,
  /// created on first use. Throws DdsError when the same name was already
  /// created with another type.
  dds_entity_t topic(std::string_view topic, const dds_topic_descriptor_t* desc);

  /// Creates a writer on `topic` with a pre-allocated RT-side outbox (see
  /// outbox.hpp).
  template <class Msg>
  std::shared_ptr<Outbox<Msg>> make_outbox(std::string_view topic_name, const QosProfile& qos, const OutboxOptions& opt,
                                           const std::function<void(Msg&)>& reserve) {
    qos.validate();
    const dds_entity_t tp = topic(topic_name, MsgTraits<Msg>::descriptor());
    auto box = std::make_shared<Outbox<Msg>>(participant_, tp, ros_name(topic_name), qos, opt, reserve, waker_);
    attach(box);
    return box;
  }

  /// Announces this participant as one ROS 2 node, `/<ns>/<node_name>` (namespace "/" without a
  /// robot namespace), the way rmw_cyclonedds does: an rmw_dds_common/ParticipantEntitiesInfo
  /// sample on the DDS topic "ros_discovery_info" (no rt/ prefix; reliable, transient-local,
  /// keep-last 1) holding the participant's gid and the node with every outbox's writer gid
  /// (gid = the entity's 16-byte DDS GUID, zero-padded to 24 bytes, as in ROS 2 Humble). Then
  /// `ros2 node list` lists the node and `ros2 topic info -v` names it as the publisher. Once
  /// announced, every outbox made later publishes the set again (a writer made after start is
  /// listed too); a later call renames the node and publishes it. A name that is
  /// not a valid ROS node name is made one (other characters -> '_', a leading digit gets '_').
  /// Non-RT. Returns the node's full name. Throws DdsError when Cyclone refuses.
  std::string announce_node(const std::string& node_name);
  /// Non-RT: a reader of this participant, listed with the node's subscriptions (its reader gids)
  /// by announce_node; when the node is already announced it is announced again with it.
  /// dds::Subscription registers and unregisters its own reader.
  void add_reader(dds_entity_t reader);
  void remove_reader(dds_entity_t reader);
  /// The 24-byte ROS gid of a DDS entity (its GUID, zero-padded).
  static std::array<std::uint8_t, 24> gid_of(dds_entity_t entity);

  /// Lossless mode (simulated time): stream writers created from now on keep all history, so a
  /// reliable reader receives every sample however fast the producer runs. Call before creating
  /// outboxes.
  void set_lossless(bool on) { lossless_ = on; }
  bool lossless() const { return lossless_; }
  /// The DDS source timestamp of every sample written from now on: `ros_now()` (ROS time, ns
  /// since 1970) read as each is written, instead of the writers' wall clock. Simulated
  /// time sets it to the simulated ROS time, so a recorder or subscriber sees samples stamped
  /// on the time line of their header stamps and /clock. Call before start(); empty = wall clock.
  void set_source_clock(SourceClock ros_now) { source_clock_ = std::move(ros_now); }
  const SourceClock& source_clock() const { return source_clock_; }
  /// The ROS time of this participant's samples now: the source clock's, else the wall clock (for
  /// header stamps of samples made outside a rate group, e.g. the live relay's status).
  TimeNs ros_now() const { return source_clock_ ? source_clock_() : realtime_now(); }
  /// Starts the publisher thread (idempotent).
  void start();
  /// Stops it after writing everything pending (idempotent).
  void stop();
  bool running() const { return thread_.joinable(); }
  /// Non-RT: writes everything pending on the calling thread (use when no
  /// thread runs, e.g. in single-threaded tests). Returns the number of samples
  /// written.
  std::size_t flush_all();
  /// Non-RT: waits until every outbox is idle (all committed samples written),
  /// at most `timeout_ns`. With no publisher thread running it flushes on the
  /// calling thread. Returns false on timeout. Useful under the simulated clock
  /// before sampling counters.
  bool drain(TimeNs timeout_ns);

  /// Non-RT: drain(), then wait until every matched reader acknowledged what was written, at most
  /// `timeout_ns` per writer. Used under the simulated clock so no reliable sample is lost however
  /// fast simulated time runs. Returns false on timeout.
  bool wait_for_acks(TimeNs timeout_ns);
  /// Non-RT: wait until the outboxes of `topics` (ROS names, relative or absolute; empty = all
  /// outboxes) each have at least one matched reader, at most `timeout_ns`. False on timeout.
  bool wait_for_readers(const std::vector<std::string>& topics, TimeNs timeout_ns);
  std::vector<OutboxStats> stats() const;
  /// One line per outbox: "/rover1/joint_states published 1000 dropped 0
  /// deadline_missed 0 readers 1".
  std::string summary() const;

 private:
  void attach(std::shared_ptr<OutboxBase> box);
  void run();

  ParticipantConfig cfg_;
  DiscoveryOptions discovery_;
  bool holds_domain_ = false;  // this participant holds a reference to a configured domain
  bool lossless_ = false;
  SourceClock source_clock_;
  dds_entity_t participant_ = 0;
  dds_entity_t discovery_writer_ = 0;  // ros_discovery_info (announce_node)
  std::string announced_;              // the node name given to announce_node (empty: not announced)
  std::shared_ptr<Waker> waker_ = std::make_shared<Waker>();

  mutable std::mutex mutex_;  // outboxes_, readers_, topics_ (never taken on the RT side)
  std::vector<std::shared_ptr<OutboxBase>> outboxes_;
  std::vector<dds_entity_t> readers_;  // subscriptions' readers (add_reader)
  std::map<std::string, std::pair<dds_entity_t, const dds_topic_descriptor_t*>, std::less<>> topics_;

  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex idle_mutex_;
  std::condition_variable idle_cv_;
  std::atomic<std::uint64_t> passes_{0};
};

}  // namespace regolith::dds
