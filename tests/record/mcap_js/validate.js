#!/usr/bin/env node
// Independent check of an MCAP file written by regolith's C++ McapWriter, with the TypeScript
// reader of the MCAP authors (@mcap/core, pinned by package-lock.json; zstd via fzstd).
//
//   node validate.js FILE.mcap EXPECTED.json
//
// EXPECTED.json: {"complete": true|false, "topics": {"/topic": message_count, ...},
//                 "attachments": ["name", ...]   (complete files only, optional)}
// complete: the file is read twice, with McapIndexedReader (footer, summary, chunk indexes,
//   summary CRC) and with McapStreamReader (every record in order, chunk CRCs); both must find
//   exactly the expected topics and per-topic message counts, and the stream must end in a valid
//   footer.
// truncated (complete: false): McapIndexedReader must refuse the file (it needs the footer: this is
//   @mcap/core's documented behaviour, asserted so a change is noticed); McapStreamReader must read
//   every complete record, i.e. the expected counts (those of the complete chunks), and then wait
//   for more data (done() is false), without an error.
// Exits 0 when everything matches; otherwise prints what differs and exits 1.
"use strict";
const fs = require("fs");
const { McapIndexedReader, McapStreamReader } = require("@mcap/core");
const fzstd = require("fzstd");

const decompressHandlers = {
  zstd: (buffer, decompressedSize) => {
    const out = fzstd.decompress(buffer, new Uint8Array(Number(decompressedSize)));
    if (BigInt(out.byteLength) !== decompressedSize) {
      throw new Error(`zstd chunk decompressed to ${out.byteLength} bytes, expected ${decompressedSize}`);
    }
    return out;
  },
};

function compareCounts(what, got, expected, errors) {
  const keys = new Set([...Object.keys(got), ...Object.keys(expected)]);
  for (const k of [...keys].sort()) {
    if ((got[k] ?? -1) !== (expected[k] ?? -1)) {
      errors.push(`${what}: topic ${k}: ${got[k] ?? "absent"} messages, expected ${expected[k] ?? "absent"}`);
    }
  }
}

async function indexed(bytes, expected, errors) {
  const readable = {
    size: async () => BigInt(bytes.byteLength),
    read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
  };
  let reader;
  try {
    reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  } catch (e) {
    if (!expected.complete) return; // a truncated file has no footer: refused, as expected
    errors.push(`McapIndexedReader: ${e.message}`);
    return;
  }
  if (!expected.complete) {
    errors.push("McapIndexedReader opened a truncated file (expected it to need the footer)");
    return;
  }
  const counts = {};
  for (const ch of reader.channelsById.values()) counts[ch.topic] = 0;
  for await (const m of reader.readMessages({ validateCrcs: true })) {
    const ch = reader.channelsById.get(m.channelId);
    counts[ch.topic] = (counts[ch.topic] ?? 0) + 1;
  }
  compareCounts("McapIndexedReader", counts, expected.topics, errors);
  if (reader.header.profile !== "ros2") errors.push(`McapIndexedReader: profile '${reader.header.profile}'`);
  const stats = reader.statistics;
  if (!stats) {
    errors.push("McapIndexedReader: no Statistics record");
  } else {
    const total = Object.values(expected.topics).reduce((a, b) => a + b, 0);
    if (stats.messageCount !== BigInt(total)) {
      errors.push(`McapIndexedReader: Statistics.messageCount ${stats.messageCount}, expected ${total}`);
    }
  }
  if (expected.attachments) {
    const names = [];
    for await (const a of reader.readAttachments({ validateCrcs: true })) names.push(a.name);
    if (JSON.stringify(names) !== JSON.stringify(expected.attachments)) {
      errors.push(`McapIndexedReader: attachments ${JSON.stringify(names)}, expected ${JSON.stringify(expected.attachments)}`);
    }
  }
}

function stream(bytes, expected, errors) {
  const reader = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  const channels = new Map();
  const counts = {};
  try {
    // Fed in pieces, as a recording arrives over a pipe.
    for (let off = 0; off < bytes.byteLength; off += 65536) {
      reader.append(bytes.subarray(off, Math.min(off + 65536, bytes.byteLength)));
      for (let r; (r = reader.nextRecord()); ) {
        if (r.type === "Channel") {
          channels.set(r.id, r);
          counts[r.topic] = counts[r.topic] ?? 0;
        } else if (r.type === "Message") {
          const ch = channels.get(r.channelId);
          if (!ch) throw new Error(`message on unknown channel ${r.channelId}`);
          counts[ch.topic] += 1;
        }
      }
    }
  } catch (e) {
    errors.push(`McapStreamReader: ${e.message}`);
    return;
  }
  compareCounts("McapStreamReader", counts, expected.topics, errors);
  if (expected.complete && !reader.done()) errors.push("McapStreamReader: did not reach a valid footer");
  if (!expected.complete && reader.done()) errors.push("McapStreamReader: a truncated file ended in a valid footer");
}

async function main() {
  if (process.argv.length !== 4) {
    console.error("usage: node validate.js FILE.mcap EXPECTED.json");
    process.exit(2);
  }
  const [file, expectedFile] = process.argv.slice(2);
  const bytes = new Uint8Array(fs.readFileSync(file));
  const expected = JSON.parse(fs.readFileSync(expectedFile, "utf8"));
  const errors = [];
  await indexed(bytes, expected, errors);
  stream(bytes, expected, errors);
  if (errors.length > 0) {
    for (const e of errors) console.error(`${file}: ${e}`);
    process.exit(1);
  }
  const total = Object.values(expected.topics).reduce((a, b) => a + b, 0);
  console.log(`${file}: ok (${expected.complete ? "indexed + stream" : "stream, truncated"}: ` +
    `${Object.keys(expected.topics).length} topics, ${total} messages)`);
}

main().catch((e) => {
  console.error(`${process.argv[2]}: ${e.stack ?? e}`);
  process.exit(1);
});
