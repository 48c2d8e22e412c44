#!/usr/bin/env node
// Independent Foxglove WebSocket client for tests/live: Foxglove's own client (@foxglove/ws-protocol
// FoxgloveClient over the `ws` WebSocket; Node 20 has no global WebSocket), the channel's ros2msg
// schema parsed by @foxglove/rosmsg and each message's CDR bytes decoded by
// @foxglove/rosmsg2-serialization's MessageReader; none of it written here (versions pinned by
// package-lock.json).
//
//   node client.js ws://127.0.0.1:8765 /rover1/joint_states COUNT
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
const timer = setTimeout(() => fail(`timeout: fewer than ${count} messages of ${topic}`), 30000);
let reader = undefined;
let received = 0;

client.on("error", (e) => fail(`websocket error: ${e.message ?? e}`));
client.on("serverInfo", (info) => process.stdout.write(JSON.stringify({ serverInfo: info }) + "\n"));
client.on("status", (s) => process.stdout.write(JSON.stringify({ status: s }) + "\n"));
client.on("advertise", (channels) => {
  process.stdout.write(JSON.stringify({ channels: channels.map((c) => ({ id: c.id, topic: c.topic,
    encoding: c.encoding, schemaName: c.schemaName, schemaEncoding: c.schemaEncoding })) }) + "\n");
  const ch = channels.find((c) => c.topic === topic);
  if (ch == undefined) fail(`topic ${topic} not advertised`);
  if (ch.encoding !== "cdr" || ch.schemaEncoding !== "ros2msg") {
    fail(`${topic}: encoding ${ch.encoding}, schema encoding ${ch.schemaEncoding}`);
  }
  reader = new MessageReader(parse(ch.schema, { ros2: true }));
  client.subscribe(ch.id);
});
client.on("message", ({ timestamp, data }) => {
  if (received >= count) return;
  let message;
  try {
    message = reader.readMessage(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
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
