// The live page: connects back to the server that served it (Foxglove WebSocket protocol,
// runtime/live/README.md), subscribes to the topics its panels show and draws them. `?ws=URL`
// points it at another server.
import { decode, parseMessageData, stampSeconds } from "./cdr.js";

const LEVELS = ["OK", "WARN", "ERROR", "STALE"];
const SINKAGE_WINDOW_S = 60;
const WHEEL_COLOURS = ["#4fc3f7", "#ffb74d", "#81c784", "#f06292", "#ba68c8", "#fff176", "#4db6ac", "#e57373"];

// Topic suffixes (relative names carry the rover's namespace: /rover1/terrain/soil).
const TOPICS = {
  diagnostics: { suffix: "/diagnostics", schema: "diagnostic_msgs/msg/DiagnosticArray" },
  sinkage: { suffix: "/terrain/wheel_sinkage", schema: "regolith_msgs/msg/WheelSinkage" },
  soil: { suffix: "/terrain/soil", schema: "regolith_msgs/msg/SoilStiffness" },
  gridMap: { suffix: "/terrain/grid_map", schema: "grid_map_msgs/msg/GridMap" },
  worldMap: { suffix: "/terrain/world_map", schema: "grid_map_msgs/msg/GridMap" },
  rocks: { suffix: "/terrain/rocks", schema: "regolith_msgs/msg/RockArray" },
  worldRocks: { suffix: "/terrain/world_rocks", schema: "vision_msgs/msg/Detection3DArray" },
  odom: { suffix: "/odom", schema: "nav_msgs/msg/Odometry" },
  tf: { suffix: "/tf", schema: "tf2_msgs/msg/TFMessage" },
  rocksPreview: { suffix: "/preview/rocks/compressed", schema: "sensor_msgs/msg/CompressedImage" },
  sinkagePreview: { suffix: "/preview/sinkage/compressed", schema: "sensor_msgs/msg/CompressedImage" },
};

const $ = (id) => document.getElementById(id);
const fixed = (v, digits) => (Number.isFinite(v) ? v.toFixed(digits) : "–");
const stampText = (h) => `${h.frame_id || "?"} @ ${new Date(stampSeconds(h) * 1000).toISOString().slice(11, 23)} UTC`;

function cell(row, text, cls) {
  const td = row.insertCell();
  td.textContent = text;
  if (cls) td.className = cls;
  return td;
}

// The runtime's microsecond strings carry 3-4 decimals: fewer once the value is large.
function micros(text) {
  const v = Number(text);
  return text === undefined || !Number.isFinite(v) ? text ?? "" : v.toFixed(v >= 1000 ? 0 : v >= 10 ? 1 : 2);
}

function arrived(panel) {
  document.querySelectorAll(`.waiting[data-topic="${panel}"]`).forEach((p) => (p.hidden = true));
}

// ---- (a) health -------------------------------------------------------------------------------
const slipsSeen = new Map(); // status name -> {slips, rising_until}

// /diagnostics has several publishers (the rover's health component, the live server itself):
// the newest status of each name is kept, and dropped when not refreshed for 10 s.
const statusSeen = new Map(); // status name -> {status, at}
function onDiagnostics(msg) {
  arrived("diagnostics");
  $("health-table").hidden = false;
  const body = $("health-table").tBodies[0];
  body.replaceChildren();
  const now = performance.now();
  for (const s of msg.status) statusSeen.set(s.name, { status: s, at: now });
  for (const [name, e] of statusSeen) if (now - e.at > 10000) statusSeen.delete(name);
  const order = (name) => (name.startsWith("rate_group:") ? 0 : name.startsWith("component:") ? 1 : 2);
  const statuses = [...statusSeen.values()].map((e) => e.status)
    .sort((a, b) => order(a.name) - order(b.name) || a.name.localeCompare(b.name));
  for (const s of statuses) {
    const kv = Object.fromEntries(s.values.map((v) => [v.key, v.value]));
    const slips = Number(kv.cycle_slips ?? 0);
    // A slip is news while the count grows; an old count alone is history (amber cell, not a red row).
    const seen = slipsSeen.get(s.name) ?? { slips, risingUntil: 0 };
    if (slips > seen.slips) seen.risingUntil = now + 5000;
    seen.slips = slips;
    slipsSeen.set(s.name, seen);
    const slipping = now < seen.risingUntil;
    const row = body.insertRow();
    row.className = ["ok", "warn", "error", "stale"][s.level] ?? "error";
    if (slipping) row.className = "error";
    row.dataset.name = s.name;
    cell(row, LEVELS[s.level] ?? String(s.level), "level");
    const [kind, ...rest] = s.name.split(": ");
    const name = cell(row, rest.length > 0 ? rest.join(": ") : s.name);
    if (rest.length > 0) {
      const tag = document.createElement("span");
      tag.className = "kind";
      tag.textContent = kind;
      name.prepend(tag, " ");
    }
    cell(row, s.message);
    const period = Number(kv.period_us);
    cell(row, period > 0 ? fixed(1e6 / period, 1) : "", "num");
    // A rate group's slips from a late start or a stall alone (the CPU was taken outside the group)
    // beside them.
    const late = Number(kv.late_start_slips ?? 0);
    const stalled = Number(kv.stall_slips ?? 0);
    const outside = [late > 0 ? `${late} late` : "", stalled > 0 ? `${stalled} stalled` : ""].filter((x) => x).join(", ");
    cell(row, (kv.cycle_slips ?? "") + (outside ? ` (${outside})` : ""), "num" + (slips > 0 ? " bad" : ""));
    cell(row, micros(kv.exec_p99_us), "num");
    cell(row, micros(kv.wakeup_p99_us), "num");
    const errors = kv.errors ?? kv.faults ?? "";
    cell(row, errors, "num" + (Number(errors) > 0 ? " bad" : ""));
    const shown = new Set(["period_us", "cycle_slips", "late_start_slips", "stall_slips", "exec_p99_us", "wakeup_p99_us", "errors",
      "faults"]);
    const other = cell(row, s.values.filter((v) => !shown.has(v.key)).map((v) => `${v.key} ${v.value}`).join(" · "), "other");
    other.title = other.textContent; // the cell is cut to one line
  }
}

// ---- (b) wheel sinkage ------------------------------------------------------------------------
const sinkage = { wheels: new Map(), latest: 0, dirty: false }; // wheel -> [{t, mm}]

function onSinkage(msg) {
  arrived("sinkage");
  $("sinkage-body").hidden = false;
  const t = stampSeconds(msg.header);
  sinkage.latest = Math.max(sinkage.latest, t);
  const body = $("sinkage-table").tBodies[0];
  body.replaceChildren();
  msg.wheel_names.forEach((wheel, i) => {
    if (!sinkage.wheels.has(wheel)) sinkage.wheels.set(wheel, []);
    const series = sinkage.wheels.get(wheel);
    series.push({ t, mm: msg.sinkage_m[i] * 1000 });
    while (series.length > 0 && series[0].t < sinkage.latest - SINKAGE_WINDOW_S) series.shift();
    const row = body.insertRow();
    const name = cell(row, wheel);
    name.style.borderLeft = `4px solid ${wheelColour(wheel)}`;
    cell(row, fixed(msg.sinkage_m[i] * 1000, 1), "num");
    cell(row, fixed(msg.confidence[i], 2), "num");
  });
  sinkage.dirty = true;
}

function wheelColour(wheel) {
  return WHEEL_COLOURS[[...sinkage.wheels.keys()].indexOf(wheel) % WHEEL_COLOURS.length];
}

function drawSinkage() {
  const canvas = $("sinkage-canvas");
  const g = canvas.getContext("2d");
  const W = canvas.width, H = canvas.height, L = 44, R = 10, T = 10, B = 24;
  g.clearRect(0, 0, W, H);
  let max = 1;
  for (const s of sinkage.wheels.values()) for (const p of s) if (Number.isFinite(p.mm)) max = Math.max(max, p.mm);
  max = Math.ceil(max * 1.15);
  const x = (t) => L + ((t - sinkage.latest + SINKAGE_WINDOW_S) / SINKAGE_WINDOW_S) * (W - L - R);
  const y = (mm) => H - B - (mm / max) * (H - T - B);
  g.font = "11px system-ui, sans-serif";
  g.strokeStyle = "#2c3440";
  g.fillStyle = "#8a96a8";
  for (let k = 0; k <= 4; ++k) {
    const mm = (max * k) / 4;
    g.beginPath(); g.moveTo(L, y(mm)); g.lineTo(W - R, y(mm)); g.stroke();
    g.fillText(mm.toFixed(max < 8 ? 1 : 0), 4, y(mm) + 4);
  }
  for (let s = 0; s <= SINKAGE_WINDOW_S; s += 10) {
    g.fillText(`${s - SINKAGE_WINDOW_S} s`, x(sinkage.latest - SINKAGE_WINDOW_S + s) - 12, H - 6);
  }
  g.save();
  g.translate(12, T + 40); g.rotate(-Math.PI / 2); g.fillText("mm", 0, 0);
  g.restore();
  g.lineWidth = 2;
  for (const [wheel, series] of sinkage.wheels) {
    g.strokeStyle = wheelColour(wheel);
    g.beginPath();
    let pen = false; // NaN (no estimate) breaks the line
    for (const p of series) {
      if (!Number.isFinite(p.mm)) { pen = false; continue; }
      pen ? g.lineTo(x(p.t), y(p.mm)) : g.moveTo(x(p.t), y(p.mm));
      pen = true;
    }
    g.stroke();
  }
  g.lineWidth = 1;
}

// ---- (c) soil ---------------------------------------------------------------------------------
function onSoil(msg) {
  arrived("soil");
  $("soil-body").hidden = false;
  $("soil-class").textContent = msg.soil_class || "unclassified";
  $("soil-k").textContent = fixed(msg.k / 1000, 1);
  $("soil-k-sigma").textContent = `± ${fixed(msg.k_sigma / 1000, 1)}`;
  $("soil-n").textContent = fixed(msg.n, 3);
  $("soil-n-sigma").textContent = msg.n_sigma === 0 ? "(fixed)" : `± ${fixed(msg.n_sigma, 3)}`;
  $("soil-sinkage").textContent = fixed(msg.mean_sinkage_m * 1000, 1);
  $("soil-samples").textContent = String(msg.samples_used);
  $("soil-stamp").textContent = stampText(msg.header);
}

// ---- (d) terrain map --------------------------------------------------------------------------
const maps = { gridMap: null, worldMap: null }; // latest GridMap of each topic
let worldRocks = null; // latest Detection3DArray of the map's rocks (drawn on a map of its frame)
const path = []; // rover positions {frame, x, y, yaw} from odom (else /tf)
let pathFromOdom = false;
let baseFrame = "base_link"; // the rover's frame: odometry's child_frame_id once known

// A perceptual dark-to-bright scale (viridis stops).
const SCALE = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
function colour(f) {
  const x = Math.min(Math.max(f, 0), 1) * (SCALE.length - 1);
  const i = Math.min(Math.floor(x), SCALE.length - 2), u = x - i;
  return SCALE[i].map((c, k) => Math.round(c + u * (SCALE[i + 1][k] - c)));
}

function onMap(which, msg) {
  maps[which] = msg;
  const topic = $("map-topic");
  if (![...topic.options].some((o) => o.value === which)) {
    topic.add(new Option(TOPICS[which].topic, which));
    // The world map (odom frame, with the path) is the more useful default once it exists.
    if (which === "worldMap" || topic.options.length === 1) topic.value = which;
  }
  if (topic.value === which) drawMap();
}

function yawOf(q) {
  return Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z));
}

function addPose(frame, p, q, fromOdom) {
  if (fromOdom) pathFromOdom = true;
  else if (pathFromOdom) return;
  const last = path[path.length - 1];
  if (last && last.frame === frame && Math.hypot(p.x - last.x, p.y - last.y) < 0.02) {
    last.yaw = yawOf(q);
    return;
  }
  path.push({ frame, x: p.x, y: p.y, yaw: yawOf(q) });
  if (path.length > 5000) path.shift();
}

function drawMap() {
  const which = $("map-topic").value;
  const msg = maps[which];
  if (!msg) return;
  arrived("map");
  document.querySelector('[data-name="map"]').textContent = TOPICS[which].topic;
  $("map-body").hidden = false;
  const layerSelect = $("map-layer");
  const names = [...layerSelect.options].map((o) => o.value);
  if (names.join() !== msg.layers.join()) {
    const keep = layerSelect.value;
    layerSelect.replaceChildren(...msg.layers.map((l) => new Option(l, l)));
    layerSelect.value = msg.layers.includes(keep) ? keep : msg.layers[0];
  }
  const k = msg.layers.indexOf(layerSelect.value);
  const layer = msg.data[k];
  if (!layer || layer.layout.dim.length < 2) return;
  // grid_map layout: column-major, dim[1] = rows (cells along x), dim[0] = columns (along y);
  // row 0 / column 0 is the +x / +y corner, shifted by the circular buffer's start indices.
  const rows = layer.layout.dim[1].size, cols = layer.layout.dim[0].size, stride = layer.layout.dim[1].stride;
  const at = (i, j) =>
    layer.data[layer.layout.data_offset + ((j + msg.inner_start_index) % cols) * stride + ((i + msg.outer_start_index) % rows)];
  let lo = Infinity, hi = -Infinity;
  for (const v of layer.data) if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!(hi > lo)) hi = lo + 1;
  const img = new ImageData(cols, rows); // screen: up = +x (ahead), left = +y
  for (let i = 0; i < rows; ++i) {
    for (let j = 0; j < cols; ++j) {
      const v = at(i, j), o = 4 * (i * cols + j);
      const [r, g, b] = Number.isFinite(v) ? colour((v - lo) / (hi - lo)) : [28, 32, 38];
      img.data.set([r, g, b, 255], o);
    }
  }
  const canvas = $("map-canvas");
  const g = canvas.getContext("2d");
  g.fillStyle = "#12161c";
  g.fillRect(0, 0, canvas.width, canvas.height);
  const px = Math.min(canvas.width / cols, canvas.height / rows);
  const ox = (canvas.width - px * cols) / 2, oy = (canvas.height - px * rows) / 2;
  const tmp = new OffscreenCanvas(cols, rows);
  tmp.getContext("2d").putImageData(img, 0, 0);
  g.imageSmoothingEnabled = false;
  g.drawImage(tmp, ox, oy, px * cols, px * rows);
  const info = msg.info, res = info.resolution;
  // Map-frame (x, y) to canvas pixels.
  const toCanvas = (x, y) => [
    ox + ((info.pose.position.y + info.length_y / 2 - y) / res) * px,
    oy + ((info.pose.position.x + info.length_x / 2 - x) / res) * px,
  ];
  const frame = msg.header.frame_id;
  const track = path.filter((p) => p.frame === frame);
  if (track.length > 1) {
    g.strokeStyle = "rgba(255,255,255,0.85)";
    g.lineWidth = 2;
    g.beginPath();
    track.forEach((p, n) => (n ? g.lineTo(...toCanvas(p.x, p.y)) : g.moveTo(...toCanvas(p.x, p.y))));
    g.stroke();
    g.lineWidth = 1;
  }
  // The map's rocks (terrain/world_rocks, same frame): the footprint (width) filled, and the
  // ellipse the rock's position covariance puts it in with 95 % (2.45 sd: sqrt of the chi-square 95 % point
  // for 2 degrees of freedom, regolith::mapping::kChi2TwoDof95) dashed.
  const rocks = worldRocks && worldRocks.header.frame_id === frame ? worldRocks.detections : [];
  for (const d of rocks) {
    const h = d.results[0];
    if (!h) continue;
    const [cx, cy] = toCanvas(h.pose.pose.position.x, h.pose.pose.position.y);
    g.fillStyle = "rgba(255,171,64,0.55)";
    g.strokeStyle = "#ffab40";
    g.beginPath();
    g.arc(cx, cy, Math.max(2, (0.5 * d.bbox.size.x / res) * px), 0, 2 * Math.PI);
    g.fill();
    const c = h.pose.covariance, a = c[0], b = c[1], e = c[7];
    const mid = 0.5 * (a + e), rad = Math.hypot(0.5 * (a - e), b);
    if (mid - rad > 0) {
      // Canvas axes: right = -y, down = -x; the ellipse's major axis at `angle` from +x in the map.
      const angle = 0.5 * Math.atan2(2 * b, a - e), k = (2.45 / res) * px;
      g.setLineDash([4, 3]);
      g.beginPath();
      g.ellipse(cx, cy, k * Math.sqrt(mid + rad), k * Math.sqrt(mid - rad), -Math.PI / 2 - angle, 0, 2 * Math.PI);
      g.stroke();
      g.setLineDash([]);
    }
  }
  $("map-rocks").textContent = rocks.length
    ? `${rocks.length} rocks from ${TOPICS.worldRocks.topic}: footprint filled, 95 % position ellipse dashed`
    : "";
  // The rover: its last pose in the map's frame, or the origin of a body-frame map.
  const rover = track.length > 0 ? track[track.length - 1] : frame === baseFrame ? { x: 0, y: 0, yaw: 0 } : null;
  if (rover) {
    const [cx, cy] = toCanvas(rover.x, rover.y);
    g.save();
    g.translate(cx, cy);
    g.rotate(-rover.yaw);
    g.fillStyle = "#ff5252";
    g.strokeStyle = "#fff";
    g.beginPath(); g.moveTo(0, -10); g.lineTo(6, 7); g.lineTo(-6, 7); g.closePath();
    g.fill(); g.stroke();
    g.restore();
  }
  const scale = $("map-scale"), sg = scale.getContext("2d");
  for (let x = 0; x < scale.width; ++x) {
    sg.fillStyle = `rgb(${colour(x / (scale.width - 1)).join(",")})`;
    sg.fillRect(x, 0, 1, scale.height);
  }
  $("map-min").textContent = fixed(lo, 3);
  $("map-max").textContent = `${fixed(hi, 3)}  ${layerSelect.value}`;
  $("map-stamp").textContent = `${stampText(msg.header)} · ${cols}×${rows} cells of ${fixed(res, 2)} m`;
  canvas.onmousemove = (e) => {
    const r = canvas.getBoundingClientRect();
    const j = Math.floor(((e.clientX - r.left) * (canvas.width / r.width) - ox) / px);
    const i = Math.floor(((e.clientY - r.top) * (canvas.height / r.height) - oy) / px);
    if (i < 0 || j < 0 || i >= rows || j >= cols) return ($("map-readout").textContent = "");
    const x = info.pose.position.x + info.length_x / 2 - (i + 0.5) * res;
    const y = info.pose.position.y + info.length_y / 2 - (j + 0.5) * res;
    $("map-readout").textContent = `x ${fixed(x, 2)} y ${fixed(y, 2)}: ${fixed(at(i, j), 3)}`;
  };
}

// ---- (e) rocks --------------------------------------------------------------------------------
function onRocks(msg) {
  arrived("rocks");
  $("rock-table").hidden = false;
  $("rock-count").textContent = `${msg.detections.length} · ${msg.hazard.filter(Boolean).length} hazards`;
  const body = $("rock-table").tBodies[0];
  body.replaceChildren();
  msg.detections.forEach((d, i) => {
    const row = body.insertRow();
    if (msg.hazard[i]) row.className = "error";
    const best = d.results[0]?.hypothesis;
    cell(row, d.id);
    cell(row, best?.class_id ?? "");
    cell(row, best ? fixed(best.score, 2) : "", "num");
    cell(row, fixed(msg.ground_range_m[i], 2), "num");
    cell(row, fixed(msg.lateral_offset_m[i], 2), "num");
    cell(row, fixed(msg.width_m[i], 2), "num");
    cell(row, fixed(msg.height_m[i], 2), "num");
    cell(row, msg.hazard[i] ? "HAZARD" : "", msg.hazard[i] ? "bad" : "");
  });
}

// ---- (f) camera previews: JPEGs with the overlays drawn by the rover (camera_preview) -------------
const previewUrls = {};
function onPreview(which, msg) {
  arrived(which);
  const img = $(`${which}-image`);
  const url = URL.createObjectURL(new Blob([msg.data], { type: `image/${msg.format === "png" ? "png" : "jpeg"}` }));
  img.onload = () => {
    img.hidden = false;
    $(`${which}-info`).textContent =
      `${img.naturalWidth}×${img.naturalHeight} · ${(msg.data.byteLength / 1024).toFixed(1)} KiB · ` +
      `${msg.header.frame_id} · t = ${stampSeconds(msg.header).toFixed(2)} s`;
    // the size of the last decoded frame (naturalWidth reads 0 again while the next one loads)
    img.dataset.width = String(img.naturalWidth);
    img.dataset.frames = String(Number(img.dataset.frames ?? 0) + 1);
  };
  img.src = url;
  if (previewUrls[which]) URL.revokeObjectURL(previewUrls[which]);
  previewUrls[which] = url;
}

// ---- connection -------------------------------------------------------------------------------
const HANDLERS = {
  diagnostics: onDiagnostics,
  sinkage: onSinkage,
  soil: onSoil,
  gridMap: (m) => onMap("gridMap", m),
  worldMap: (m) => onMap("worldMap", m),
  worldRocks: (m) => {
    worldRocks = m;
    drawMap();
  },
  rocks: onRocks,
  rocksPreview: (m) => onPreview("rocksPreview", m),
  sinkagePreview: (m) => onPreview("sinkagePreview", m),
  odom: (m) => {
    baseFrame = m.child_frame_id || baseFrame;
    addPose(m.header.frame_id, m.pose.pose.position, m.pose.pose.orientation, true);
  },
  // Only the rover's own transform: /tf also carries its sensors' frames.
  tf: (m) => m.transforms.filter((t) => t.child_frame_id === baseFrame)
    .forEach((t) => addPose(t.header.frame_id, t.transform.translation, t.transform.rotation, false)),
};

function status(text, cls) {
  $("connection").textContent = text;
  $("connection").className = `conn ${cls}`;
}

function advertised(channels, ws) {
  const subscriptions = [];
  const subs = new Map();
  for (const [key, t] of Object.entries(TOPICS)) {
    const ch = channels.find((c) => c.schemaName === t.schema && (c.topic === t.suffix || c.topic.endsWith(t.suffix)));
    t.topic = ch ? ch.topic : t.suffix.slice(1);
    if (!ch) continue;
    subs.set(subscriptions.length + 1, { key, schema: ch.schemaName });
    subscriptions.push({ id: subscriptions.length + 1, channelId: ch.id });
  }
  const panels = { diagnostics: ["diagnostics"], sinkage: ["sinkage"], soil: ["soil"], rocks: ["rocks"],
    map: ["worldMap", "gridMap"], rocksPreview: ["rocksPreview"], sinkagePreview: ["sinkagePreview"] };
  for (const [panel, keys] of Object.entries(panels)) {
    const names = keys.map((k) => TOPICS[k].topic);
    const missing = !channels.some((c) => names.includes(c.topic));
    document.querySelectorAll(`.waiting[data-topic="${panel}"]`).forEach((p) => {
      p.textContent = missing ? `${names.join(" / ")}: not advertised by this server` : `waiting for ${names.join(" or ")}`;
    });
    if (keys.length === 1) document.querySelectorAll(`[data-name="${panel}"]`).forEach((s) => (s.textContent = names[0]));
  }
  ws.send(JSON.stringify({ op: "subscribe", subscriptions }));
  return subs;
}

function connect() {
  // The page's own server by default; `?ws=URL` names another. A `?token=` of the page goes along
  // (the server also sets it as a same-origin cookie, which the WebSocket upgrade carries).
  const params = new URLSearchParams(location.search);
  const token = params.get("token");
  const url = params.get("ws") ??
    `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/${token ? `?token=${encodeURIComponent(token)}` : ""}`;
  const ws = new WebSocket(url, ["foxglove.websocket.v1"]);
  ws.binaryType = "arraybuffer";
  let subs = new Map();
  let received = 0;
  status(`connecting to ${url}…`, "connecting");
  ws.onopen = () => status(`connected to ${url}`, "connected");
  ws.onmessage = (event) => {
    if (typeof event.data === "string") {
      const m = JSON.parse(event.data);
      if (m.op === "serverInfo") $("server").textContent = `server "${m.name}"`;
      else if (m.op === "advertise") subs = advertised(m.channels, ws);
      else if (m.op === "status") $("problem").textContent = `server: ${m.message}`;
      return;
    }
    const frame = parseMessageData(event.data);
    const sub = frame && subs.get(frame.subscriptionId);
    if (!sub) return;
    try {
      HANDLERS[sub.key](decode(sub.schema, frame.payload));
      ++received;
      status(`connected to ${url} · ${received} messages`, "connected");
    } catch (e) {
      // Shown, not only logged: a decoder out of step with a message definition must be seen.
      $("problem").textContent = `${TOPICS[sub.key].topic}: ${e.message}`;
      console.error(e);
    }
  };
  ws.onclose = () => {
    status(`disconnected from ${url}; retrying in 2 s`, "disconnected");
    setTimeout(connect, 2000);
  };
}

$("map-topic").onchange = drawMap;
$("map-layer").onchange = drawMap;
function frame() {
  if (sinkage.dirty) {
    sinkage.dirty = false;
    drawSinkage();
  }
  requestAnimationFrame(frame);
}
requestAnimationFrame(frame);
connect();
