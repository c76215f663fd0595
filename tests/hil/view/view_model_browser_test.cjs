// Browser test of what the operator sees on a drift scenario: a live `teamscan demo --scenario lap2-drift
// --registration --view PORT`, the page open in headless Chromium from start to end. When the demo stops
// the station, its last turn releases every held scan, publishes the map once more and sends it to the
// open page before the view stops; then it writes the fused model (session/fused_all.pcd). The test
// checks that the page's map shows the core's final release (the page's map_release, the station's
// events.log), that the voxels the page draws (keys and classes, read from its drawn buffers) are exactly
// the model file's points binned at the map resolution, that with "hide removed" it draws exactly the
// model's voxels with a point kept at release, and that the walls are single: no voxel of robot 2's on a
// wall of the room more than 10 cm outside robot 1's outermost voxel on that wall.
// usage: node view_model_browser_test.cjs TEAMSCAN_BIN OUT_DIR [--expect-doubled-walls] [--duration S]
//   (NODE_PATH: the view's node_modules). --expect-doubled-walls runs the same scenario with odometry
//   alone (--no-registration) and requires the wall check to find robot 2's walls outside robot 1's:
//   the check can fail. --duration: seconds of robot time (30).
'use strict';
const fs = require('node:fs');
const path = require('node:path');
const { check, failed, freePort, waitFor, spawnDemo, stopDemo, openDemoView } =
  require(path.join(__dirname, '..', '..', 'support', 'node', 'harness.cjs'));
const { readPcd, binModel } = require(path.join(__dirname, '..', '..', 'support', 'node', 'model_file.cjs'));

const [teamscan, outDir, ...options] = process.argv.slice(2);
const DOUBLED = options.includes('--expect-doubled-walls');
const DURATION_S = options.includes('--duration') ? Number(options[options.indexOf('--duration') + 1]) : 30;
// sim/scenarios/lap2-drift.toml: the room is 9 × 7 × 3 m, centred on the map origin (sim/world.hpp).
const ROOM_HALF_M = [4.5, 3.5];
const WALL_BAND_M = 0.6;      // a voxel within this of a wall (inside or out) is the wall's
const WALL_CORNER_M = 0.6;    // ... unless it is this close to a corner (the other wall's)
const WALL_Z_M = [0.3, 2.7];  // above the floor, below the ceiling
const OUTSIDE_M = 0.10;
const WALL_MIN_SCANS = 2;     // a robot's wall voxel: seen in at least this many of its scans

// The page's drawn voxels (window.teamscanView.drawnMap) as key -> { ghost, robot }; repeated keys counted.
function pageVoxels(drawn) {
  const out = new Map();
  let repeated = 0;
  for (let i = 0; i < drawn.voxels.length; i += 5) {
    const key = `${drawn.voxels[i]},${drawn.voxels[i + 1]},${drawn.voxels[i + 2]}`;
    if (out.has(key)) repeated++;
    out.set(key, { ghost: (drawn.voxels[i + 3] & 1) === 1, robot: drawn.voxels[i + 4] });
  }
  return { voxels: out, repeated };
}

// Keys of `a` not in `b`, and keys in both whose class differs (the first few of each, for the log).
function compare(a, b) {
  const missing = [], wrongClass = [];
  for (const [key, v] of a) {
    const w = b.get(key);
    if (!w) missing.push(key);
    else if (w.ghost !== v.ghost) wrongClass.push(`${key} (${v.ghost ? 'ghost' : 'kept'} vs ${w.ghost ? 'ghost' : 'kept'})`);
  }
  return { missing, wrongClass };
}

// Per wall of the room, over the drawn voxels (`shown`, keys as the model's): robot 1's outermost voxel
// across the wall and how far robot 2's voxels lie beyond it (voxel centres, metres); `beyond`: robot 2's
// voxels more than OUTSIDE_M outside. A voxel is robot r's when at least `minScans` of robot r's scans
// have a point in it (the model's rows).
function wallOffsets(shown, model, resolutionM, minScans) {
  const walls = [];
  const robots = (key) => [1, 2].map((r) => ((model.get(key) || { scans: new Map() }).scans.get(r) || new Set()).size >= minScans);
  for (const [axis, sign] of [[0, -1], [0, 1], [1, -1], [1, 1]]) {
    const along = 1 - axis;
    const wall = { name: `${sign < 0 ? '-' : '+'}${'xy'[axis]}`, robot1: -Infinity, robot2: [], beyond: 0, max_m: -Infinity, scans: new Set() };
    for (const key of shown.keys()) {
      const c = key.split(',').map((k) => (Number(k) + 0.5) * resolutionM);
      const outward = sign * c[axis] - ROOM_HALF_M[axis];  // 0 on the wall, > 0 outside the room
      if (Math.abs(outward) > WALL_BAND_M || Math.abs(c[along]) > ROOM_HALF_M[along] - WALL_CORNER_M) continue;
      if (c[2] < WALL_Z_M[0] || c[2] > WALL_Z_M[1]) continue;
      const [of1, of2] = robots(key);
      if (of1) wall.robot1 = Math.max(wall.robot1, outward);
      if (of2) wall.robot2.push([outward, key]);
    }
    for (const [o, key] of wall.robot2) {
      wall.max_m = Math.max(wall.max_m, o - wall.robot1);
      if (o - wall.robot1 > OUTSIDE_M + 1e-6) {
        wall.beyond++;
        for (const seq of model.get(key).scans.get(2)) wall.scans.add(seq);
      }
    }
    walls.push(wall);
  }
  return walls;
}

async function main() {
  const startMs = Date.now();
  const elapsed = () => `${((Date.now() - startMs) / 1000).toFixed(1)} s`;
  const port = await freePort();
  fs.rmSync(outDir, { recursive: true, force: true });
  const demo = spawnDemo(teamscan, ['demo', '--scenario', 'lap2-drift', DOUBLED ? '--no-registration' : '--registration',
    '--duration', String(DURATION_S), '--bringup', '4', '--method', 'best', '--station-compare', 'none',
    '--view', String(port), '--out', outDir, '--quiet']);
  let browser = null;
  try {
    browser = await openDemoView(demo);
    const { page } = browser;
    await waitFor('map points', 90000, () => page.evaluate(() => window.teamscanView.voxels > 200));

    // The demo stops the station; the page keeps what it was sent last.
    const session = path.join(outDir, 'session');
    const modelFile = path.join(session, 'fused_all.pcd');
    await waitFor('the station to write its final model', 240000, () => {
      if (fs.existsSync(modelFile)) return true;
      if (demo.exited) throw new Error('the demo exited without the station writing session/fused_all.pcd');
      return false;
    });
    console.log(`${elapsed()}: the station wrote its model`);
    await waitFor('the page to see the station go', 10000, () => page.evaluate(() => !window.teamscanView.connected));
    page.removeAllListeners('console');  // its reconnection attempts fail from now on: expected
    // The demo's own scoring (offline evaluations) is not this test's: stopped, so that it does not take
    // the CPU from the page (its processes are down; the session folder is complete).
    if (!demo.exited) demo.child.kill('SIGKILL');
    await waitFor('the demo to stop', 10000, () => demo.exited);

    // The instant: the page's map release is the station's last publication's, which is the core's last.
    const drawn = await page.evaluate(() => window.teamscanView.drawnMap());
    const events = fs.readFileSync(path.join(session, 'events.log'), 'utf8');
    const last = /live map: last published at release (\d+) \((\d+) voxels\); the core released (\d+) scans/.exec(events);
    check(!!last, 'the station logged its last map publication');
    const release = last ? Number(last[1]) : -1;
    const order = /\d+ scans released by hold_s, \d+ out of stamp order/g;
    const released = events.match(order);
    if (released) console.log(`the core: ${released[released.length - 1]}`);
    check(release > 0 && drawn.release === release && Number(last[3]) === release,
      `the page shows release ${drawn.release}; the station last published release ${release}, its core released ${last && last[3]} scans`);

    // The page's voxels against the model file binned: the same keys, the same classes.
    const pcd = readPcd(modelFile);
    const model = binModel(pcd, drawn.resolution_m);
    const shown = pageVoxels(drawn);
    const notShown = compare(model, shown.voxels);
    const notInModel = compare(shown.voxels, model);
    const ghosts = [...model.values()].filter((v) => v.ghost).length;
    let robotDiffers = 0;
    for (const [key, v] of shown.voxels) if (model.has(key) && model.get(key).robot !== v.robot) robotDiffers++;
    console.log(`model: ${model.size} voxels (${ghosts} removed ghosts) at ${drawn.resolution_m} m; page: ${shown.voxels.size} drawn` +
      ` (${shown.repeated} repeated); voxels whose first row's robot differs from the page's: ${robotDiffers}`);
    if (notShown.missing.length) console.log(`  model voxels not drawn: ${notShown.missing.slice(0, 5).join(' ')}`);
    if (notInModel.missing.length) console.log(`  drawn voxels not in the model: ${notInModel.missing.slice(0, 5).join(' ')}`);
    if (notShown.wrongClass.length) console.log(`  class differs (model vs page): ${notShown.wrongClass.slice(0, 5).join(' ')}`);
    check(model.size > 1000 && ghosts > 0, `the model is not trivial: ${model.size} voxels, ${ghosts} of them removed ghosts`);
    check(shown.repeated === 0 && notShown.missing.length === 0 && notInModel.missing.length === 0,
      `the page draws exactly the model's voxels (${notShown.missing.length} missing, ${notInModel.missing.length} extra, ${shown.repeated} repeated)`);
    check(notShown.wrongClass.length === 0, `every drawn voxel has the model's class (${notShown.wrongClass.length} differ)`);

    // "hide removed": exactly the model's voxels with a point kept at release.
    await page.evaluate(() => {  // what choosing "hide" does (a change event on the select)
      const select = document.getElementById('removed');
      select.value = 'hide';
      select.dispatchEvent(new Event('change'));
    });
    const kept = pageVoxels(await page.evaluate(() => window.teamscanView.drawnMap())).voxels;
    const modelKept = new Map([...model].filter(([, v]) => !v.ghost));
    const keptDiff = [compare(modelKept, kept).missing.length, compare(kept, modelKept).missing.length];
    check(kept.size === modelKept.size && keptDiff[0] === 0 && keptDiff[1] === 0,
      `hiding removed ghosts draws the model's kept voxels: ${kept.size} drawn, ${modelKept.size} in the model (${keptDiff[0]} missing, ${keptDiff[1]} extra)`);

    // Single walls, on what the page draws: robot 2's wall voxels (seen in at least two of its scans)
    // against robot 1's; with every voxel (one point of one scan enough) for the figures.
    for (const minScans of [1, WALL_MIN_SCANS]) {
      const walls = wallOffsets(shown.voxels, model, drawn.resolution_m, minScans);
      const beyond = walls.reduce((n, w) => n + w.beyond, 0);
      console.log(`voxels seen in at least ${minScans} of a robot's scans:`);
      for (const w of walls) {
        console.log(`  wall ${w.name}: robot 1 outermost ${w.robot1.toFixed(2)} m, robot 2 at most ${w.max_m.toFixed(2)} m beyond it ` +
          `(${w.beyond} of ${w.robot2.length} voxels more than ${OUTSIDE_M * 100} cm)`);
      }
      const scans = [...new Set(walls.flatMap((w) => [...w.scans]))].sort((a, b) => a - b);
      if (scans.length) console.log(`  robot 2's scans in those voxels: ${scans.slice(0, 40).join(' ')}${scans.length > 40 ? ' ...' : ''}`);
      if (minScans !== WALL_MIN_SCANS) continue;
      check(walls.every((w) => Number.isFinite(w.robot1) && w.robot2.length > 20), 'both robots drew every wall');
      if (DOUBLED) check(beyond > 0, `odometry alone: robot 2's walls outside robot 1's (${beyond} voxels more than ${OUTSIDE_M * 100} cm)`);
      else check(beyond === 0, `single walls: no voxel of robot 2's wall more than ${OUTSIDE_M * 100} cm outside robot 1's (${beyond})`);
    }
  } catch (e) {
    check(false, String(e.message || e));
  } finally {
    console.log(`${elapsed()}: checked`);
    if (browser) await browser.close();
    await stopDemo(demo);
  }
  console.log(failed() === 0 ? 'view model browser test: passed' : `view model browser test: ${failed()} failed`);
  process.exit(failed() === 0 ? 0 : 1);
}

main();
