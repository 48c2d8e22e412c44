// CDR decoding for the live page: the Foxglove messageData frame and the ROS 2 messages the page
// shows, field by field as in msgs/idl. No DOM use, so node imports it too (tests/live/js).
//
// CDR (XCDR1, as Cyclone DDS writes for these @final types): a 4-byte encapsulation header
// (00 01 = little endian, 00 00 = big endian, then 2 option bytes), then the fields, each aligned
// to its own size relative to the byte after that header. Strings: uint32 length including the
// NUL, then the bytes. Sequences: uint32 count, then the elements. Fixed arrays: elements only.

const decoder = new TextDecoder("utf-8");

export class CdrReader {
  /** @param {Uint8Array} bytes the serialized message, encapsulation header included */
  constructor(bytes) {
    if (bytes.byteLength < 4 || bytes[0] !== 0 || (bytes[1] !== 0 && bytes[1] !== 1)) {
      throw new Error(`not plain CDR (encapsulation ${Array.from(bytes.subarray(0, 4)).join(" ")})`);
    }
    this.le = bytes[1] === 1;
    this.bytes = bytes.subarray(4);
    this.view = new DataView(bytes.buffer, bytes.byteOffset + 4, bytes.byteLength - 4);
    this.off = 0;
  }
  align(size) {
    this.off += (size - (this.off % size)) % size;
  }
  take(size) {
    this.align(size);
    const at = this.off;
    if (at + size > this.view.byteLength) throw new Error(`CDR: read past the end at ${at}`);
    this.off += size;
    return at;
  }
  uint8() { return this.view.getUint8(this.take(1)); }
  bool() { return this.uint8() !== 0; }
  uint16() { return this.view.getUint16(this.take(2), this.le); }
  uint32() { return this.view.getUint32(this.take(4), this.le); }
  int32() { return this.view.getInt32(this.take(4), this.le); }
  float32() { return this.view.getFloat32(this.take(4), this.le); }
  float64() { return this.view.getFloat64(this.take(8), this.le); }
  string() {
    const n = this.uint32();
    if (n === 0) return "";
    if (this.off + n > this.bytes.byteLength) throw new Error(`CDR: string of ${n} bytes past the end`);
    const s = decoder.decode(this.bytes.subarray(this.off, this.off + n - 1));
    this.off += n;
    return s;
  }
  /** A sequence: count, then `element(reader)` per element; `minSize` bounds the count. */
  sequence(element, minSize = 1) {
    const n = this.uint32();
    if (n * minSize > this.view.byteLength - this.off) throw new Error(`CDR: sequence of ${n} past the end`);
    const out = new Array(n);
    for (let i = 0; i < n; ++i) out[i] = element(this);
    return out;
  }
  float32Sequence() {
    const n = this.uint32();
    this.align(4);
    if (this.off + 4 * n > this.view.byteLength) throw new Error(`CDR: float32[${n}] past the end`);
    const out = new Float32Array(n);
    for (let i = 0; i < n; ++i, this.off += 4) out[i] = this.view.getFloat32(this.off, this.le);
    return out;
  }
  float64Sequence() { return this.sequence((r) => r.float64(), 8); }
  /** uint8[]: a view on the payload's bytes (no copy). */
  uint8Sequence() {
    const n = this.uint32();
    if (this.off + n > this.bytes.byteLength) throw new Error(`CDR: uint8[${n}] past the end`);
    const out = this.bytes.subarray(this.off, this.off + n);
    this.off += n;
    return out;
  }
  float64Array(n) {
    const out = new Array(n);
    for (let i = 0; i < n; ++i) out[i] = this.float64();
    return out;
  }
}

/** Foxglove messageData (opcode 0x01): uint32 subscription id, uint64 timestamp (ns), payload. */
export function parseMessageData(buffer) {
  const view = new DataView(buffer);
  if (buffer.byteLength < 13 || view.getUint8(0) !== 0x01) return null;
  return {
    subscriptionId: view.getUint32(1, true),
    timestamp: view.getBigUint64(5, true),
    payload: new Uint8Array(buffer, 13),
  };
}

const time = (r) => ({ sec: r.int32(), nanosec: r.uint32() });
const header = (r) => ({ stamp: time(r), frame_id: r.string() });
const vector3 = (r) => ({ x: r.float64(), y: r.float64(), z: r.float64() });
const quaternion = (r) => ({ x: r.float64(), y: r.float64(), z: r.float64(), w: r.float64() });
const pose = (r) => ({ position: vector3(r), orientation: quaternion(r) });
const poseWithCovariance = (r) => ({ pose: pose(r), covariance: r.float64Array(36) });
const twistWithCovariance = (r) => ({
  twist: { linear: vector3(r), angular: vector3(r) },
  covariance: r.float64Array(36),
});
const keyValue = (r) => ({ key: r.string(), value: r.string() });
const diagnosticStatus = (r) => ({
  level: r.uint8(),
  name: r.string(),
  message: r.string(),
  hardware_id: r.string(),
  values: r.sequence(keyValue, 8),
});
const multiArrayDimension = (r) => ({ label: r.string(), size: r.uint32(), stride: r.uint32() });
const float32MultiArray = (r) => ({
  layout: { dim: r.sequence(multiArrayDimension, 12), data_offset: r.uint32() },
  data: r.float32Sequence(),
});
const hypothesisWithPose = (r) => ({
  hypothesis: { class_id: r.string(), score: r.float64() },
  pose: poseWithCovariance(r),
});
const detection2D = (r) => ({
  header: header(r),
  results: r.sequence(hypothesisWithPose, 4),
  bbox: {
    center: { position: { x: r.float64(), y: r.float64() }, theta: r.float64() },
    size_x: r.float64(),
    size_y: r.float64(),
  },
  id: r.string(),
});
const detection3D = (r) => ({
  header: header(r),
  results: r.sequence(hypothesisWithPose, 4),
  bbox: { center: pose(r), size: vector3(r) },
  id: r.string(),
});
const transformStamped = (r) => ({
  header: header(r),
  child_frame_id: r.string(),
  transform: { translation: vector3(r), rotation: quaternion(r) },
});

/** Decoders by the advertised schemaName. */
export const decoders = {
  "diagnostic_msgs/msg/DiagnosticArray": (r) => ({ header: header(r), status: r.sequence(diagnosticStatus, 4) }),
  "regolith_msgs/msg/WheelSinkage": (r) => ({
    header: header(r),
    wheel_names: r.sequence((q) => q.string(), 4),
    sinkage_m: r.float64Sequence(),
    confidence: r.float64Sequence(),
  }),
  "regolith_msgs/msg/SoilStiffness": (r) => ({
    header: header(r),
    k: r.float64(),
    n: r.float64(),
    k_sigma: r.float64(),
    n_sigma: r.float64(),
    mean_sinkage_m: r.float64(),
    samples_used: r.uint32(),
    soil_class: r.string(),
  }),
  "grid_map_msgs/msg/GridMap": (r) => ({
    header: header(r),
    info: { resolution: r.float64(), length_x: r.float64(), length_y: r.float64(), pose: pose(r) },
    layers: r.sequence((q) => q.string(), 4),
    basic_layers: r.sequence((q) => q.string(), 4),
    data: r.sequence(float32MultiArray, 12),
    outer_start_index: r.uint16(),
    inner_start_index: r.uint16(),
  }),
  "regolith_msgs/msg/RockArray": (r) => ({
    header: header(r),
    detections: r.sequence(detection2D, 4),
    ground_range_m: r.float64Sequence(),
    lateral_offset_m: r.float64Sequence(),
    width_m: r.float64Sequence(),
    height_m: r.float64Sequence(),
    hazard: r.sequence((q) => q.bool(), 1),
  }),
  "vision_msgs/msg/Detection3DArray": (r) => ({ header: header(r), detections: r.sequence(detection3D, 4) }),
  "nav_msgs/msg/Odometry": (r) => ({
    header: header(r),
    child_frame_id: r.string(),
    pose: poseWithCovariance(r),
    twist: twistWithCovariance(r),
  }),
  "tf2_msgs/msg/TFMessage": (r) => ({ transforms: r.sequence(transformStamped, 4) }),
  "sensor_msgs/msg/CompressedImage": (r) => ({ header: header(r), format: r.string(), data: r.uint8Sequence() }),
};

/** Decodes one CDR payload of `schemaName`; throws on unknown types and malformed bytes. */
export function decode(schemaName, bytes) {
  const d = decoders[schemaName];
  if (d === undefined) throw new Error(`no decoder for ${schemaName}`);
  return d(new CdrReader(bytes));
}

/** header.stamp in seconds. */
export const stampSeconds = (h) => h.stamp.sec + h.stamp.nanosec * 1e-9;
