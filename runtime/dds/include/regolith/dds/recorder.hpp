#pragma once
// DdsRecorder: records DDS topics into an MCAP file (record/README.md), the one implementation
// behind `regolith record` (topics of another process) and `regolith run --record` (the topics of
// the running deployment, on its own participant). Samples are taken as the serialized CDR bytes
// that were on the wire (take_serialized), one ros2msg Schema per ROS type, one cdr Channel per
// topic. A non-real-time thread of its own waits on the readers and writes; it only reads DDS,
// so it never blocks a rate group. Target regolith::dds_record (dds + record + ros2msg).
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "regolith/core/time.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/record/mcap_writer.hpp"
#include "regolith/record/sink.hpp"

namespace regolith::dds {

class Participant;
class ReaderWaitSet;
class Subscription;

struct DdsRecorderOptions {
  std::vector<const TopicInfo*> topics;  ///< what to record (each once); empty = every known topic
  record::Compression compression = record::Compression::kZstd;
  std::string library = "regolith";  ///< MCAP Header.library
  /// Keep-all reader history (the writers' lossless mode under simulated time): no sample is lost
  /// however far the recorder falls behind (memory grows instead). False: the topic's reader QoS
  /// (keep-last, as `regolith echo`).
  bool keep_all = false;
  std::uint64_t max_samples = 0;  ///< stop taking after this many samples in total (0 = no limit)
  /// MCAP log time of a DDS sample: false = when it was received (wall clock, as rosbag2);
  /// true = on the simulated time line (`--use-sim-time`, see sim_log_time()): a writer on
  /// simulated time (dds::Participant::set_source_clock: `regolith run --sim-time`) is logged at
  /// its DDS source timestamp, so the recording plays back on the run's own time line however fast
  /// it ran; a writer on wall time (a ROS 2 node under use_sim_time stamps its headers by /clock but
  /// its DDS samples by the wall clock) at the newest /clock received, as rosbag2 does. The
  /// recorder reads /clock for that whether or not it is one of `topics`.
  bool log_source_time = false;
  /// Split into files of about this many bytes / this long (0 = never; record::McapWriterOptions).
  std::uint64_t split_bytes = 0;
  std::uint64_t split_duration_ns = 0;
  /// Called once, from the thread that hit it, when writing the file fails (disk full, file too
  /// large, I/O error): the message names the file and the byte. The recording then stops; samples
  /// keep being taken (the readers are drained) and are counted as lost(). May be empty.
  std::function<void(const std::string&)> on_error;
};

/// The log time of one sample on the simulated time line (DdsRecorderOptions::log_source_time):
/// its source timestamp `source_ns` when that is nearer the newest /clock `clock_ns` than the
/// wall-clock receipt time `receipt_ns` (a writer on simulated time), else `clock_ns` (a writer on
/// wall time, logged where rosbag2 would). `clock_ns` < 0 (no /clock received yet): `source_ns`.
std::uint64_t sim_log_time(std::uint64_t source_ns, std::int64_t clock_ns, std::uint64_t receipt_ns);

/// The rosbag2 (Humble) `offered_qos_profiles` YAML of regolith's writers of a topic.
std::string offered_qos_yaml(const QosProfile& q);

class DdsRecorder final : public record::MessageSink {
 public:
  struct TopicCount {
    std::string ros_name;  ///< e.g. /rover1/joint_states
    std::string ros_type;  ///< e.g. sensor_msgs/msg/JointState
    std::uint64_t count = 0;
  };

  /// Creates the file (throws when it cannot), the schemas, channels and one reader per topic on
  /// `p` (which must outlive the recorder). No sample is taken before start().
  DdsRecorder(Participant& p, const std::filesystem::path& file, DdsRecorderOptions options);
  ~DdsRecorder();
  DdsRecorder(const DdsRecorder&) = delete;
  DdsRecorder& operator=(const DdsRecorder&) = delete;

  /// Attachment / Metadata records (thread-safe, also while recording).
  void add_attachment(const std::string& name, const std::string& media_type, const std::string& data);
  void add_metadata(const std::string& name, const std::map<std::string, std::string>& values) override;
  /// Channels and messages of other recorders in the same file (record::MessageSink: the HAL
  /// recorder of `regolith run --record`); thread-safe.
  std::uint16_t add_cdr_channel(const std::string& topic, const std::string& ros_type,
                                const std::map<std::string, std::string>& metadata) override;
  void write(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time, std::uint64_t publish_time,
             std::span<const std::uint8_t> data) override;

  /// Starts the recording thread (idempotent).
  void start();
  /// Stops the thread, takes what the readers still hold (unless max_samples was reached), writes
  /// the last chunk, the summary and the footer (idempotent). Never throws for a write error: it
  /// is kept in error() (the file then ends where the writing failed: every chunk before is whole).
  void stop();
  /// Why the recording stopped early ("" while it is fine): the first write error, naming the file.
  std::string error() const;
  /// Samples (DDS and other recorders' messages) not written because the recording had failed.
  std::uint64_t lost() const { return lost_.load(); }
  /// True once max_samples samples were recorded.
  bool done() const;
  /// Samples logged at the newest /clock instead of their source time (log_source_time: writers on
  /// wall time).
  std::uint64_t logged_at_clock() const { return at_clock_.load(); }

  std::uint64_t total() const { return total_.load(); }
  std::vector<TopicCount> counts() const;
  std::uint64_t file_bytes() const;
  std::size_t topic_count() const { return rec_.size(); }
  /// CPU time used by the recording thread so far (CLOCK_THREAD_CPUTIME_ID; updated every wake-up).
  TimeNs thread_cpu_ns() const { return cpu_ns_.load(); }
  const std::filesystem::path& path() const { return path_; }
  /// The files written so far (more than one when split).
  std::vector<std::filesystem::path> files() const;

 private:
  struct Recorded;
  void take_all();
  void take(Recorded& r);
  void note_clock(std::span<const std::uint8_t> cdr);  // mutex_ held
  void loop();
  void fail(const std::exception& e);  // mutex_ held: keeps the first error, stops writing

  std::filesystem::path path_;
  DdsRecorderOptions opts_;
  mutable std::mutex mutex_;  // guards writer_
  std::unique_ptr<record::McapWriter> writer_;
  std::unique_ptr<ReaderWaitSet> waitset_;
  std::vector<std::unique_ptr<Recorded>> rec_;
  // log_source_time: /clock, taken before the topics on every pass: the recorded one (clock_rec_)
  // or a reader of its own (clock_sub_, not recorded, not on the waitset).
  Recorded* clock_rec_ = nullptr;
  std::unique_ptr<Subscription> clock_sub_;
  std::int64_t newest_clock_ = -1;  // guarded by mutex_; -1 = none yet
  std::vector<std::uint8_t> scratch_;
  std::map<std::string, std::uint16_t> schemas_;  // ROS type -> schema id (guarded by mutex_)
  std::uint16_t schema_for(const std::string& ros_type);
  std::atomic<std::uint64_t> total_{0}, lost_{0}, at_clock_{0};
  std::string error_;  // guarded by mutex_
  std::atomic<bool> stop_{false};
  std::atomic<TimeNs> cpu_ns_{0};
  std::thread thread_;
  bool closed_ = false;
  bool writer_closed_ = false;  // guarded by mutex_: late write()s of other recorders are ignored
};

}  // namespace regolith::dds
