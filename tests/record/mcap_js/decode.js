#!/usr/bin/env node
// Independent decoder of a regolith recording (`regolith record`): the MCAP file is read with the
// MCAP authors' @mcap/core (McapIndexedReader: footer, summary and chunk CRCs), each channel's
// ros2msg schema is parsed by Foxglove's @foxglove/rosmsg (parse(..., {ros2: true})) and every
// message is decoded from its CDR bytes by @foxglove/rosmsg2-serialization's MessageReader, none
// of which was written here (versions pinned by package-lock.json).
//
//   node decode.js FILE.mcap
//
// Prints one JSON line per channel first: {"channel": topic, "schema": name, "schema_encoding",
// "message_encoding"}, then one per message in log-time order: {"topic", "sequence", "log_time",
// "publish_time" (ns as strings), "message": the decoded message}. Typed arrays become arrays,
// NaN becomes null. Exits 1 with the error on stderr when any message does not decode.
"use strict";
const fs = require("fs");
const { McapIndexedReader } = require("@mcap/core");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");
const fzstd = require("fzstd");

const decompressHandlers = {
  zstd: (buffer, decompressedSize) => fzstd.decompress(buffer, new Uint8Array(Number(decompressedSize))),
};

function replacer(_key, value) {
  if (typeof value === "bigint") return value.toString();
  if (ArrayBuffer.isView(value)) return Array.from(value);
  return value;
}

async function main() {
  const bytes = fs.readFileSync(process.argv[2]);
  const readable = {
    size: async () => BigInt(bytes.byteLength),
    read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const readers = new Map();
  const out = [];
  for (const ch of reader.channelsById.values()) {
    const schema = reader.schemasById.get(ch.schemaId);
    if (schema == undefined) throw new Error(`channel ${ch.topic}: no schema ${ch.schemaId}`);
    out.push(JSON.stringify({ channel: ch.topic, schema: schema.name, schema_encoding: schema.encoding,
                              message_encoding: ch.messageEncoding }));
    if (schema.encoding !== "ros2msg" || ch.messageEncoding !== "cdr") {
      throw new Error(`channel ${ch.topic}: schema encoding ${schema.encoding}, message encoding ${ch.messageEncoding}`);
    }
    const text = new TextDecoder().decode(schema.data);
    readers.set(ch.id, new MessageReader(parse(text, { ros2: true })));
  }
  for await (const m of reader.readMessages()) {
    const ch = reader.channelsById.get(m.channelId);
    let message;
    try {
      message = readers.get(m.channelId).readMessage(m.data);
    } catch (e) {
      throw new Error(`${ch.topic} sequence ${m.sequence}: ${e.message}`);
    }
    out.push(JSON.stringify({ topic: ch.topic, sequence: m.sequence, log_time: m.logTime,
                              publish_time: m.publishTime, message }, replacer));
  }
  process.stdout.write(out.join("\n") + "\n");
}

main().catch((e) => {
  process.stderr.write(`decode.js: ${e.stack || e.message}\n`);
  process.exit(1);
});
