#!/usr/bin/env node
// Independent Foxglove WebSocket client for tests/live: Foxglove's own client (@foxglove/ws-protocol
// FoxgloveClient over the `ws` WebSocket; Node 20 has no global WebSocket), the channel's ros2msg
// schema parsed by @foxglove/rosmsg and each message's CDR bytes decoded by
// @foxglove/rosmsg2-serialization's MessageReader; none of it written here (versions pinned by
// package-lock.json).
//
//   node client.js ws://127.0.0.1:8765 /rover1/joint_states COUNT
//   node client.js ws://127.0.0.1:8765 '*' COUNT     (every channel, until the server closes)
//
// Prints JSON lines: {"serverInfo": ...}, {"channels": [{id, topic, encoding, schemaName,
// schemaEncoding}]} (every advertised channel), then COUNT lines {"topic", "timestamp" (ns as a
// string), "message"} and exits 0. Typed arrays become arrays, NaN becomes null. Exits 1 with the
// error on stderr when the topic is not advertised, a message does not decode, or after 30 s.
"use strict";
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");
const WebSocket = require("ws");

function replacer(_key, value) {
  if (typeof value === "bigint") return value.toString();
  if (ArrayBuffer.isView(value)) return Array.from(value);
  return value;
}

function fail(message) {
  process.stderr.write(`client.js: ${message}\n`);
  process.exit(1);
}

const [url, topic, countText] = process.argv.slice(2);
const count = Number(countText ?? "1");
const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
const timer = setTimeout(() => fail(`timeout: fewer than ${count} messages of ${topic}`), topic === "*" ? 120000 : 30000);
// topic "*": every advertised channel, at most COUNT messages each, printed until the server
// closes the connection (then exit 0): {"subscribed": N} once subscribed, then message lines.
const all = topic === "*";
const readers = new Map(); // channel id -> {topic, reader, received}
let reader = undefined;
let received = 0;

client.on("error", (e) => fail(`websocket error: ${e.message ?? e}`));
client.on("close", () => {
  if (!all) return;
  clearTimeout(timer);
  process.exit(0);
});
client.on("serverInfo", (info) => process.stdout.write(JSON.stringify({ serverInfo: info }) + "\n"));
client.on("status", (s) => process.stdout.write(JSON.stringify({ status: s }) + "\n"));
client.on("advertise", (channels) => {
  process.stdout.write(JSON.stringify({ channels: channels.map((c) => ({ id: c.id, topic: c.topic,
    encoding: c.encoding, schemaName: c.schemaName, schemaEncoding: c.schemaEncoding })) }) + "\n");
  if (all) {
    for (const c of channels) {
      if (c.encoding !== "cdr" || c.schemaEncoding !== "ros2msg") {
        fail(`${c.topic}: encoding ${c.encoding}, schema encoding ${c.schemaEncoding}`);
      }
      const id = client.subscribe(c.id);
      readers.set(id, { topic: c.topic, reader: new MessageReader(parse(c.schema, { ros2: true })), received: 0 });
    }
    process.stdout.write(JSON.stringify({ subscribed: channels.length }) + "\n");
    return;
  }
  const ch = channels.find((c) => c.topic === topic);
  if (ch == undefined) fail(`topic ${topic} not advertised`);
  if (ch.encoding !== "cdr" || ch.schemaEncoding !== "ros2msg") {
    fail(`${topic}: encoding ${ch.encoding}, schema encoding ${ch.schemaEncoding}`);
  }
  reader = new MessageReader(parse(ch.schema, { ros2: true }));
  client.subscribe(ch.id);
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  if (all) {
    const r = readers.get(subscriptionId);
    if (r === undefined || r.received >= count) return;
    let message;
    try {
      message = r.reader.readMessage(bytes);
    } catch (e) {
      fail(`${r.topic} message ${r.received}: ${e.message}`);
    }
    ++r.received;
    process.stdout.write(JSON.stringify({ topic: r.topic, timestamp, message }, replacer) + "\n");
    return;
  }
  if (received >= count) return;
  let message;
  try {
    message = reader.readMessage(bytes);
  } catch (e) {
    fail(`${topic} message ${received}: ${e.message}`);
  }
  process.stdout.write(JSON.stringify({ topic, timestamp, message }, replacer) + "\n");
  if (++received === count) {
    clearTimeout(timer);
    client.close();
    process.exit(0);
  }
});
