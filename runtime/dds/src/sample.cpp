#include "regolith/dds/sample.hpp"

#include <new>

namespace regolith::dds {

char* alloc_string(std::size_t capacity) {
  void* p = dds_alloc(capacity + 1);
  if (p == nullptr) throw std::bad_alloc();
  std::memset(p, 0, capacity + 1);
  return static_cast<char*>(p);
}

void free_contents(const dds_topic_descriptor_t* desc, void* sample) noexcept {
  if (sample == nullptr || desc == nullptr) return;
  dds_sample_free(sample, desc, DDS_FREE_CONTENTS);
  std::memset(sample, 0, desc->m_size);
}

namespace {
void reserve_header(msgs::std_msgs::Header& h, std::size_t frame_id_capacity) {
  if (h.frame_id != nullptr) dds_free(h.frame_id);
  h.frame_id = alloc_string(frame_id_capacity);
  h.stamp = {};
}
}  // namespace

void reserve(msgs::sensor_msgs::Imu& m, std::size_t frame_id_capacity) {
  reserve_header(m.header, frame_id_capacity);
}

void reserve(msgs::sensor_msgs::CompressedImage& m, std::uint32_t max_bytes, std::size_t format_capacity,
             std::size_t frame_id_capacity) {
  reserve_header(m.header, frame_id_capacity);
  if (m.format != nullptr) dds_free(m.format);
  m.format = alloc_string(format_capacity);
  reserve_sequence(m.data, max_bytes);
}

void reserve(msgs::nav_msgs::Odometry& m, std::size_t frame_id_capacity) {
  reserve_header(m.header, frame_id_capacity);
  if (m.child_frame_id != nullptr) dds_free(m.child_frame_id);
  m.child_frame_id = alloc_string(frame_id_capacity);
  m.pose.pose.orientation.w = 1.0;
}

void reserve(msgs::tf2_msgs::TFMessage& m, std::uint32_t transforms, std::size_t frame_id_capacity) {
  reserve_sequence(m.transforms, transforms);
  for (std::uint32_t i = 0; i < transforms; ++i) {
    auto& t = m.transforms._buffer[i];
    reserve_header(t.header, frame_id_capacity);
    t.child_frame_id = alloc_string(frame_id_capacity);
    t.transform.rotation.w = 1.0;
  }
}

void reserve(msgs::rcl_interfaces::Log& m, std::size_t msg_capacity, std::size_t name_capacity) {
  for (char** s : {&m.name, &m.file, &m.function}) {
    if (*s != nullptr) dds_free(*s);
    *s = alloc_string(name_capacity);
  }
  if (m.msg != nullptr) dds_free(m.msg);
  m.msg = alloc_string(msg_capacity);
}

void reserve(msgs::sensor_msgs::JointState& m, const JointStateCapacity& c) {
  reserve_header(m.header, c.frame_id_capacity);
  reserve_string_sequence(m.name, c.joints, c.name_capacity);
  reserve_sequence(m.position, c.joints);
  reserve_sequence(m.velocity, c.joints);
  reserve_sequence(m.effort, c.joints);
}

void reserve(msgs::diagnostic_msgs::DiagnosticArray& m, const DiagnosticArrayCapacity& c) {
  reserve_header(m.header, c.frame_id_capacity);
  reserve_sequence(m.status, c.statuses);
  for (std::uint32_t i = 0; i < c.statuses; ++i) {
    auto& s = m.status._buffer[i];
    s.name = alloc_string(c.string_capacity);
    s.message = alloc_string(c.string_capacity);
    s.hardware_id = alloc_string(c.string_capacity);
    reserve_sequence(s.values, c.values_per_status);
    for (std::uint32_t k = 0; k < c.values_per_status; ++k) {
      s.values._buffer[k].key = alloc_string(c.string_capacity);
      s.values._buffer[k].value = alloc_string(c.string_capacity);
    }
  }
}

void reserve(msgs::regolith_msgs::WheelSinkage& m, const WheelSinkageCapacity& c) {
  reserve_header(m.header, c.frame_id_capacity);
  reserve_string_sequence(m.wheel_names, c.wheels, c.name_capacity);
  reserve_sequence(m.sinkage_m, c.wheels);
  reserve_sequence(m.confidence, c.wheels);
}

void reserve(msgs::regolith_msgs::SoilStiffness& m, const SoilStiffnessCapacity& c) {
  reserve_header(m.header, c.frame_id_capacity);
  if (m.soil_class != nullptr) dds_free(m.soil_class);
  m.soil_class = alloc_string(c.soil_class_capacity);
}

void reserve(msgs::grid_map_msgs::GridMap& m, const GridMapCapacity& c) {
  reserve_header(m.header, c.frame_id_capacity);
  m.info.pose.orientation.w = 1.0;
  reserve_string_sequence(m.layers, c.layers, c.name_capacity);
  reserve_string_sequence(m.basic_layers, c.basic_layers, c.name_capacity);
  reserve_sequence(m.data, c.layers);
  const std::uint32_t cells = c.size_x * c.size_y;
  for (std::uint32_t i = 0; i < c.layers; ++i) {
    auto& layer = m.data._buffer[i];
    reserve_sequence(layer.layout.dim, 2);
    layer.layout.dim._length = 2;
    auto& d0 = layer.layout.dim._buffer[0];
    auto& d1 = layer.layout.dim._buffer[1];
    d0.label = alloc_string(16);
    d1.label = alloc_string(16);
    copy_string(d0.label, 16, "column_index");
    copy_string(d1.label, 16, "row_index");
    d0.size = c.size_y;  // columns
    d0.stride = cells;
    d1.size = c.size_x;  // rows
    d1.stride = c.size_x;
    layer.layout.data_offset = 0;
    reserve_sequence(layer.data, cells);
    layer.data._length = cells;
  }
  m.outer_start_index = 0;
  m.inner_start_index = 0;
}

namespace {
// One vision_msgs Detection2D / Detection3D: its frame_id and id strings, `hypotheses` results
// (class_id reserved, orientation identity; the sequence's length left as it is).
template <class Detection>
void reserve_detection(Detection& d, std::uint32_t hypotheses, std::size_t string_capacity,
                       std::size_t frame_id_capacity) {
  d.header.frame_id = alloc_string(frame_id_capacity);
  d.id = alloc_string(string_capacity);
  reserve_sequence(d.results, hypotheses);
  for (std::uint32_t k = 0; k < hypotheses; ++k) {
    auto& r = d.results._buffer[k];
    r.hypothesis.class_id = alloc_string(string_capacity);
    r.pose.pose.orientation.w = 1.0;
  }
}
}  // namespace

void reserve(msgs::regolith_msgs::RockArray& m, const RockArrayCapacity& c) {
  reserve_header(m.header, c.frame_id_capacity);
  reserve_sequence(m.detections, c.rocks);
  for (std::uint32_t i = 0; i < c.rocks; ++i)
    reserve_detection(m.detections._buffer[i], c.hypotheses, c.string_capacity, c.frame_id_capacity);
  reserve_sequence(m.ground_range_m, c.rocks);
  reserve_sequence(m.lateral_offset_m, c.rocks);
  reserve_sequence(m.width_m, c.rocks);
  reserve_sequence(m.height_m, c.rocks);
  reserve_sequence(m.hazard, c.rocks);
}

void reserve(msgs::vision_msgs::Detection3DArray& m, const Detection3DArrayCapacity& c) {
  reserve_header(m.header, c.frame_id_capacity);
  reserve_sequence(m.detections, c.detections);
  for (std::uint32_t i = 0; i < c.detections; ++i) {
    auto& d = m.detections._buffer[i];
    reserve_detection(d, c.hypotheses, c.string_capacity, c.frame_id_capacity);
    d.results._length = c.hypotheses;
    d.bbox.center.orientation.w = 1.0;
  }
  m.detections._length = 0;
}

}  // namespace regolith::dds
