#!/usr/bin/env node
// Test-only checker: decodes an MCAP (rosbag2) file with @mcap/core + @foxglove/rosmsg2-serialization
// and prints it as JSON lines, so C++ tests can check files our code writes against an independent
// reader. Usage: node mcap_dump.mjs FILE.mcap [--stream]
//   line 1:  {"header":{profile,library},"channels":[...],"statistics":{...}|null}
//   then one {"topic","schema","log_time","publish_time","sequence","message"} per message, in
//   log_time order (ties in file order) whichever reader is used, so the two modes compare equal.
// Fails (exit 1, reason on stderr) on anything malformed: bad magic, CRCs, codecs, CDR payloads.
import { readFile } from "node:fs/promises";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { crc32 } from "@foxglove/crc";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { decompressHandlers, headerLine, messageLine } from "./mcap_common.mjs";

const args = process.argv.slice(2);
const forceStream = args.includes("--stream");
const files = args.filter((a) => !a.startsWith("--"));
if (files.length !== 1) {
  console.error("usage: node mcap_dump.mjs FILE.mcap [--stream]");
  process.exit(2);
}

// The footer is fixed-size: opcode, length, summary_start, summary_offset_start, summary_crc, magic.
const FOOTER_AND_MAGIC = 1 + 8 + 8 + 8 + 4 + 8;

// Neither @mcap/core reader checks DataEnd's data_section_crc (CRC-32 of every byte before DataEnd,
// magic included), so check it here; 0 means "not computed".
function checkDataSectionCrc(bytes, dataEndOffset, expected) {
  if (!expected) return;
  const actual = crc32(bytes.subarray(0, dataEndOffset));
  if (actual !== expected) {
    throw new Error(`data section CRC ${actual} does not match DataEnd's ${expected}`);
  }
}

// Indexed read: the summary gives schemas/channels/statistics, messages come through the chunk and
// message indexes (the library checks the summary CRC and each chunk's CRC).
async function readIndexed(bytes, handlers) {
  const readable = {
    size: async () => BigInt(bytes.byteLength),
    read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers: handlers });
  checkDataSectionCrc(bytes, Number(reader.dataEndOffset), reader.dataSectionCrc);
  const messages = [];
  for await (const m of reader.readMessages({ validateCrcs: true })) messages.push(m);
  return {
    header: reader.header,
    channels: reader.channelsById,
    schemas: reader.schemasById,
    statistics: reader.statistics,
    messages,
    // readMessages only walks chunk indexes: messages outside chunks would silently vanish.
    unindexedMessages: reader.chunkIndexes.length === 0,
  };
}

// Streaming read: every record in file order (chunks decompressed and CRC-checked by the library).
// The reader is given the whole file, so bytesRemaining() tells where each record starts, which is
// what the DataEnd and summary CRCs need.
function readStream(bytes, handlers) {
  const reader = new McapStreamReader({ decompressHandlers: handlers, validateCrcs: true });
  reader.append(bytes);
  const out = { channels: new Map(), schemas: new Map(), messages: [], statistics: undefined };
  let dataEnd; // [start, end) of the DataEnd record
  let footer;
  for (;;) {
    const start = bytes.byteLength - reader.bytesRemaining();
    const record = reader.nextRecord();
    if (!record) break;
    switch (record.type) {
      case "Header": out.header = record; break;
      case "Schema": out.schemas.set(record.id, record); break;
      case "Channel": out.channels.set(record.id, record); break;
      case "Message": out.messages.push(record); break;
      case "Statistics": out.statistics = record; break;
      case "DataEnd":
        dataEnd = [start, bytes.byteLength - reader.bytesRemaining(), record.dataSectionCrc];
        break;
      case "Footer": footer = record; break;
    }
  }
  if (!reader.done()) throw new Error("file ends before the Footer and closing magic (truncated?)");
  if (!dataEnd) throw new Error("no DataEnd record");
  checkDataSectionCrc(bytes, dataEnd[0], dataEnd[2]);
  if (footer.summaryCrc !== 0) {
    // Summary CRC: everything after DataEnd up to and including the footer's summary_offset_start.
    const actual = crc32(bytes.subarray(dataEnd[1], bytes.byteLength - FOOTER_AND_MAGIC + 1 + 8 + 8 + 8));
    if (actual !== footer.summaryCrc) {
      throw new Error(`summary CRC ${actual} does not match the footer's ${footer.summaryCrc}`);
    }
  }
  // Log-time order, ties in file order (Array.prototype.sort is stable), as the indexed reader.
  out.messages.sort((a, b) => (a.logTime < b.logTime ? -1 : a.logTime > b.logTime ? 1 : 0));
  return out;
}

// One MessageReader per schema, built from the ros2msg text (root type plus "MSG:" dependencies).
// rosbag2 (Iron+) stores service events under a "pkg/srv/Name_Event" schema whose text is the .srv
// file (request --- response), not the _Event message that was serialized; those are not decoded
// (printed with "message": null and the raw bytes), like any non-ros2msg/cdr channel.
function makeDecoder(channel, schemas, cache) {
  const schema = schemas.get(channel.schemaId);
  if (channel.messageEncoding !== "cdr" || schema?.encoding !== "ros2msg") return undefined;
  if (/\/srv\/[^/]+_Event$/.test(schema.name)) return undefined;
  if (!cache.has(schema.id)) {
    const text = new TextDecoder("utf-8", { fatal: true }).decode(schema.data);
    cache.set(schema.id, new MessageReader(parse(text, { ros2: true })));
  }
  return cache.get(schema.id);
}

async function main() {
  const bytes = new Uint8Array(await readFile(files[0]));
  const handlers = await decompressHandlers();
  let data;
  if (!forceStream) {
    try {
      data = await readIndexed(bytes, handlers);
    } catch (err) {
      // Only an unindexed file may fall back; any other indexed-read failure is a real error.
      if (!/File is not indexed/.test(err.message)) throw err;
    }
    if (data?.unindexedMessages) data = undefined;
  }
  data ??= readStream(bytes, handlers);

  const { header, channels, schemas, statistics, messages } = data;
  if (!header) throw new Error("no Header record");
  if (statistics && statistics.messageCount !== BigInt(messages.length)) {
    throw new Error(`read ${messages.length} messages, Statistics says ${statistics.messageCount}`);
  }

  const lines = [headerLine(header, channels, schemas, statistics)];
  const decoders = new Map();
  for (const record of messages) {
    const channel = channels.get(record.channelId);
    if (!channel) throw new Error(`message on unknown channel ${record.channelId}`);
    const schema = schemas.get(channel.schemaId);
    const decoder = makeDecoder(channel, schemas, decoders);
    let message = null;
    if (decoder) {
      try {
        message = decoder.readMessage(record.data);
      } catch (err) {
        throw new Error(`${channel.topic} @ ${record.logTime}: CDR decode failed: ${err.message}`);
      }
      // CDR tolerates trailing bytes, but more than alignment padding (< 4) means the payload is
      // not of this schema (or the schema text is wrong).
      const extra = record.data.byteLength - decoder.lastReadByteLength();
      if (extra > 3) {
        throw new Error(`${channel.topic} @ ${record.logTime}: ${extra} bytes left after decoding`);
      }
    }
    lines.push(messageLine(channel.topic, schema?.name ?? null, record, message, record.data));
  }
  process.stdout.write(lines.join("\n") + "\n");
}

main().catch((err) => {
  console.error(`mcap_dump: ${files[0]}: ${err.message}`);
  process.exit(1);
});
