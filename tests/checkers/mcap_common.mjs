// Shared by mcap_dump.mjs and mcap_write.mjs: chunk (de)compression and the JSON line format, so the
// writer's "what I meant" JSON and the reader's dump are byte-for-byte comparable.
import zstd from "@foxglove/wasm-zstd";
import lz4Decompress from "@foxglove/wasm-lz4";
import lz4js from "lz4js";

// The wasm modules load asynchronously; every call before this resolves throws.
async function wasmReady() {
  await zstd.isLoaded;
  await lz4Decompress.isLoaded;
}

// @mcap/core passes the chunk's declared uncompressed size; a codec that yields fewer bytes means a
// corrupt chunk or a wrong uncompressed_size field, which the library itself would not notice.
export async function decompressHandlers() {
  await wasmReady();
  const exact = (name, decode) => (data, size) => {
    const out = decode(data, Number(size));
    if (out.byteLength !== Number(size)) {
      throw new Error(`${name} chunk decompressed to ${out.byteLength} bytes, header says ${size}`);
    }
    return out;
  };
  return {
    zstd: exact("zstd", (d, n) => zstd.decompress(d, n)),
    lz4: exact("lz4", (d, n) => lz4Decompress(d, n)),
  };
}

// A McapWriter compressChunk callback, or undefined for uncompressed chunks. @foxglove/wasm-lz4 can
// only decompress, so LZ4 frames are made with the pure-JS lz4js (standard LZ4 frame format).
export async function chunkCompressor(name) {
  await wasmReady();
  switch (name) {
    case "none":
      return undefined;
    case "zstd":
      return (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) });
    case "lz4":
      return (data) => ({ compression: "lz4", compressedData: lz4js.compress(data) });
    default:
      throw new Error(`unknown compression ${name} (want zstd, lz4 or none)`);
  }
}

// JSON-safe copy of a decoded message. JSON has no int64, NaN, infinities or negative zero, so:
// bigint -> decimal string; NaN/Infinity/-Infinity/-0 -> the strings "NaN", "Infinity",
// "-Infinity", "-0" (all of which strtod parses back exactly); typed arrays -> plain arrays
// (Float32Array elements widen to double exactly). Finite numbers stay numbers: JSON.stringify
// prints the shortest text that round-trips to the same double.
export function toJson(value) {
  if (typeof value === "bigint") return value.toString();
  if (typeof value === "number") {
    if (Number.isNaN(value)) return "NaN";
    if (value === Infinity) return "Infinity";
    if (value === -Infinity) return "-Infinity";
    if (Object.is(value, -0)) return "-0";
    return value;
  }
  if (ArrayBuffer.isView(value)) return Array.from(value, toJson);
  if (Array.isArray(value)) return value.map(toJson);
  if (value instanceof Map) {
    return Object.fromEntries([...value].map(([k, v]) => [String(k), toJson(v)]));
  }
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, toJson(v)]));
  }
  return value; // string, boolean, null
}

// First output line: file header, channels (sorted by id) and the Statistics record if any.
export function headerLine(header, channelsById, schemasById, statistics) {
  const channels = [...channelsById.values()]
    .sort((a, b) => a.id - b.id)
    .map((c) => {
      const schema = schemasById.get(c.schemaId);
      return {
        id: c.id,
        topic: c.topic,
        message_encoding: c.messageEncoding,
        metadata: Object.fromEntries(c.metadata),
        schema_name: schema?.name ?? null,
        schema_encoding: schema?.encoding ?? null,
      };
    });
  // Statistics under the MCAP spec's field names (the library uses camelCase).
  const stats = statistics
    ? toJson({
        message_count: statistics.messageCount,
        schema_count: statistics.schemaCount,
        channel_count: statistics.channelCount,
        attachment_count: statistics.attachmentCount,
        metadata_count: statistics.metadataCount,
        chunk_count: statistics.chunkCount,
        message_start_time: statistics.messageStartTime,
        message_end_time: statistics.messageEndTime,
        channel_message_counts: statistics.channelMessageCounts,
      })
    : null;
  return JSON.stringify({
    header: { profile: header.profile, library: header.library },
    channels,
    statistics: stats,
  });
}

// One output line per message. `message` is the decoded object, or null when the channel is not
// ros2msg/cdr (then the raw payload is given as base64 instead).
export function messageLine(topic, schemaName, record, message, rawData) {
  const line = {
    topic,
    schema: schemaName,
    log_time: record.logTime.toString(),
    publish_time: record.publishTime.toString(),
    sequence: record.sequence,
    message: message == null ? null : toJson(message),
  };
  if (message == null) line.data_base64 = Buffer.from(rawData).toString("base64");
  return JSON.stringify(line);
}
