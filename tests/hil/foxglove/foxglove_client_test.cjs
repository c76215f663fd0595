// The ground station's Foxglove WebSocket channels read by Foxglove's own client library
// (@foxglove/ws-protocol) and ROS 2 CDR decoder (@foxglove/rosmsg + @foxglove/rosmsg2-serialization)
// during a live `teamscan demo --view PORT --registration` (lap2, two robots; map -> robotN/odom is the
// registration's correction once it has one: the identity until then, as in the first seconds this test
// usually takes; the units test non-identity corrections). Checks: the server selects
// foxglove.websocket.v1 and sends serverInfo; every advertised channel is subscribed and delivers
// messages that decode with the advertised schema; the map cloud has x y z in frame `map`; /tf_static has
// each robot's laser mount; the frame tree of /tf with /tf_static has one parent per frame and `map` as its
// root (map -> robotN/odom -> robotN/base_link -> robotN/laser); each
// robot's base_link, composed through the tree, is within 5 cm of the station's tracked pose of the same
// snapshot (/api/state); a client publish and a parameter request are refused and counted (/api/stats);
// and at the stop, the last /map the client holds when the station closes the socket is the model the
// station wrote (session/fused_all.pcd's voxels with a point kept at release, at the map resolution).
// usage: node foxglove_client_test.cjs TEAMSCAN_BIN OUT_DIR   (NODE_PATH: this folder's node_modules)
'use strict';
const fs = require('node:fs');
const path = require('node:path');
const { FoxgloveClient } = require('@foxglove/ws-protocol');
const { parse: parseMessageDefinition } = require('@foxglove/rosmsg');
const { MessageReader } = require('@foxglove/rosmsg2-serialization');
const WebSocket = require('ws');
const { check, failed, sleep, freePort, getJson, waitFor, spawnDemo, stopDemo, waitForViewUrl } =
  require(path.join(__dirname, '..', '..', 'support', 'node', 'harness.cjs'));
const { readPcd, binModel } = require(path.join(__dirname, '..', '..', 'support', 'node', 'model_file.cjs'));

const [teamscan, outDir] = process.argv.slice(2);
const ROBOTS = [1, 2];
const POSE_TOLERANCE_M = 0.05;
const POSE_COMPARISONS = 10;  // snapshots compared per robot
const MAP_RESOLUTION_M = 0.1;  // the station's [fusion] map_resolution_m (its default, as the demo runs it)
const TEST_BUDGET_MS = 200000;

// Planar transform helpers: a tf transform as (x, y, yaw) (z and roll/pitch are 0 for these frames).
function planar(t) {
  const q = t.transform.rotation;
  return { x: t.transform.translation.x, y: t.transform.translation.y, yaw: 2 * Math.atan2(q.z, q.w) };
}
function compose(a, b) {
  const c = Math.cos(a.yaw), s = Math.sin(a.yaw);
  return { x: a.x + c * b.x - s * b.y, y: a.y + s * b.x + c * b.y, yaw: a.yaw + b.yaw };
}
const stampNs = (h) => h.stamp.sec * 1e9 + h.stamp.nanosec;

// Every frame one parent, every frame reaching `map` (no cycle, one root).
function frameTreeFault(transforms) {
  const parentOf = new Map();
  for (const t of transforms) {
    const p = t.header.frame_id, c = t.child_frame_id;
    if (!p || !c || p.startsWith('/') || c.startsWith('/') || p === c) return `bad frame ids ${p} -> ${c}`;
    if (parentOf.has(c) && parentOf.get(c) !== p) return `${c} has two parents`;
    parentOf.set(c, p);
  }
  if (parentOf.has('map')) return 'map has a parent';
  for (const start of parentOf.keys()) {
    let f = start;
    for (let steps = 0; f !== 'map'; steps++) {
      if (!parentOf.has(f)) return `${start} does not reach map`;
      if (steps > parentOf.size) return `${start} is in a cycle`;
      f = parentOf.get(f);
    }
  }
  return '';
}

async function main() {
  const port = await freePort();
  fs.rmSync(outDir, { recursive: true, force: true });
  const demo = spawnDemo(teamscan, ['demo', '--scenario', 'lap2', '--duration', '40', '--view', String(port), '--out',
    outDir, '--registration', '--quiet']);
  let client = null;
  try {
    const url = await waitForViewUrl(demo, 120000);
    const channels = new Map();       // channel id -> { channel, reader, count }
    const bySubscription = new Map(); // subscription id -> channel id
    let serverInfo = null;
    const statuses = [];
    let cloud = null;
    const tfByStamp = new Map();      // stamp ns (rounded to 1 ms) -> transforms
    let treeFault = null, treesChecked = 0;
    const tfBuffer = new Map();       // child frame -> its latest /tf transform
    let staticTransforms = [];        // /tf_static: robotN/base_link -> robotN/laser
    const decodeErrors = [];
    const attach = (fc) => {
      fc.on('serverInfo', (info) => (serverInfo = info));
      fc.on('status', (s) => statuses.push(s));
      fc.on('error', (e) => { if (fc === client) decodeErrors.push(`client error: ${e && e.message}`); });
      fc.on('advertise', (list) => {
        for (const ch of list) {
          if (channels.has(ch.id)) continue;
          let reader = null;
          try {
            if (ch.encoding === 'cdr') {
              check(ch.schemaEncoding === 'ros2msg', `${ch.topic}: cdr with a ros2msg schema (${ch.schemaName})`);
              reader = new MessageReader(parseMessageDefinition(ch.schema, { ros2: true }));
            } else {
              check(ch.encoding === 'json' && ch.schemaEncoding === 'jsonschema', `${ch.topic}: json with a jsonschema`);
              JSON.parse(ch.schema);
            }
          } catch (e) {
            decodeErrors.push(`${ch.topic}: schema: ${e.message}`);
          }
          channels.set(ch.id, { channel: ch, reader, count: 0 });
          bySubscription.set(fc.subscribe(ch.id), ch.id);
        }
      });
      fc.on('message', ({ subscriptionId, data }) => {
        const entry = channels.get(bySubscription.get(subscriptionId));
        if (!entry) return;
        const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
        let msg;
        try {
          msg = entry.reader ? entry.reader.readMessage(bytes) : JSON.parse(new TextDecoder().decode(bytes));
        } catch (e) {
          decodeErrors.push(`${entry.channel.topic}: ${e.message}`);
          return;
        }
        entry.count++;
        const topic = entry.channel.topic;
        if (topic === '/map') cloud = msg;
        if (topic === '/tf_static') staticTransforms = msg.transforms;
        if (topic === '/tf' && msg.transforms.length > 0) {
          // As a tf listener sees it: the latest transform of each child so far with /tf_static. A robot the
          // station does not track yet (or has lost) is absent from a /tf message, so the tree is judged once
          // every laser mount's base_link has appeared; a child that changes parent is a fault at once.
          for (const t of msg.transforms) {
            const before = tfBuffer.get(t.child_frame_id);
            if (before && before.header.frame_id !== t.header.frame_id && !treeFault)
              treeFault = `${t.child_frame_id} changed parent ${before.header.frame_id} -> ${t.header.frame_id}`;
            tfBuffer.set(t.child_frame_id, t);
          }
          if (staticTransforms.length > 0 && staticTransforms.every((s) => tfBuffer.has(s.header.frame_id))) {
            const fault = frameTreeFault([...tfBuffer.values()].concat(staticTransforms));
            treesChecked++;
            if (fault && !treeFault) treeFault = fault;
          }
          tfByStamp.set(Math.round(stampNs(msg.transforms[0].header) / 1e6), msg.transforms);
          if (tfByStamp.size > 200) tfByStamp.delete(tfByStamp.keys().next().value);
        }
      });
    };
    // The demo prints the URL as it starts the station: connect (a new client each try) once it listens.
    let ws = null;
    await waitFor('the station to accept a Foxglove WebSocket', 60000, () => new Promise((resolve) => {
      ws = new WebSocket(`ws://127.0.0.1:${port}/`, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
      const c = new FoxgloveClient({ ws });
      attach(c);
      c.on('open', () => { client = c; resolve(true); });
      ws.once('error', () => setTimeout(() => resolve(false), 400));
    }));

    await waitFor('serverInfo', 20000, () => serverInfo);
    check(ws.protocol === FoxgloveClient.SUPPORTED_SUBPROTOCOL, `the server selected ${ws.protocol}`);
    check(serverInfo.capabilities.length === 0, `serverInfo "${serverInfo.name}" announces no capabilities (read-only)`);

    // Every robot's channels are advertised, and every channel delivers.
    const wanted = ['/map', '/tf', '/tf_static', '/teamscan/robots'];
    for (const id of ROBOTS) wanted.push(`/robot${id}/pose`, `/robot${id}/odom`, `/robot${id}/scan`);
    await waitFor('a message on every channel', 90000, () => wanted.every((t) =>
      [...channels.values()].some((e) => e.channel.topic === t && e.count > 0)));
    check(true, `messages on all ${wanted.length} channels: ${[...channels.values()].map((e) => `${e.channel.topic} ${e.count}`).join(', ')}`);

    // The map, decoded.
    await waitFor('a map of more than 200 points', 60000, () => cloud && cloud.width > 200);
    const names = cloud.fields.map((f) => f.name).join(' ');
    check(cloud.header.frame_id === 'map' && /^x y z/.test(names), `map cloud in ${cloud.header.frame_id}, fields ${names}`);
    check(cloud.data.length === cloud.width * cloud.height * cloud.point_step,
      `map cloud: ${cloud.width} points, data ${cloud.data.length} bytes = width x point_step`);

    // Each robot's base_link through the tree against the station's tracked pose of the same snapshot.
    const compared = new Map(ROBOTS.map((id) => [id, 0]));
    let worst = 0, largestCorrection = 0;
    await waitFor('tracked poses compared', 60000, async () => {
      const st = (await getJson(`${url}api/state`)).json;
      if (!st) return false;
      const transforms = tfByStamp.get(Math.round(st.stamp_ns / 1e6));
      if (!transforms) return false;
      const byChild = new Map(transforms.map((t) => [t.child_frame_id, t]));
      for (const r of st.robots) {
        if (r.lost || !compared.has(r.id)) continue;
        const odom = byChild.get(`robot${r.id}/odom`), base = byChild.get(`robot${r.id}/base_link`);
        if (!odom || !base || odom.header.frame_id !== 'map' || base.header.frame_id !== `robot${r.id}/odom`) continue;
        const p = compose(planar(odom), planar(base));
        largestCorrection = Math.max(largestCorrection, Math.hypot(odom.transform.translation.x, odom.transform.translation.y));
        const err = Math.hypot(p.x - r.x_m, p.y - r.y_m);
        worst = Math.max(worst, err);
        compared.set(r.id, compared.get(r.id) + 1);
      }
      await sleep(150);
      return [...compared.values()].every((n) => n >= POSE_COMPARISONS);
    });
    check(worst <= POSE_TOLERANCE_M, `base_link within ${POSE_TOLERANCE_M * 100} cm of the tracked pose: worst ${(worst * 100).toFixed(2)} cm over ${[...compared.values()].join(' + ')} comparisons (largest map -> odom shift ${(largestCorrection * 100).toFixed(2)} cm)`);
    const lasers = staticTransforms.map((t) => `${t.header.frame_id} -> ${t.child_frame_id}`);
    check(ROBOTS.every((id) => lasers.includes(`robot${id}/base_link -> robot${id}/laser`)),
      `/tf_static has each robot's laser mount: ${lasers.join(', ')}`);
    check(treesChecked > 0 && !treeFault, `frame tree (one parent per frame, root map) in ${treesChecked} /tf messages with /tf_static${treeFault ? ': ' + treeFault : ''}`);

    // Read-only: a client publish and a parameter request are refused, answered and counted.
    const before = (await getJson(`${url}api/stats`)).json;
    const statusesBefore = statuses.length;
    client.getParameters([], 'p1');
    client.setParameters([{ name: '/x', value: 1 }], 'p2');
    await waitFor('the refusals', 10000, async () => {
      const s = (await getJson(`${url}api/stats`)).json;
      return s && s.foxglove_refused >= before.foxglove_refused + 2 ? s : null;
    });
    await waitFor('status messages', 5000, () => statuses.length >= statusesBefore + 2);
    check(statuses.slice(statusesBefore).every((s) => s.level === 2 && /read-only/.test(s.message)),
      `refused requests answered with error statuses: "${statuses[statusesBefore].message}"`);
    check(decodeErrors.length === 0, `no decode errors${decodeErrors.length ? ': ' + decodeErrors.slice(0, 3).join('; ') : ''}`);

    // The stop: the last /map the client holds when the station closes the socket is the model it wrote
    // (with the pose graph, the final model on its poses): one point per voxel with a point kept at release.
    const modelFile = path.join(outDir, 'session', 'fused_all.pcd');
    await waitFor('the station to write its final model', 120000, () => {
      if (fs.existsSync(modelFile)) return true;
      if (demo.exited) throw new Error('the demo exited without the station writing session/fused_all.pcd');
      return false;
    });
    await waitFor('the station to close the Foxglove socket', 60000, () => ws.readyState === WebSocket.CLOSED);
    if (!demo.exited) demo.child.kill('SIGKILL');  // its scoring is not this test's
    const resolutionM = MAP_RESOLUTION_M;
    const kept = new Set();
    for (const [key, v] of binModel(readPcd(modelFile), resolutionM)) if (!v.ghost) kept.add(key);
    const sent = new Set();
    const view = new DataView(cloud.data.buffer, cloud.data.byteOffset, cloud.data.byteLength);
    for (let i = 0; i < cloud.width; i++) {
      const o = i * cloud.point_step;
      sent.add([0, 4, 8].map((f) => Math.floor(view.getFloat32(o + f, true) / resolutionM)).join(','));
    }
    const missing = [...kept].filter((k) => !sent.has(k)), extra = [...sent].filter((k) => !kept.has(k));
    check(kept.size > 200 && missing.length === 0 && extra.length === 0 && cloud.width === sent.size,
      `the last /map is the written model: ${cloud.width} points, ${kept.size} kept voxels in fused_all.pcd, ` +
      `${missing.length} missing, ${extra.length} extra${missing.length + extra.length ? ' (' + missing.concat(extra).slice(0, 5).join(' ') + ')' : ''}`);
  } finally {
    if (client) client.close();
    await stopDemo(demo);
  }
}

const budget = setTimeout(() => {
  console.log(`FAIL the test did not finish within ${TEST_BUDGET_MS / 1000} s`);
  process.exit(1);
}, TEST_BUDGET_MS);
main().then(() => {
  clearTimeout(budget);
  console.log(failed() === 0 ? 'foxglove client test passed' : `${failed()} check(s) failed`);
  process.exit(failed() === 0 ? 0 : 1);
}, (e) => {
  clearTimeout(budget);
  console.log(`FAIL ${e.message}`);
  process.exit(1);
});
