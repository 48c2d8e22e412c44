#pragma once
// DdsRelay: the DDS topics of a participant relayed by a FoxgloveServer. One channel per known
// regolith topic (topic = ROS name with its leading slash, encoding "cdr", schema = the type's full
// ros2msg definition); a thread of its own waits on the readers and takes each sample as the
// serialized CDR bytes on the wire (take_serialized, encapsulation header included). It only
// reads DDS, so it never blocks a rate group. Once a second the same thread publishes the server's
// own counters on /diagnostics (one DiagnosticStatus "live: foxglove server", beside whatever
// else publishes there): clients connected, accepted, refused, dropped as too slow, samples
// dropped, unauthorized requests; WARN while any of the drop / refusal counters grew in the last
// second.
#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include "regolith/live/foxglove_server.hpp"

namespace regolith::dds {
class OutboxBase;
class Participant;
class ReaderWaitSet;
class Subscription;
}  // namespace regolith::dds

namespace regolith::live {

class DdsRelay {
 public:
  /// Readers on `p` (which must outlive the relay) for every known topic, and the server
  /// (bound; throws when it cannot). Nothing is served before start().
  DdsRelay(dds::Participant& p, FoxgloveServerOptions options);
  ~DdsRelay();
  DdsRelay(const DdsRelay&) = delete;
  DdsRelay& operator=(const DdsRelay&) = delete;

  void start();  ///< the server thread and the taking thread (idempotent)
  void stop();   ///< both stopped and joined (idempotent)

  FoxgloveServer& server() { return *server_; }
  std::uint64_t samples() const { return samples_.load(); }  ///< samples taken from DDS

 private:
  struct Topic;
  void loop();
  void publish_status();

  dds::Participant& participant_;
  std::shared_ptr<dds::OutboxBase> status_;  ///< /diagnostics (DiagnosticArray)
  FoxgloveServerStats last_{};               ///< counters at the previous status
  std::string where_;                        ///< ws://ADDR:PORT
  std::unique_ptr<dds::ReaderWaitSet> waitset_;
  std::vector<std::unique_ptr<Topic>> topics_;
  std::unique_ptr<FoxgloveServer> server_;
  std::atomic<std::uint64_t> samples_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace regolith::live
