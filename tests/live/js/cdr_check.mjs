#!/usr/bin/env node
// Checks the live page's CDR module (runtime/live/web/cdr.js, imported as the browser does: an ES
// module, nothing from npm) against frames written by tests/live/test_live_page.cpp: for every
// KEY.frame (a relayed Foxglove messageData frame whose payload Cyclone DDS serialized) and
// KEY.json ({schemaName, subscriptionId, message}: the sample as the runtime's dds::to_json
// renders it), the frame is parsed and decoded and every field compared exactly (float32 as
// read, NaN as JSON null, no missing or extra field).
//
//   node cdr_check.mjs path/to/cdr.js DIR COUNT
//
// Prints one line per checked message; exits 1 naming each mismatch, or when DIR holds other than
// COUNT messages.
import { readFileSync, readdirSync } from "node:fs";
import { join } from "node:path";
import { pathToFileURL } from "node:url";

const [modulePath, dir, countText] = process.argv.slice(2);
const { decode, parseMessageData } = await import(pathToFileURL(modulePath).href);

const mismatches = [];
function compare(path, got, want) {
  // uint8[] payloads (CompressedImage.data) render in to_json as {bytes: N} only
  if (ArrayBuffer.isView(got) && want !== null && typeof want === "object" && !Array.isArray(want) && "bytes" in want) {
    if (got.byteLength !== want.bytes) mismatches.push(`${path}: ${got.byteLength} bytes, expected ${want.bytes}`);
    return;
  }
  if (ArrayBuffer.isView(got)) got = Array.from(got);
  if (typeof got === "number" && Number.isNaN(got)) got = null;
  if (Array.isArray(want)) {
    if (!Array.isArray(got) || got.length !== want.length) {
      mismatches.push(`${path}: length ${Array.isArray(got) ? got.length : typeof got}, expected ${want.length}`);
      return;
    }
    want.forEach((w, i) => compare(`${path}[${i}]`, got[i], w));
  } else if (want !== null && typeof want === "object") {
    if (got === null || typeof got !== "object") {
      mismatches.push(`${path}: ${JSON.stringify(got)}, expected an object`);
      return;
    }
    const keys = new Set([...Object.keys(want), ...Object.keys(got)]);
    for (const k of keys) {
      if (!(k in got)) mismatches.push(`${path}.${k}: missing`);
      else if (!(k in want)) mismatches.push(`${path}.${k}: not in the message`);
      else compare(`${path}.${k}`, got[k], want[k]);
    }
  } else if (got !== want) {
    mismatches.push(`${path}: ${JSON.stringify(got)}, expected ${JSON.stringify(want)}`);
  }
}

const keys = readdirSync(dir).filter((f) => f.endsWith(".json")).map((f) => f.slice(0, -5)).sort();
for (const key of keys) {
  const expected = JSON.parse(readFileSync(join(dir, `${key}.json`), "utf8"));
  const bytes = readFileSync(join(dir, `${key}.frame`));
  const frame = parseMessageData(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
  if (frame === null) {
    mismatches.push(`${key}: not a messageData frame`);
    continue;
  }
  compare(`${key}.subscriptionId`, frame.subscriptionId, expected.subscriptionId);
  const before = mismatches.length;
  try {
    compare(key, decode(expected.schemaName, frame.payload), expected.message);
  } catch (e) {
    mismatches.push(`${key}: ${e.message}`);
  }
  console.log(`${key}: ${expected.schemaName}, ${frame.payload.byteLength} bytes, ` +
    `${mismatches.length === before ? "every field equal" : `${mismatches.length - before} mismatches`}`);
}
if (keys.length !== Number(countText)) mismatches.push(`${keys.length} messages in ${dir}, expected ${countText}`);
for (const m of mismatches.slice(0, 50)) console.error(`cdr_check: ${m}`);
process.exit(mismatches.length === 0 ? 0 : 1);
