// Reads an MCAP export of a ground-station session (teamscan export SESSION --format mcap) with the MCAP
// project's TypeScript indexed reader (@mcap/core), CRCs validated, and decodes every message with
// Foxglove's ROS 2 CDR decoder from the file's own schemas. Checks, against the session folder read here
// independently: one /robotN/scan per accepted scans.bin record, one /robotN/odom per accepted poses.csv
// line, one /robotN/status per status.csv line; the frame tree (every frame one parent, `map` the root);
// a seek into the middle of the file; and the size against the session's raw files.
// Usage: node read_mcap.cjs SESSION_DIR FILE.mcap [--laser-frames N] [--max-size-ratio R]
"use strict";
const fs = require("fs");
const path = require("path");
const { McapIndexedReader } = require("@mcap/core");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");

const failures = [];
function check(ok, what) {
  if (!ok) failures.push(what);
}

// scans.bin: 16-byte header ("TSSCANS1", u32 version, u32 header bytes), then records
// (u32 magic "TCSR", u32 body bytes, body, u32 crc); accepted = the body's `rejected` field is 0.
function sessionScans(dir) {
  const file = path.join(dir, "scans.bin");
  if (!fs.existsSync(file)) return new Map();
  const b = fs.readFileSync(file);
  if (b.toString("latin1", 0, 8) !== "TSSCANS1") throw new Error(`${file}: no teamscan header`);
  const version = b.readUInt32LE(8);
  const rejectedAt = version === 1 ? 46 : 62;
  const perRobot = new Map();
  const first = new Map();  // robot -> the first accepted record's points [x_mm, y_mm, z_mm, beam, flags]
  const pointsAt = version === 1 ? 48 : 64;
  let pos = b.readUInt32LE(12);
  while (pos + 8 <= b.length) {
    if (b.readUInt32LE(pos) !== 0x52534354) throw new Error(`${file}: no record magic at ${pos}`);
    const body = b.readUInt32LE(pos + 4);
    if (pos + 12 + body > b.length) break;  // a torn tail
    const robot = b.readUInt32LE(pos + 8 + 16);
    if (b.readUInt16LE(pos + 8 + rejectedAt) === 0) {
      perRobot.set(robot, (perRobot.get(robot) ?? 0) + 1);
      if (!first.has(robot)) {
        const count = b.readUInt16LE(pos + 8 + rejectedAt - 2), points = [];
        for (let i = 0, p = pos + 8 + pointsAt; i < count; ++i, p += 16) {
          points.push([b.readInt32LE(p), b.readInt32LE(p + 4), b.readInt32LE(p + 8), b.readUInt16LE(p + 12), b.readUInt16LE(p + 14)]);
        }
        first.set(robot, points);
      }
    }
    pos += 12 + body;
  }
  perRobot.first = first;
  return perRobot;
}

// poses.csv / status.csv: one line per sample after the header; robot_id is column 3; poses.csv's
// last column `rejected` marks a refused one.
function sessionCsv(dir, name, acceptedOnly) {
  const file = path.join(dir, name);
  const perRobot = new Map();
  if (!fs.existsSync(file)) return perRobot;
  const lines = fs.readFileSync(file, "utf8").split("\n").filter((l) => l.length > 0);
  const header = lines.shift().split(",");
  const rejectedColumn = header.indexOf("rejected");
  for (const line of lines) {
    const cols = line.split(",");
    if (acceptedOnly && rejectedColumn >= 0 && Number(cols[rejectedColumn]) !== 0) continue;
    const robot = Number(cols[2]);
    perRobot.set(robot, (perRobot.get(robot) ?? 0) + 1);
  }
  return perRobot;
}

async function fileReadable(file) {
  const handle = await fs.promises.open(file, "r");
  const size = BigInt((await handle.stat()).size);
  return {
    handle,
    size: async () => size,
    read: async (offset, length) => {
      const buf = Buffer.alloc(Number(length));
      await handle.read(buf, 0, Number(length), Number(offset));
      return new Uint8Array(buf.buffer, buf.byteOffset, buf.length);
    },
  };
}

async function main() {
  const args = process.argv.slice(2);
  const [sessionDir, mcapFile] = args;
  const option = (name, dflt) => (args.indexOf(name) >= 0 ? Number(args[args.indexOf(name) + 1]) : dflt);
  const laserFrames = option("--laser-frames", -1);
  const maxSizeRatio = option("--max-size-ratio", 0.2);

  const readable = await fileReadable(mcapFile);
  const reader = await McapIndexedReader.Initialize({ readable });
  check(reader.header.profile === "ros2", `profile ${reader.header.profile}`);
  check(reader.chunkIndexes.length > 0, "no chunk indexes");
  check(reader.statistics !== undefined, "no statistics");

  const decoders = new Map();
  for (const [id, channel] of reader.channelsById) {
    const schema = reader.schemasById.get(channel.schemaId);
    check(schema.encoding === "ros2msg" && channel.messageEncoding === "cdr", `${channel.topic}: encodings`);
    const definition = parse(new TextDecoder().decode(schema.data), { ros2: true });
    decoders.set(id, { topic: channel.topic, schema: schema.name, reader: new MessageReader(definition) });
  }

  const firstClouds = new Map();  // topic -> the first decoded cloud
  const counts = new Map();
  const parents = new Map();  // child frame -> set of parents
  let lastLogTime = -1n, unordered = 0, trailing = 0, badClouds = 0, firstTime, lastTime;
  for await (const m of reader.readMessages({ validateCrcs: true })) {
    const d = decoders.get(m.channelId);
    const msg = d.reader.readMessage(m.data);
    if (d.reader.lastReadHadTrailingBytes()) ++trailing;
    counts.set(d.topic, (counts.get(d.topic) ?? 0) + 1);
    if (m.logTime < lastLogTime) ++unordered;
    lastLogTime = m.logTime;
    firstTime ??= m.logTime;
    lastTime = m.logTime;
    if (d.schema === "sensor_msgs/msg/PointCloud2" && msg.data.length !== msg.width * msg.height * msg.point_step) ++badClouds;
    if (d.schema === "sensor_msgs/msg/PointCloud2" && !firstClouds.has(d.topic)) firstClouds.set(d.topic, msg);
    if (d.schema === "tf2_msgs/msg/TFMessage") {
      for (const t of msg.transforms) {
        if (!parents.has(t.child_frame_id)) parents.set(t.child_frame_id, new Set());
        parents.get(t.child_frame_id).add(t.header.frame_id);
      }
    }
  }
  check(unordered === 0, `${unordered} messages out of log-time order`);
  check(trailing === 0, `${trailing} messages longer than their schema`);
  check(badClouds === 0, `${badClouds} clouds whose data is not width x height x point_step`);

  // Counts: equal to the session's, robot by robot.
  const expect = [
    ["scan", sessionScans(sessionDir)],
    ["odom", sessionCsv(sessionDir, "poses.csv", true)],
    ["status", sessionCsv(sessionDir, "status.csv", false)],
  ];
  let scans = 0, poses = 0;
  for (const [kind, perRobot] of expect) {
    for (const [robot, n] of perRobot) {
      const got = counts.get(`/robot${robot}/${kind}`) ?? 0;
      check(got === n, `/robot${robot}/${kind}: ${got} messages, the session has ${n}`);
      if (kind === "scan") scans += got;
      if (kind === "odom") poses += got;
    }
  }
  // Values: each robot's first cloud holds its first scans.bin record's points (mm -> m as float32, beam,
  // flags; a point without a position as NaN).
  const scanFile = expect[0][1];
  let comparedPoints = 0;
  for (const [robot, points] of scanFile.first) {
    const cloud = firstClouds.get(`/robot${robot}/scan`);
    if (!cloud) continue;
    check(cloud.header.frame_id === `robot${robot}/odom` && cloud.width === points.length,
          `/robot${robot}/scan: frame ${cloud.header.frame_id}, width ${cloud.width} (record: ${points.length} points)`);
    const view = new DataView(cloud.data.buffer, cloud.data.byteOffset, cloud.data.byteLength);
    let wrong = 0;
    points.forEach(([x, y, z, beam, flags], i) => {
      const o = i * cloud.point_step, unplaced = (flags & 0x26) !== 0;
      const same = (v, mm) => (unplaced ? Number.isNaN(v) : v === Math.fround(mm * 1e-3));
      if (!same(view.getFloat32(o, true), x) || !same(view.getFloat32(o + 4, true), y) ||
          !same(view.getFloat32(o + 8, true), z) || view.getUint16(o + 12, true) !== beam ||
          view.getUint16(o + 14, true) !== flags) ++wrong;
    });
    check(wrong === 0, `/robot${robot}/scan: ${wrong} of ${points.length} points differ from scans.bin`);
    comparedPoints += points.length;
  }

  // The data section CRC (Data End): every byte from the leading magic up to Data End.
  const whole = fs.readFileSync(mcapFile);
  if (require("zlib").crc32) {
    const crc = require("zlib").crc32(whole.subarray(0, Number(reader.dataEndOffset)));
    check(crc === reader.dataSectionCrc, `data section CRC ${reader.dataSectionCrc}, computed ${crc}`);
    console.log(`data section CRC ${crc} checked; ${comparedPoints} points of the first scans checked against scans.bin`);
  }

  // Team state: a Kalman track per robot, at most one per pose, in `map`.
  for (const [robot, n] of expect[1][1]) {
    const tracks = counts.get(`/robot${robot}/track`) ?? 0;
    check(tracks > 0 && tracks <= n, `/robot${robot}/track: ${tracks} tracks for ${n} poses`);
  }

  const statsTotal = [...reader.statistics.channelMessageCounts.values()].reduce((a, b) => a + b, 0n);
  const readTotal = [...counts.values()].reduce((a, b) => a + b, 0);
  check(statsTotal === BigInt(readTotal) && reader.statistics.messageCount === BigInt(readTotal),
        `statistics say ${reader.statistics.messageCount} messages, ${readTotal} read`);

  // Frame tree: one parent per frame, every chain ends at `map`.
  for (const [child, ps] of parents) check(ps.size === 1, `${child} has parents ${[...ps]}`);
  for (const child of parents.keys()) {
    let f = child, hops = 0;
    while (parents.has(f) && hops++ < 16) f = [...parents.get(f)][0];
    check(f === "map", `${child} does not lead to map (ends at ${f})`);
  }
  check(!parents.has("map"), "map has a parent");
  const lasers = [...parents.keys()].filter((f) => f.endsWith("/laser")).length;
  if (laserFrames >= 0) check(lasers === laserFrames, `${lasers} laser frames, expected ${laserFrames}`);

  // Seek: messages from the middle on come from the index, the first at or after the time asked.
  const middle = firstTime + (lastTime - firstTime) / 2n;
  let seeked;
  for await (const m of reader.readMessages({ startTime: middle })) {
    seeked = m.logTime;
    break;
  }
  check(seeked !== undefined && seeked >= middle, `seek to ${middle} gave ${seeked}`);

  // Size against the session's raw files (scans.bin, poses.csv, status.csv and the fused model).
  const raw = ["scans.bin", "poses.csv", "status.csv", "fused.pcd"]
    .map((f) => path.join(sessionDir, f))
    .filter((f) => fs.existsSync(f))
    .reduce((sum, f) => sum + fs.statSync(f).size, 0);
  const size = fs.statSync(mcapFile).size;
  const ratio = size / raw;
  check(Math.abs(ratio - 1) <= maxSizeRatio, `size ${size} is ${(ratio * 100).toFixed(1)} % of the raw files (${raw})`);

  await readable.handle.close();
  console.log(`read ${readTotal} messages in ${reader.chunkIndexes.length} chunks (${scans} scans, ${poses} poses, ` +
              `${parents.size} frames, ${lasers} laser); ${size} bytes = ${(ratio * 100).toFixed(1)} % of the session's ` +
              `raw files (${raw} bytes)`);
  for (const [topic, n] of [...counts].sort()) console.log(`  ${topic}: ${n}`);
  if (failures.length > 0) {
    for (const f of failures) console.error(`FAIL: ${f}`);
    process.exit(1);
  }
}

main().catch((e) => {
  console.error(`FAIL: ${e.stack ?? e}`);
  process.exit(1);
});
