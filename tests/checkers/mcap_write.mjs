#!/usr/bin/env node
// Test-only checker: writes a small ROS 2 (rosbag2-style) MCAP file with @mcap/core's McapWriter and
// @foxglove/rosmsg2-serialization's MessageWriter, so C++ tests can check that our reader decodes a
// file made by an independent writer. Usage:
//   node mcap_write.mjs OUT.mcap [--compression zstd|lz4|none]   (default zstd)
// Prints to stdout exactly what was written, in mcap_dump.mjs's JSON-lines format, so
// `node mcap_dump.mjs OUT.mcap` must print the same bytes, and a C++ decode can be compared with it.
import { writeFile } from "node:fs/promises";
import { McapWriter, LIBRARY_IDENTIFIER } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader, MessageWriter } from "@foxglove/rosmsg2-serialization";
import { chunkCompressor, headerLine, messageLine } from "./mcap_common.mjs";

// ROS 2 Humble definitions, fields only (comments dropped), written as the .msg files spell them:
// types from the same package are relative ("Pose pose"), others are "pkg/Type".
const DEFS = {
  "builtin_interfaces/Time": "int32 sec\nuint32 nanosec\n",
  "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
  "std_msgs/String": "string data\n",
  "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z\n",
  "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
  "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
  "geometry_msgs/Pose": "Point position\nQuaternion orientation\n",
  "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance\n",
  "geometry_msgs/PoseWithCovarianceStamped": "std_msgs/Header header\nPoseWithCovariance pose\n",
  "geometry_msgs/Twist": "Vector3 linear\nVector3 angular\n",
  "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance\n",
  "geometry_msgs/Transform": "Vector3 translation\nQuaternion rotation\n",
  "geometry_msgs/TransformStamped":
    "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
  "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
  "nav_msgs/Odometry":
    "std_msgs/Header header\nstring child_frame_id\n" +
    "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
  "sensor_msgs/LaserScan":
    "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n" +
    "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n" +
    "float32[] ranges\nfloat32[] intensities\n",
};
const PRIMITIVES = new Set(
  "bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64 string wstring".split(" "),
);

// Full schema text as rosbag2 stores it: the root definition, then every dependency once (in order
// of first use) after a line of 80 '=' and a "MSG: pkg/Type" line.
function schemaText(root) {
  const seen = [];
  const visit = (type) => {
    const pkg = type.split("/")[0];
    for (const line of DEFS[type].split("\n")) {
      const fieldType = line.split(" ")[0].replace(/\[.*\]$/, "").replace(/<=\d+$/, "");
      if (!fieldType || PRIMITIVES.has(fieldType)) continue;
      const dep = fieldType.includes("/") ? fieldType : `${pkg}/${fieldType}`;
      if (!DEFS[dep]) throw new Error(`no definition for ${dep}`);
      if (!seen.includes(dep)) {
        seen.push(dep);
        visit(dep);
      }
    }
  };
  visit(root);
  return DEFS[root] + seen.map((d) => `\n${"=".repeat(80)}\nMSG: ${d}\n${DEFS[d]}`).join("");
}

// Humble's rosbag2 stores each publisher's QoS as YAML in the channel metadata.
const qos = (durability) =>
  "- history: 3\n  depth: 0\n  reliability: 1\n" +
  `  durability: ${durability}\n` +
  "  deadline:\n    sec: 2147483647\n    nsec: 4294967295\n" +
  "  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n" +
  "  liveliness: 1\n  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n" +
  "  avoid_ros_namespace_conventions: false";

const TOPICS = [
  { topic: "/scan", type: "sensor_msgs/LaserScan" },
  { topic: "/odom", type: "nav_msgs/Odometry" },
  { topic: "/tf", type: "tf2_msgs/TFMessage" },
  { topic: "/amcl_pose", type: "geometry_msgs/PoseWithCovarianceStamped" },
  { topic: "/chatter", type: "std_msgs/String" },
];

// --- deterministic message contents -------------------------------------------------------------
const T0 = 1_700_000_000n * 1_000_000_000n; // ns
const stampOf = (ns) => ({ sec: Number(ns / 1_000_000_000n), nanosec: Number(ns % 1_000_000_000n) });
const header = (ns, frame_id) => ({ stamp: stampOf(ns), frame_id });
const f32 = Math.fround; // float32 fields must hold values float32 can represent exactly
const yawQuat = (yaw) => ({ x: 0, y: 0, z: Math.sin(yaw / 2), w: Math.cos(yaw / 2) });
// 6x6 row-major covariance: a distinct full-precision double in every slot.
const covariance = (seed) => Array.from({ length: 36 }, (_, k) =>
  k % 7 === 0 ? 0.01 * (seed + 1) + k / 3 : Math.sin(seed + k) * 1e-6);

function laserScan(i, ns) {
  const n = 90 + i; // a different length each message
  const ranges = new Float32Array(n);
  for (let k = 0; k < n; k++) ranges[k] = 0.5 + 0.01 * k + 0.1 * i;
  ranges[5] = Infinity; // no return
  ranges[11 + i] = NaN; // invalid reading
  ranges[n - 1] = -Infinity; // closer than range_min (REP 117)
  // Even messages carry intensities (one of them a negative zero), odd ones an empty array.
  const intensities = i % 2 === 0 ? Float32Array.from({ length: n }, (_, k) => (k * 37) % 101) : new Float32Array(0);
  if (i === 2) intensities[0] = -0;
  return {
    header: header(ns, "base_scan"),
    angle_min: f32(-Math.PI / 2),
    angle_max: f32(Math.PI / 2),
    angle_increment: f32(Math.PI / (n - 1)),
    time_increment: f32(1 / (5 * 360)),
    scan_time: f32(0.2),
    range_min: f32(0.12),
    range_max: f32(3.5),
    ranges,
    intensities,
  };
}

const odometry = (i, ns) => ({
  header: header(ns, "odom"),
  child_frame_id: "base_footprint",
  pose: {
    pose: {
      position: { x: Math.cos(i * 0.3), y: 0.5 * Math.sin(i * 0.3), z: 0 },
      orientation: yawQuat(i * 0.3 + Math.PI / 2),
    },
    covariance: covariance(i),
  },
  twist: {
    twist: { linear: { x: 0.2, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.1 * i } },
    covariance: covariance(100 + i),
  },
});

const transform = (ns, parent, child, x, y, yaw) => ({
  header: header(ns, parent),
  child_frame_id: child,
  transform: { translation: { x, y, z: 0 }, rotation: yawQuat(yaw) },
});
const tfMessage = (i, ns) => ({
  transforms: [
    transform(ns, "map", "odom", 0.01 * i, -0.02 * i, 0.001 * i),
    transform(ns, "odom", "base_footprint", Math.cos(i * 0.3), 0.5 * Math.sin(i * 0.3), i * 0.3),
  ],
});

const amclPose = (i, ns) => ({
  header: header(ns, "map"),
  pose: { pose: { position: { x: 1 + i / 3, y: -2 + i / 7, z: 0 }, orientation: yawQuat(-i / 5) }, covariance: covariance(50 + i) },
});

// ASCII only: @foxglove/cdr's CdrWriter sizes strings by UTF-16 length, so non-ASCII text would be
// written truncated (the self-check below would catch it).
const CHATTER = ["hello locsim", "", "tab\tquote\" backslash\\ end"];

// [topic, count, period ns, builder]; log_time = stamp + a small receive delay, so log_time and
// publish_time (= stamp) differ and a reader that swaps them is caught.
const SERIES = [
  ["/scan", 5, 200_000_000n, laserScan],
  ["/odom", 8, 125_000_000n, odometry],
  ["/tf", 4, 250_000_000n, tfMessage],
  ["/amcl_pose", 3, 333_333_333n, amclPose],
  ["/chatter", CHATTER.length, 300_000_000n, (i) => ({ data: CHATTER[i] })],
];

// --- writing --------------------------------------------------------------------------------------
async function main() {
  const args = process.argv.slice(2);
  const out = args.find((a, i) => !a.startsWith("--") && args[i - 1] !== "--compression");
  const ci = args.indexOf("--compression");
  const compression = ci >= 0 ? args[ci + 1] : "zstd";
  if (!out) throw new Error("usage: node mcap_write.mjs OUT.mcap [--compression zstd|lz4|none]");

  // In-memory IWritable; McapWriter reuses its buffer after write(), so copy.
  const parts = [];
  let size = 0n;
  const writable = {
    write: async (buf) => { parts.push(Uint8Array.from(buf)); size += BigInt(buf.byteLength); },
    position: () => size,
  };
  // A small chunk size so the file has several chunks (and message indexes per chunk).
  const writer = new McapWriter({ writable, chunkSize: 2048, compressChunk: await chunkCompressor(compression) });
  const fileHeader = { profile: "ros2", library: `${LIBRARY_IDENTIFIER} (locsim tests/checkers)` };
  await writer.start(fileHeader);

  const schemas = new Map();
  const channels = new Map();
  const byTopic = new Map();
  for (const { topic, type } of TOPICS) {
    const [pkg, name] = type.split("/");
    const schema = { name: `${pkg}/msg/${name}`, encoding: "ros2msg", data: new TextEncoder().encode(schemaText(type)) };
    const schemaId = await writer.registerSchema(schema);
    schemas.set(schemaId, { id: schemaId, ...schema });
    const definitions = parse(schemaText(type), { ros2: true });
    const metadata = new Map([["offered_qos_profiles", qos(topic === "/tf" ? 2 : 1)]]);
    const channel = { topic, messageEncoding: "cdr", schemaId, metadata };
    const id = await writer.registerChannel(channel);
    channels.set(id, { id, ...channel });
    byTopic.set(topic, { id, schema: schema.name, encoder: new MessageWriter(definitions), decoder: new MessageReader(definitions), seq: 0 });
  }

  // All messages, written in log_time order (unique times), so every reader order agrees.
  const messages = SERIES.flatMap(([topic, count, period, build], s) =>
    Array.from({ length: count }, (_, i) => {
      const stamp = T0 + BigInt(i) * period + BigInt(s) * 1_000_000n;
      return { topic, publishTime: stamp, logTime: stamp + 2_500_000n + BigInt(i) * 1_000n, msg: build(i, stamp) };
    }),
  ).sort((a, b) => (a.logTime < b.logTime ? -1 : a.logTime > b.logTime ? 1 : 0));

  const lines = [];
  for (const { topic, publishTime, logTime, msg } of messages) {
    const ch = byTopic.get(topic);
    const data = ch.encoder.writeMessage(msg);
    // Self-check: the bytes must decode to exactly the object meant (catches fields left to
    // defaults, float32 values that would round, bad strings). Same library, so this checks the
    // input here, not the library.
    const record = { channelId: ch.id, sequence: ++ch.seq, publishTime, logTime, data };
    const meant = messageLine(topic, ch.schema, record, msg);
    if (messageLine(topic, ch.schema, record, ch.decoder.readMessage(data)) !== meant) {
      throw new Error(`${topic} @ ${logTime}: message does not round-trip:\n${meant}`);
    }
    await writer.addMessage(record);
    lines.push(meant);
  }
  await writer.end();

  await writeFile(out, Buffer.concat(parts));
  lines.unshift(headerLine(fileHeader, channels, schemas, writer.statistics));
  process.stdout.write(lines.join("\n") + "\n");
}

main().catch((err) => {
  console.error(`mcap_write: ${err.message}`);
  process.exit(1);
});
