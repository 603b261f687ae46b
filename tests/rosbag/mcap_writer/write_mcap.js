#!/usr/bin/env node
// Writes the MCAP files of fleetmap's MCAP reader tests (tests/rosbag/mcap_reader_test.cc,
// tests/stereo/mcap_import_test.cc) with writers that are not fleetmap's: @mcap/core's McapWriter
// (the MCAP container, summary and indexes included) and @foxglove/cdr's CdrWriter (ROS 2's CDR
// serialisation), chunks compressed by lz4js (LZ4 frames) and @foxglove/wasm-zstd (libzstd in
// WebAssembly). So fleetmap's reader, written from the specification, is checked against
// independent implementations of it.
//
//   node write_mcap.js EUROC_DIR OUT_DIR
//
// writes into OUT_DIR:
//   euroc-none.mcap, euroc-lz4.mcap, euroc-zstd.mcap  the same content in three compressions:
//     6 stereo pairs of real EuRoC frames (sensor_msgs/msg/Image, mono8, 752x480, decoded from
//     EUROC_DIR/cam0/data/*.png and cam1 with pngjs; the left image of pair 1 with rows padded by
//     4 bytes of 0xEE), one sensor_msgs/msg/CompressedImage (the PNG file of the first left frame
//     as it is), 2 CameraInfo per camera (a rectified pair 0.11 m apart), 50 Imu and 5 NavSatFix
//     messages, in chunks of about 256 KiB;
//   euroc-compressed.mcap  the same content, zstd, but the right camera's images as
//     sensor_msgs/msg/CompressedImage on /stereo/right/image_raw/compressed (image_transport's
//     compressed topic): each the PNG file of the frame as it is, format "png" and, every other
//     frame, "mono8; png compressed mono8" as image_transport writes it; and no other
//     CompressedImage (the import takes the file's one Image and one CompressedImage topic as its
//     cameras);
//   small-none.mcap, small-lz4.mcap, small-zstd.mcap  a few small messages (one 8x6 stereo pair,
//     a CameraInfo per camera with binning and a region of interest, 2 Imu, 1 NavSatFix, 1
//     CompressedImage) in chunks of about 1 KiB,
//     their schemas without the types they use: the files the tests flip and cut byte by byte;
//   small-big-endian.mcap  the small content in big-endian CDR, uncompressed;
//   sizes-none.mcap, sizes-lz4.mcap, sizes-zstd.mcap (zstd level 1), sizes-zstd19.mcap (level 19)
//     chunks of sizes at and around multiples of the readers' decompression buffers (64 KiB,
//     and zstd's 128 KiB ZSTD_DStreamOutSize()): one message a chunk, each a
//     sensor_msgs/msg/CompressedImage of format "bytes" on /sizes, padded so that its chunk's
//     records take exactly the bytes kSizedChunks says (text of words, which both codecs
//     compress), and in the compressed files also chunks whose compressed records take exactly
//     the bytes kSizedCompressedChunks says (random bytes, which neither compresses); the first
//     chunk, which also holds the schema and the channel, is small. level 19 only on the chunks
//     up to 128 KiB (it compresses at a few hundred KiB a second);
//   written.json  every value written, file by file and message by message in file order (times
//     as decimal strings of nanoseconds; image pixels as the PNG they came from, or as numbers for
//     the synthetic ones; the sized files' data as its length and FNV-1a 32 hash, and their
//     chunks' uncompressed and compressed sizes), for the tests to compare what fleetmap reads
//     with.
//
// Every value is chosen deterministically (no randomness, no clock): two runs write the same
// files.
"use strict";

const fs = require("fs");
const path = require("path");
const { McapWriter } = require("@mcap/core");
const { CdrWriter, EncapsulationKind } = require("@foxglove/cdr");
const lz4js = require("lz4js");
const zstd = require("@foxglove/wasm-zstd");
const { PNG } = require("pngjs");

// 2024-05-01T08:30:00Z.
const kStartSec = 1714552200;

// ros2msg schemas: each type's .msg, then the types it uses, as rosbag2 writes them.
const kTime = "int32 sec\nuint32 nanosec\n";
const kHeader = "builtin_interfaces/Time stamp\nstring frame_id\n";
function Dependencies(...types) {
  const msgs = {
    "std_msgs/Header": kHeader,
    "builtin_interfaces/Time": kTime,
    "sensor_msgs/RegionOfInterest":
      "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n",
    "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "sensor_msgs/NavSatStatus":
      "int8 STATUS_NO_FIX = -1\nint8 STATUS_FIX = 0\nint8 STATUS_SBAS_FIX = 1\n" +
      "int8 STATUS_GBAS_FIX = 2\nint8 status\nuint16 SERVICE_GPS = 1\nuint16 service\n",
  };
  return types
    .map((t) => "=".repeat(80) + "\nMSG: " + t + "\n" + msgs[t])
    .join("");
}
const kSchemas = {
  "sensor_msgs/msg/Image":
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n" +
    "uint8 is_bigendian\nuint32 step\nuint8[] data\n" +
    Dependencies("std_msgs/Header", "builtin_interfaces/Time"),
  "sensor_msgs/msg/CompressedImage":
    "std_msgs/Header header\nstring format\nuint8[] data\n" +
    Dependencies("std_msgs/Header", "builtin_interfaces/Time"),
  "sensor_msgs/msg/CameraInfo":
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n" +
    "float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\n" +
    "uint32 binning_y\nRegionOfInterest roi\n" +
    Dependencies("std_msgs/Header", "builtin_interfaces/Time", "sensor_msgs/RegionOfInterest"),
  "sensor_msgs/msg/Imu":
    "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n" +
    "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n" +
    "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n" +
    "float64[9] linear_acceleration_covariance\n" +
    Dependencies(
      "std_msgs/Header",
      "builtin_interfaces/Time",
      "geometry_msgs/Quaternion",
      "geometry_msgs/Vector3",
    ),
  "sensor_msgs/msg/NavSatFix":
    "std_msgs/Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\n" +
    "float64 altitude\nfloat64[9] position_covariance\nuint8 position_covariance_type\n" +
    Dependencies("std_msgs/Header", "builtin_interfaces/Time", "sensor_msgs/NavSatStatus"),
};

function StampOf(ns) {
  return { sec: Number(ns / 1000000000n), nanosec: Number(ns % 1000000000n) };
}

function WriteHeader(w, header) {
  w.int32(header.sec);
  w.uint32(header.nanosec);
  w.string(header.frame_id);
}

// CDR of each type, field by field as its .msg declares them.
const kSerialise = {
  "sensor_msgs/msg/Image": (w, m, bytes) => {
    WriteHeader(w, m.header);
    w.uint32(m.height).uint32(m.width).string(m.encoding).uint8(m.is_bigendian).uint32(m.step);
    w.uint8Array(bytes, true);
  },
  "sensor_msgs/msg/CompressedImage": (w, m, bytes) => {
    WriteHeader(w, m.header);
    w.string(m.format);
    w.uint8Array(bytes, true);
  },
  "sensor_msgs/msg/CameraInfo": (w, m) => {
    WriteHeader(w, m.header);
    w.uint32(m.height).uint32(m.width).string(m.distortion_model);
    w.float64Array(m.d, true);
    w.float64Array(m.k, false).float64Array(m.r, false).float64Array(m.p, false);
    w.uint32(m.binning_x).uint32(m.binning_y);
    w.uint32(m.roi.x_offset).uint32(m.roi.y_offset).uint32(m.roi.height).uint32(m.roi.width);
    w.uint8(m.roi.do_rectify ? 1 : 0);
  },
  "sensor_msgs/msg/Imu": (w, m) => {
    WriteHeader(w, m.header);
    w.float64Array(m.orientation, false).float64Array(m.orientation_covariance, false);
    w.float64Array(m.angular_velocity, false).float64Array(m.angular_velocity_covariance, false);
    w.float64Array(m.linear_acceleration, false);
    w.float64Array(m.linear_acceleration_covariance, false);
  },
  "sensor_msgs/msg/NavSatFix": (w, m) => {
    WriteHeader(w, m.header);
    w.int8(m.status.status).uint16(m.status.service);
    w.float64(m.latitude).float64(m.longitude).float64(m.altitude);
    w.float64Array(m.position_covariance, false).uint8(m.position_covariance_type);
  },
};

// A mono8 image's rows `step` bytes apart, padding 0xEE.
function Mono8Rows(pixels, width, height, step) {
  const out = new Uint8Array(step * height).fill(0xee);
  for (let r = 0; r < height; ++r) out.set(pixels.subarray(r * width, (r + 1) * width), r * step);
  return out;
}

function ReadMono8Png(file) {
  const png = PNG.sync.read(fs.readFileSync(file));
  const pixels = new Uint8Array(png.width * png.height);
  for (let i = 0; i < pixels.length; ++i) pixels[i] = png.data[4 * i];  // RGBA, grey in R
  return { width: png.width, height: png.height, pixels };
}

// `unusual`: binning and a region of interest (which the import does not keep: a calibration
// is stored only without them), to check that the decoder reads every field.
function CameraInfo(stampNs, right, width, height, unusual) {
  const f = 0.61 * width, cx = width / 2 - 0.5, cy = height / 2 + 0.25, baseline = 0.11;
  return {
    header: { ...StampOf(stampNs), frame_id: right ? "right_camera" : "left_camera" },
    height, width,
    distortion_model: "plumb_bob",
    d: [-0.28, 0.07, 0.0002, 0.00002, 0.0],
    k: [f, 0, cx, 0, f * 1.001, cy, 0, 0, 1],
    r: [1, 0, 0, 0, 1, 0, 0, 0, 1],
    p: [f, 0, cx, right ? -f * baseline : 0, 0, f, cy, 0, 0, 0, 1, 0],
    binning_x: unusual && right ? 2 : 0, binning_y: unusual ? 1 : 0,
    roi: unusual
      ? { x_offset: 3, y_offset: 5, height: height - 10, width: width - 6, do_rectify: right }
      : { x_offset: 0, y_offset: 0, height: 0, width: 0, do_rectify: false },
  };
}

function Imu(stampNs, i) {
  return {
    header: { ...StampOf(stampNs), frame_id: "imu_link" },
    orientation: [0.01 * i, -0.02, 0.03 + i / 7, 0.999],
    orientation_covariance: [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 2e-4 * (i + 1)],
    angular_velocity: [0.1 + 0.001 * i, -0.2, Math.sin(i) / 3],
    angular_velocity_covariance: [-1, 0, 0, 0, 0, 0, 0, 0, 0],
    linear_acceleration: [0.5, -0.25 * i, 9.81 + Math.cos(i) / 100],
    linear_acceleration_covariance: [0.01, 0.001, 0, 0.001, 0.01, 0, 0, 0, 0.02],
  };
}

function NavSatFix(stampNs, i) {
  return {
    header: { ...StampOf(stampNs), frame_id: "gps" },
    status: { status: (i % 4) - 1, service: 1 + (i % 2) * 8 },
    latitude: 51.759 + 1e-6 * i + 1 / 3e7,
    longitude: -1.258 - 1e-6 * i,
    altitude: 70.5 + i / 3,
    position_covariance: [0.25, 0, 0, 0, 0.25, 0, 0, 0, 1.0 + i],
    position_covariance_type: 2,
  };
}

// The messages of a file, in log-time order: {topic, type, logTime, message, bytes, record}
// (`bytes`: an image's data; `record`: what written.json says of it).
// `rightCompressed`: the right camera's images as CompressedImage PNG files (euroc-compressed).
function EurocMessages(eurocDir, rightCompressed) {
  const frames = (camera) =>
    fs
      .readdirSync(path.join(eurocDir, camera, "data"))
      .filter((f) => f.endsWith(".png"))
      .sort()
      .map((f) => path.join(eurocDir, camera, "data", f));
  const left = frames("cam0"), right = frames("cam1");
  const messages = [];
  const start = BigInt(kStartSec) * 1000000000n;
  for (let i = 0; i < 6; ++i) {
    for (const [side, files, lag] of [["left", left, 0n], ["right", right, 200000n]]) {
      const file = files[i * 5];
      if (side === "right" && rightCompressed) {
        const stamp = start + BigInt(i) * 100000000n + lag;
        const m = {
          header: { ...StampOf(stamp), frame_id: side + "_camera" },
          format: i % 2 ? "mono8; png compressed mono8" : "png",
        };
        messages.push({
          topic: `/stereo/${side}/image_raw/compressed`, type: "sensor_msgs/msg/CompressedImage",
          stamp, message: m, bytes: fs.readFileSync(file), record: { ...m, png: file },
        });
        continue;
      }
      const image = ReadMono8Png(file);
      const pad = side === "left" && i === 1 ? 4 : 0;
      const stamp = start + BigInt(i) * 100000000n + lag;
      const m = {
        header: { ...StampOf(stamp), frame_id: side + "_camera" },
        height: image.height, width: image.width, encoding: "mono8", is_bigendian: 0,
        step: image.width + pad,
      };
      messages.push({
        topic: `/stereo/${side}/image_raw`, type: "sensor_msgs/msg/Image", stamp, message: m,
        bytes: Mono8Rows(image.pixels, image.width, image.height, m.step),
        record: { ...m, png: file, pad },
      });
    }
  }
  if (!rightCompressed) {
    const png = fs.readFileSync(left[0]);
    const compressed = { header: { ...StampOf(start + 50000000n), frame_id: "left_camera" }, format: "png" };
    messages.push({
      topic: "/stereo/left/image_raw/compressed", type: "sensor_msgs/msg/CompressedImage",
      stamp: start + 50000000n, message: compressed, bytes: png,
      record: { ...compressed, png: left[0] },
    });
  }
  const size = ReadMono8Png(left[0]);
  for (let i = 0; i < 2; ++i) {
    for (const side of ["left", "right"]) {
      const stamp = start + BigInt(i) * 500000000n;
      const m = CameraInfo(stamp, side === "right", size.width, size.height, false);
      messages.push({ topic: `/stereo/${side}/camera_info`, type: "sensor_msgs/msg/CameraInfo", stamp, message: m, record: m });
    }
  }
  for (let i = 0; i < 50; ++i) {
    const stamp = start + BigInt(i) * 10000000n + 123n;
    const m = Imu(stamp, i);
    messages.push({ topic: "/imu/data", type: "sensor_msgs/msg/Imu", stamp, message: m, record: m });
  }
  for (let i = 0; i < 5; ++i) {
    const stamp = start + BigInt(i) * 100000000n + 7n;
    const m = NavSatFix(stamp, i);
    messages.push({ topic: "/gps/fix", type: "sensor_msgs/msg/NavSatFix", stamp, message: m, record: m });
  }
  return messages;
}

function SmallMessages() {
  const start = BigInt(kStartSec) * 1000000000n;
  const messages = [];
  const width = 8, height = 6;
  for (const [side, lag, seed] of [["left", 0n, 11], ["right", 200000n, 29]]) {
    const pixels = new Uint8Array(width * height);
    for (let i = 0; i < pixels.length; ++i) pixels[i] = (i * 37 + seed) & 0xff;
    const stamp = start + lag;
    const m = {
      header: { ...StampOf(stamp), frame_id: side + "_camera" },
      height, width, encoding: "mono8", is_bigendian: 0, step: width,
    };
    messages.push({
      topic: `/stereo/${side}/image_raw`, type: "sensor_msgs/msg/Image", stamp, message: m,
      bytes: pixels, record: { ...m, pixels: Array.from(pixels), pad: 0 },
    });
    const info = CameraInfo(start, side === "right", width, height, true);
    messages.push({ topic: `/stereo/${side}/camera_info`, type: "sensor_msgs/msg/CameraInfo", stamp: start, message: info, record: info });
  }
  for (let i = 0; i < 2; ++i) {
    const stamp = start + BigInt(i) * 10000000n + 123n;
    const m = Imu(stamp, i);
    messages.push({ topic: "/imu/data", type: "sensor_msgs/msg/Imu", stamp, message: m, record: m });
  }
  const fix = NavSatFix(start + 7n, 1);
  messages.push({ topic: "/gps/fix", type: "sensor_msgs/msg/NavSatFix", stamp: start + 7n, message: fix, record: fix });
  const jpegish = Uint8Array.from([0xff, 0xd8, 0xff, 0xe0, 0, 0x10, 0x4a, 0x46, 0x49, 0x46, 0, 0xff, 0xd9]);
  const compressed = { header: { ...StampOf(start + 50000000n), frame_id: "left_camera" }, format: "jpeg" };
  messages.push({
    topic: "/stereo/left/image_raw/compressed", type: "sensor_msgs/msg/CompressedImage",
    stamp: start + 50000000n, message: compressed, bytes: jpegish,
    record: { ...compressed, bytes: Array.from(jpegish) },
  });
  return messages;
}

// An in-memory IWritable for McapWriter.
class BufferWritable {
  constructor() {
    this.parts = [];
    this.size = 0n;
  }
  position() {
    return this.size;
  }
  async write(buffer) {
    this.parts.push(Buffer.from(buffer));
    this.size += BigInt(buffer.byteLength);
  }
}

const kCompressors = {
  none: undefined,
  lz4: (data) => ({ compression: "lz4", compressedData: Uint8Array.from(lz4js.compress(data)) }),
  zstd: (data) => ({ compression: "zstd", compressedData: zstd.compress(data, 3) }),
};

// Writes `messages` (in log-time order; log time 1 ms after the stamp, publish time the stamp)
// into `file`; returns what written.json says of it.
// `fullSchemas`: each schema with the types it uses, as rosbag2 writes them; else only the
// type's own fields (the small files, which the tests flip byte by byte, stay small).
async function WriteMcap(file, messages, compression, chunkSize, kind, fullSchemas) {
  const writable = new BufferWritable();
  const writer = new McapWriter({ writable, chunkSize, compressChunk: kCompressors[compression] });
  await writer.start({ profile: "ros2", library: "fleetmap tests/rosbag/mcap_writer" });
  const schemaIds = {}, channelIds = {};
  const sorted = [...messages].sort((a, b) => (a.stamp < b.stamp ? -1 : a.stamp > b.stamp ? 1 : 0));
  const written = [];
  let sequence = 0;
  for (const m of sorted) {
    if (schemaIds[m.type] === undefined) {
      const text = fullSchemas ? kSchemas[m.type] : kSchemas[m.type].split("=".repeat(80))[0];
      schemaIds[m.type] = await writer.registerSchema({
        name: m.type, encoding: "ros2msg", data: new TextEncoder().encode(text),
      });
    }
    if (channelIds[m.topic] === undefined) {
      channelIds[m.topic] = await writer.registerChannel({
        topic: m.topic, messageEncoding: "cdr", schemaId: schemaIds[m.type],
        metadata: new Map([["offered_qos_profiles", ""]]),
      });
    }
    const w = new CdrWriter({ kind });
    kSerialise[m.type](w, m.message, m.bytes);
    const logTime = m.stamp + 1000000n;
    await writer.addMessage({
      channelId: channelIds[m.topic], sequence: ++sequence, logTime, publishTime: m.stamp,
      data: w.data,
    });
    written.push({
      topic: m.topic, type: m.type, sequence, log_time: logTime.toString(),
      publish_time: m.stamp.toString(), bytes: w.data.byteLength, message: m.record,
    });
  }
  await writer.end();
  fs.writeFileSync(file, Buffer.concat(writable.parts));
  return { compression, messages: written };
}

// The uncompressed sizes of the sized files' chunks (after the first), and the compressed sizes
// of further chunks of the compressed ones.
const kSizedChunks = [
  65535, 65536, 65537, 131071, 131072, 131073, 196608, 262144, 393216, 1048576, 4194304,
];
const kSizedCompressedChunks = [65535, 65536, 65537, 131072, 262144];

// Deterministic bytes: xorshift32 from `seed`. `text`: words of a fixed list (compressible);
// else the generator's bytes (incompressible).
function PatternBytes(n, seed, text) {
  const out = new Uint8Array(n);
  let s = seed >>> 0 || 1;
  const next = () => {
    s ^= s << 13;
    s ^= s >>> 17;
    s ^= s << 5;
    return s >>> 0;
  };
  if (!text) {
    for (let i = 0; i < n; ++i) out[i] = next() >>> 24;
    return out;
  }
  const words = [];
  for (let w = 0; w < 256; ++w) {
    let t = "";
    for (let k = 0; k < 3 + (w % 7); ++k) t += String.fromCharCode(97 + ((w * 7 + k * 13) % 26));
    words.push(t + " ");
  }
  for (let i = 0; i < n; ) {
    const word = words[next() >>> 24];
    for (let k = 0; k < word.length && i < n; ++k) out[i++] = word.charCodeAt(k);
  }
  return out;
}

function Fnv1a32(bytes) {
  let h = 0x811c9dc5;
  for (let i = 0; i < bytes.length; ++i) h = Math.imul(h ^ bytes[i], 0x01000193) >>> 0;
  return h.toString(16).padStart(8, "0");
}

// A Message record (MCAP opcode 0x05) as McapWriter's ChunkBuilder lays it out in a chunk.
const kMessageRecordOverhead = 1 + 8 + 2 + 4 + 8 + 8;
function MessageRecord(channelId, sequence, logTime, publishTime, data) {
  const out = new Uint8Array(kMessageRecordOverhead + data.length);
  const view = new DataView(out.buffer);
  out[0] = 0x05;
  view.setBigUint64(1, BigInt(out.length - 9), true);
  view.setUint16(9, channelId, true);
  view.setUint32(11, sequence, true);
  view.setBigUint64(15, logTime, true);
  view.setBigUint64(23, publishTime, true);
  out.set(data, kMessageRecordOverhead);
  return out;
}

// Writes the sized file `name` compressed by `compress` (undefined: none) into `outDir`: each
// chunk one message (McapWriter closes a chunk once it holds more than chunkSize bytes: 0). Checks
// every chunk's size is the one asked for; returns what written.json says of the file.
async function WriteSizedMcap(outDir, name, compression, compress, uncompressedSizes,
                              compressedSizes) {
  const chunks = [];
  const writable = new BufferWritable();
  const writer = new McapWriter({
    writable, chunkSize: 0,
    compressChunk: compress && ((data) => {
      const compressedData = compress(data);
      chunks.push({ uncompressed_size: data.length, compressed_size: compressedData.length });
      return { compression, compressedData };
    }),
  });
  await writer.start({ profile: "ros2", library: "fleetmap tests/rosbag/mcap_writer" });
  const type = "sensor_msgs/msg/CompressedImage";
  const schemaId = await writer.registerSchema({
    name: type, encoding: "ros2msg", data: new TextEncoder().encode(kSchemas[type]),
  });
  const channelId = await writer.registerChannel({
    topic: "/sizes", messageEncoding: "cdr", schemaId,
    metadata: new Map([["offered_qos_profiles", ""]]),
  });
  const start = BigInt(kStartSec) * 1000000000n;
  const cdr = (sequence, bytes) => {
    const w = new CdrWriter({ kind: EncapsulationKind.CDR_LE });
    kSerialise[type](w, {
      header: { ...StampOf(start + BigInt(sequence) * 1000000n), frame_id: "sizes" },
      format: "bytes",
    }, bytes);
    return w.data;
  };
  const cdrOverhead = cdr(0, new Uint8Array(0)).length;
  // [payload, expected chunk size, which size] of each message.
  const plan = [[PatternBytes(16, 1, true), null, null]];
  for (const n of uncompressedSizes) {
    const payload = PatternBytes(n - kMessageRecordOverhead - cdrOverhead, n, true);
    plan.push([payload, n, "uncompressed_size"]);
  }
  for (const n of compress ? compressedSizes : []) {
    // Random bytes compress to themselves and a few bytes of framing: find the payload whose
    // record compresses to exactly n bytes.
    const sequence = plan.length + 1;
    const logTime = start + BigInt(sequence) * 1000000n + 1000000n;
    const all = PatternBytes(n + 1024, n, false);
    let p = n - kMessageRecordOverhead - cdrOverhead;
    for (let tries = 0; ; ++tries) {
      const record = MessageRecord(channelId, sequence, logTime, logTime - 1000000n,
                                   cdr(sequence, all.subarray(0, p)));
      const got = compress(record).length;
      if (got === n) break;
      if (tries === 20) throw new Error(`${name}: no payload compresses to ${n} bytes`);
      p += n - got;
    }
    plan.push([all.slice(0, p), n, "compressed_size"]);
  }
  const messages = [];
  for (const [bytes] of plan) {
    const sequence = messages.length + 1;
    const publishTime = start + BigInt(sequence) * 1000000n;
    const logTime = publishTime + 1000000n;
    const data = cdr(sequence, bytes);
    await writer.addMessage({ channelId, sequence, logTime, publishTime, data });
    if (!compress) chunks.push({ uncompressed_size: data.length + kMessageRecordOverhead });
    messages.push({
      topic: "/sizes", type, sequence, log_time: logTime.toString(),
      publish_time: publishTime.toString(), bytes: data.length,
      message: { data_size: bytes.length, data_fnv1a32: Fnv1a32(bytes) },
    });
  }
  await writer.end();
  if (!compress) chunks[0].uncompressed_size = null;  // the first chunk also holds the schema
  plan.forEach(([, n, which], i) => {
    if (n !== null && chunks[i][which] !== n) {
      throw new Error(`${name}: chunk ${i} has ${which} ${chunks[i][which]}, not ${n}`);
    }
  });
  fs.writeFileSync(path.join(outDir, name), Buffer.concat(writable.parts));
  return { compression, chunks, messages };
}

async function Main() {
  const [eurocDir, outDir] = process.argv.slice(2);
  if (!eurocDir || !outDir) {
    console.error("usage: node write_mcap.js EUROC_DIR OUT_DIR");
    process.exit(2);
  }
  await zstd.isLoaded;
  fs.mkdirSync(outDir, { recursive: true });
  const euroc = EurocMessages(eurocDir, false), small = SmallMessages();
  const files = {};
  for (const compression of ["none", "lz4", "zstd"]) {
    files[`euroc-${compression}.mcap`] = await WriteMcap(
      path.join(outDir, `euroc-${compression}.mcap`), euroc, compression, 256 * 1024,
      EncapsulationKind.CDR_LE, true);
    files[`small-${compression}.mcap`] = await WriteMcap(
      path.join(outDir, `small-${compression}.mcap`), small, compression, 1024,
      EncapsulationKind.CDR_LE, false);
  }
  files["euroc-compressed.mcap"] = await WriteMcap(
    path.join(outDir, "euroc-compressed.mcap"), EurocMessages(eurocDir, true), "zstd", 256 * 1024,
    EncapsulationKind.CDR_LE, true);
  files["small-big-endian.mcap"] = await WriteMcap(
    path.join(outDir, "small-big-endian.mcap"), small, "none", 1024, EncapsulationKind.CDR_BE,
    false);
  const sized = [
    ["sizes-none.mcap", "none", undefined, kSizedChunks],
    ["sizes-lz4.mcap", "lz4", (data) => Uint8Array.from(lz4js.compress(data)), kSizedChunks],
    ["sizes-zstd.mcap", "zstd", (data) => zstd.compress(data, 1), kSizedChunks],
    ["sizes-zstd19.mcap", "zstd", (data) => zstd.compress(data, 19),
     kSizedChunks.filter((n) => n <= 131072)],
  ];
  for (const [name, compression, compress, sizes] of sized) {
    files[name] = await WriteSizedMcap(outDir, name, compression, compress, sizes,
                                       kSizedCompressedChunks);
  }
  fs.writeFileSync(path.join(outDir, "written.json"), JSON.stringify({ files }, null, 1));
}

Main().catch((e) => {
  console.error(e.stack || String(e));
  process.exit(1);
});
