#include "regolith/dds/participant.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

#include "regolith/dds/sample.hpp"

namespace regolith::dds {

int default_domain_id() {
  return domain_id_from_environment();
}

namespace {

// The DDS domains this process configured (discovery other than Cyclone's default), with the
// participants that use them: the domain is deleted with the last.
struct ConfiguredDomain {
  dds_entity_t handle = 0;
  int users = 0;
  DiscoveryOptions options;
};
std::mutex& domains_mutex() {
  static std::mutex m;
  return m;
}
std::map<std::uint32_t, ConfiguredDomain>& configured_domains() {
  static std::map<std::uint32_t, ConfiguredDomain> d;
  return d;
}

// True when the participant about to be made holds a reference to a configured domain.
bool acquire_domain(std::uint32_t id, const DiscoveryOptions& o) {
  const std::string xml = discovery_config(o, static_cast<long>(::getpid()));
  std::lock_guard lock(domains_mutex());
  auto& domains = configured_domains();
  const auto it = domains.find(id);
  if (it != domains.end()) {
    if (!(it->second.options == o))
      throw DdsError("DDS domain " + std::to_string(id) + " is configured in this process for discovery range " +
                     to_string(it->second.options.range) + "; a participant with range " + to_string(o.range) +
                     " cannot join it");
    ++it->second.users;
    return true;
  }
  if (xml.empty()) return false;  // Cyclone's own configuration (CYCLONEDDS_URI)
  // rmw_cyclonedds's order: the discovery fragment, then CYCLONEDDS_URI (empty fragments ignored).
  const char* uri = std::getenv("CYCLONEDDS_URI");
  const std::string config = xml + "," + (uri != nullptr ? uri : "");
  const dds_entity_t h = dds_create_domain(id, config.c_str());
  if (h == DDS_RETCODE_PRECONDITION_NOT_MET)
    throw DdsError("DDS domain " + std::to_string(id) +
                   " already exists in this process with Cyclone's default discovery; discovery range " +
                   to_string(o.range) + " cannot apply to it");
  check(h, "dds_create_domain(" + std::to_string(id) + ") for discovery range " + std::string(to_string(o.range)) +
               " (check CYCLONEDDS_URI)");
  domains[id] = ConfiguredDomain{h, 1, o};
  return true;
}

void release_domain(std::uint32_t id) {
  std::lock_guard lock(domains_mutex());
  auto& domains = configured_domains();
  const auto it = domains.find(id);
  if (it == domains.end() || --it->second.users > 0) return;
  (void)dds_delete(it->second.handle);
  domains.erase(it);
}

}  // namespace

void ParticipantConfig::validate() const {
  if (domain_id > 232)
    throw std::invalid_argument("dds.domain: must be in [0, 232] (got " + std::to_string(domain_id) + ")");
  (void)normalize_namespace(ns);
}

Participant::Participant(ParticipantConfig cfg) : Participant(std::move(cfg), discovery_from_environment()) {}

Participant::Participant(ParticipantConfig cfg, DiscoveryOptions discovery)
    : cfg_(std::move(cfg)), discovery_(std::move(discovery)) {
  cfg_.validate();
  cfg_.ns = normalize_namespace(cfg_.ns);
  holds_domain_ = acquire_domain(cfg_.domain_id, discovery_);
  participant_ = dds_create_participant(cfg_.domain_id, nullptr, nullptr);
  if (participant_ < 0 && holds_domain_) {
    release_domain(cfg_.domain_id);
    holds_domain_ = false;
  }
  check(participant_, "dds_create_participant(domain " + std::to_string(cfg_.domain_id) + ") (check CYCLONEDDS_URI)");
}

Participant::~Participant() {
  stop();
  {
    std::lock_guard lock(mutex_);
    outboxes_.clear();  // deletes the writers of outboxes nobody else holds
    topics_.clear();
  }
  (void)dds_delete(participant_);  // deletes every remaining child entity
  if (holds_domain_) release_domain(cfg_.domain_id);
}

dds_entity_t Participant::topic(std::string_view name, const dds_topic_descriptor_t* desc) {
  const std::string wire = wire_name(name);
  std::lock_guard lock(mutex_);
  if (auto it = topics_.find(wire); it != topics_.end()) {
    if (it->second.second != desc)
      throw DdsError("topic " + ros_name(name) + ": already used with type " + it->second.second->m_typename +
                     ", cannot use it with " + desc->m_typename);
    return it->second.first;
  }
  const dds_entity_t tp = dds_create_topic(participant_, desc, wire.c_str(), nullptr, nullptr);
  check(tp, "dds_create_topic " + wire + " (" + desc->m_typename + ")");
  topics_.emplace(wire, std::make_pair(tp, desc));
  return tp;
}

std::array<std::uint8_t, 24> Participant::gid_of(dds_entity_t entity) {
  dds_guid_t guid;
  check(dds_get_guid(entity, &guid), "dds_get_guid");
  std::array<std::uint8_t, 24> gid{};
  static_assert(sizeof guid.v <= 24);
  std::copy(std::begin(guid.v), std::end(guid.v), gid.begin());
  return gid;
}

std::string Participant::announce_node(const std::string& node_name) {
  // A ROS node name: [A-Za-z_][A-Za-z0-9_]*.
  std::string name = node_name.empty() ? std::string("regolith") : node_name;
  for (char& c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) c = '_';
  if (std::isdigit(static_cast<unsigned char>(name[0]))) name.insert(name.begin(), '_');
  const std::string ns = cfg_.ns.empty() ? std::string("/") : "/" + cfg_.ns;

  using Info = msgs::rmw_dds_common::ParticipantEntitiesInfo;
  using Node = msgs::rmw_dds_common::NodeEntitiesInfo;
  using Gid = msgs::rmw_dds_common::Gid;
  std::lock_guard lock(mutex_);
  announced_ = node_name;
  if (discovery_writer_ == 0) {
    const dds_entity_t tp =
        dds_create_topic(participant_, MsgTraits<Info>::descriptor(), "ros_discovery_info", nullptr, nullptr);
    check(tp, "dds_create_topic ros_discovery_info");
    dds_qos_t* q = dds_create_qos();
    dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
    dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
    discovery_writer_ = dds_create_writer(participant_, tp, q, nullptr);
    dds_delete_qos(q);
    check(discovery_writer_, "dds_create_writer ros_discovery_info");
  }
  const auto gid = [](dds_entity_t e) {
    Gid g{};
    const auto a = gid_of(e);
    std::copy(a.begin(), a.end(), g.data);
    return g;
  };
  std::vector<Gid> writers, readers;
  for (const auto& box : outboxes_) writers.push_back(gid(box->writer()));
  for (const dds_entity_t r : readers_) readers.push_back(gid(r));
  Node node{};
  // bounded strings: char[257] for string<256> (capacity excludes the terminator)
  copy_string(node.node_namespace, sizeof node.node_namespace - 1, ns);
  copy_string(node.node_name, sizeof node.node_name - 1, name);
  node.reader_gid_seq._maximum = node.reader_gid_seq._length = static_cast<std::uint32_t>(readers.size());
  node.reader_gid_seq._buffer = readers.empty() ? nullptr : readers.data();
  node.reader_gid_seq._release = false;
  node.writer_gid_seq._maximum = node.writer_gid_seq._length = static_cast<std::uint32_t>(writers.size());
  node.writer_gid_seq._buffer = writers.data();
  node.writer_gid_seq._release = false;
  Info info{};
  const auto pg = gid_of(participant_);
  std::copy(pg.begin(), pg.end(), info.gid.data);
  info.node_entities_info_seq._maximum = info.node_entities_info_seq._length = 1;
  info.node_entities_info_seq._buffer = &node;
  info.node_entities_info_seq._release = false;
  check(dds_write(discovery_writer_, &info), "dds_write ros_discovery_info");
  return ns == "/" ? "/" + name : ns + "/" + name;
}

void Participant::attach(std::shared_ptr<OutboxBase> box) {
  std::string again;
  bool announced = false;
  {
    std::lock_guard lock(mutex_);
    outboxes_.push_back(std::move(box));
    announced = discovery_writer_ != 0;
    if (announced) again = announced_;
  }
  if (announced) announce_node(again);  // the node's writer list now includes it
}

void Participant::add_reader(dds_entity_t reader) {
  std::string again;
  {
    std::lock_guard lock(mutex_);
    readers_.push_back(reader);
    if (discovery_writer_ == 0) return;
    again = announced_;
  }
  announce_node(again);  // the node's reader list now includes it
}

void Participant::remove_reader(dds_entity_t reader) {
  std::string again;
  {
    std::lock_guard lock(mutex_);
    const auto it = std::find(readers_.begin(), readers_.end(), reader);
    if (it == readers_.end()) return;
    readers_.erase(it);
    if (discovery_writer_ == 0) return;
    again = announced_;
  }
  try {
    announce_node(again);
  } catch (const std::exception&) {
    // a reader removed while the participant shuts down: nobody left to tell (never throws:
    // called from ~Subscription)
  }
}

void Participant::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] { run(); });
}

void Participant::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true);
  waker_->notify();
  thread_.join();
  flush_all();  // whatever was committed after the thread's last pass
}

std::size_t Participant::flush_all() {
  std::vector<std::shared_ptr<OutboxBase>> boxes;
  {
    std::lock_guard lock(mutex_);
    boxes = outboxes_;
  }
  std::size_t n = 0;
  for (auto& b : boxes) n += b->flush(source_clock_);
  return n;
}

void Participant::run() {
  std::vector<std::shared_ptr<OutboxBase>> boxes;
  std::size_t known = 0;
  while (true) {
    const std::uint32_t seen = waker_->counter.load(std::memory_order_acquire);
    {
      std::lock_guard lock(mutex_);
      if (outboxes_.size() != known) {
        boxes = outboxes_;
        known = boxes.size();
      }
    }
    std::size_t written = 0;
    for (auto& b : boxes) written += b->flush(source_clock_);
    {
      std::lock_guard lock(idle_mutex_);  // no lost wake-up for drain()
      passes_.fetch_add(1, std::memory_order_release);
    }
    idle_cv_.notify_all();
    if (stop_.load(std::memory_order_acquire)) break;
    if (written == 0) waker_->counter.wait(seen, std::memory_order_acquire);
  }
}

bool Participant::wait_for_acks(TimeNs timeout_ns) {
  bool ok = drain(timeout_ns);
  std::lock_guard lock(mutex_);
  for (auto& b : outboxes_) {
    if (b->matched_readers() == 0) continue;
    ok = dds_wait_for_acks(b->writer(), timeout_ns) == DDS_RETCODE_OK && ok;
  }
  return ok;
}

bool Participant::wait_for_readers(const std::vector<std::string>& topics, TimeNs timeout_ns) {
  std::vector<std::string> wanted;
  for (const auto& t : topics) wanted.push_back(ros_name(t));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::nanoseconds(timeout_ns);
  for (;;) {
    bool all = true;
    {
      std::lock_guard lock(mutex_);
      for (auto& b : outboxes_) {
        const bool selected = wanted.empty() || std::find(wanted.begin(), wanted.end(), b->topic()) != wanted.end();
        if (selected) all = all && b->matched_readers() > 0;
      }
    }
    if (all) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

bool Participant::drain(TimeNs timeout_ns) {
  auto all_idle = [this] {
    std::lock_guard lock(mutex_);
    for (auto& b : outboxes_)
      if (!b->idle()) return false;
    return true;
  };
  if (!thread_.joinable()) {
    flush_all();
    return all_idle();
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::nanoseconds(timeout_ns);
  std::unique_lock lock(idle_mutex_);
  while (!all_idle()) {
    // Wait for the publisher to complete two more passes: then everything
    // committed before this call has been written (a pass may have started
    // before our samples were committed).
    const std::uint64_t target = passes_.load(std::memory_order_acquire) + 2;
    waker_->notify();
    while (passes_.load(std::memory_order_acquire) < target) {
      if (idle_cv_.wait_until(lock, deadline) == std::cv_status::timeout) return all_idle();
    }
  }
  return true;
}

std::vector<OutboxStats> Participant::stats() const {
  std::lock_guard lock(mutex_);
  std::vector<OutboxStats> out;
  out.reserve(outboxes_.size());
  for (auto& b : outboxes_) out.push_back(b->stats());
  return out;
}

std::string Participant::summary() const {
  std::ostringstream os;
  for (const auto& s : stats()) {
    os << s.topic << " published " << s.published << " dropped " << s.dropped;
    if (s.write_errors > 0) os << " write_errors " << s.write_errors;
    os << " deadline_missed " << s.deadline_missed << " readers " << s.matched_readers << "\n";
  }
  return os.str();
}

}  // namespace regolith::dds
