// Test support: a station model file (a binary PCD, common/dataset/pcd.hpp's layout) read in Node, and
// its points binned as the station's live map bins them, for the tests that compare what a client was
// sent with the model the station wrote (view_model_browser_test, foxglove_client_test).
'use strict';
const fs = require('node:fs');

// A binary PCD (common/dataset/pcd.hpp's layout): { fields: {name: {offset, type, size}}, rows, view, stride }.
function readPcd(file) {
  const bytes = fs.readFileSync(file);
  const end = bytes.indexOf('DATA binary\n');
  if (end < 0) throw new Error(`${file}: not a binary PCD`);
  const header = {};
  for (const line of bytes.subarray(0, end).toString('latin1').split('\n')) {
    const [k, ...v] = line.split(' ');
    if (k && k[0] !== '#') header[k] = v;
  }
  const fields = {};
  let offset = 0;
  header.FIELDS.forEach((name, i) => {
    fields[name] = { offset, type: header.TYPE[i], size: Number(header.SIZE[i]) };
    offset += Number(header.SIZE[i]) * Number(header.COUNT[i]);
  });
  const rows = Number(header.POINTS[0]);
  const data = bytes.subarray(end + 'DATA binary\n'.length);
  if (data.length !== rows * offset) throw new Error(`${file}: ${data.length} data bytes for ${rows} rows of ${offset}`);
  return { fields, rows, stride: offset, view: new DataView(data.buffer, data.byteOffset, data.length) };
}

function pcdField(pcd, row, name) {
  const f = pcd.fields[name];
  const o = row * pcd.stride + f.offset;
  if (f.type === 'F') return pcd.view.getFloat32(o, true);
  return f.size === 1 ? pcd.view.getUint8(o) : f.size === 2 ? pcd.view.getUint16(o, true) : pcd.view.getUint32(o, true);
}

// The model's points binned as the station's live map bins them (groundstation/station/live_map.cpp,
// mapping::voxel_key: floor(coordinate × (1 / resolution)) in double): key "i,j,k" -> { ghost: every
// point in it removed at release (live_keep 0), robot: its first row's, scans: robot -> the set of that
// robot's scans with a point in it }.
function binModel(pcd, resolutionM) {
  const inverse = 1.0 / resolutionM;
  const out = new Map();
  for (let r = 0; r < pcd.rows; r++) {
    const key = [pcdField(pcd, r, 'x'), pcdField(pcd, r, 'y'), pcdField(pcd, r, 'z')].map((c) => Math.floor(c * inverse)).join(',');
    const kept = pcdField(pcd, r, 'live_keep') === 1;
    const robot = pcdField(pcd, r, 'robot');
    let v = out.get(key);
    if (!v) out.set(key, (v = { ghost: !kept, robot, scans: new Map() }));
    else if (kept) v.ghost = false;
    if (!v.scans.has(robot)) v.scans.set(robot, new Set());
    v.scans.get(robot).add(pcdField(pcd, r, 'scan'));
  }
  return out;
}

module.exports = { readPcd, pcdField, binModel };
