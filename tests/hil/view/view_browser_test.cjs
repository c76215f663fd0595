// Browser test of the ground station's view (issue 13): a live `teamscan demo --view PORT` (lap2), opened
// in headless Chromium (Debian's /usr/bin/chromium, driven by playwright-core). Checks that map points
// arrive, that every robot's marker is drawn within 5 cm of the station's tracked pose for the same state
// (/api/state?seq=N), and that the robot whose daemon the demo kills shows as lost within 2 s of the kill
// (the moment the demo prints it). Saves a screenshot.
// usage: node view_browser_test.cjs TEAMSCAN_BIN OUT_DIR SCREENSHOT.png   (NODE_PATH: the view's node_modules)
'use strict';
const fs = require('node:fs');
const path = require('node:path');
const { check, failed, sleep, freePort, getJson, waitFor, spawnDemo, stopDemo, openDemoView } =
  require(path.join(__dirname, '..', '..', 'support', 'node', 'harness.cjs'));

const [teamscan, outDir, screenshot] = process.argv.slice(2);
const KILLED_ROBOT = 2;
const KILL_AT_S = 24;          // world time of the kill (the robots drive from ~6 s of bring-up)
const MARKER_TOLERANCE_M = 0.05;
const LOST_WITHIN_MS = 2000;

async function main() {
  const port = await freePort();
  fs.rmSync(outDir, { recursive: true, force: true });
  let killedAtMs = 0;
  const demo = spawnDemo(teamscan, ['demo', '--scenario', 'lap2', '--duration', '45', '--view', String(port), '--out', outDir,
    '--kill-robot', String(KILLED_ROBOT), '--kill-robot-at', String(KILL_AT_S), '--quiet'], (output) => {
    if (!killedAtMs && /fault: robot\d+ daemon killed/.test(output)) killedAtMs = Date.now();
  });
  let browser = null;
  try {
    browser = await openDemoView(demo);
    const { page, url } = browser;

    // Map points arrive (the whole map, then changes) and both robots appear.
    const arrived = await waitFor('map points and two robots', 90000, () => page.evaluate(() => {
      const v = window.teamscanView;
      return v.voxels > 200 && v.robots().length === 2 && v.robots().every((r) => !r.lost) ? { voxels: v.voxels, messages: v.voxelMessages } : null;
    }));
    check(arrived.voxels > 200, `map points arrived: ${arrived.voxels} voxels in ${arrived.messages} voxel messages`);
    const grown = await waitFor('the map to grow', 20000, () => page.evaluate((n) => window.teamscanView.voxels > n ? window.teamscanView.voxels : 0, arrived.voxels));
    check(grown > arrived.voxels, `changes arrive as deltas: ${arrived.voxels} -> ${grown} voxels`);

    // Every robot's marker against the station's tracked pose of the same state, a few times while driving.
    let worst = 0, compared = 0;
    for (let k = 0; k < 10 && !killedAtMs; k++) {
      const s = await page.evaluate(() => ({ seq: window.teamscanView.stateSeq, robots: window.teamscanView.robots() }));
      const st = await getJson(`${url}api/state?seq=${s.seq}`);
      if (st.status !== 200) continue;  // the page's state is no longer held (only the newest are)
      for (const r of s.robots) {
        const t = st.json.robots.find((x) => x.id === r.id);
        if (!t) continue;
        const d = Math.hypot(r.marker_x_m - t.x_m, r.marker_y_m - t.y_m);
        worst = Math.max(worst, d);
        compared++;
      }
      await sleep(400);
    }
    check(compared >= 10 && worst <= MARKER_TOLERANCE_M,
      `robot markers vs the station's tracked pose: ${compared} comparisons, worst ${(worst * 100).toFixed(2)} cm (≤ ${MARKER_TOLERANCE_M * 100} cm)`);

    // The killed robot shows as lost.
    await waitFor('the demo to kill a robot', 120000, () => killedAtMs);
    const pageLostAtMs = await waitFor('the page to show the robot lost', 15000, () => page.evaluate((id) => {
      const r = window.teamscanView.robots().find((x) => x.id === id);
      return r && r.lost && /LOST/.test(r.row_text) ? Date.now() : 0;
    }, KILLED_ROBOT));
    // The station's own record (events.log) of the loss, for the figures: the page shows the team state's
    // lost flag, set by the tracker (no pose for team.kalman.lost_after_s) or by DDS liveliness/dispose.
    const events = fs.readFileSync(path.join(outDir, 'session', 'events.log'), 'utf8');
    const lostLine = events.split('\n').find((l) => l.includes(`robot ${KILLED_ROBOT} LOST`));
    const stationLost = lostLine ? `${Number(BigInt(lostLine.split(' ')[0]) / 1000000n) - killedAtMs} ms (events.log)` : 'not yet in events.log';
    const shownMs = pageLostAtMs - killedAtMs;
    const st = await getJson(`${url}api/state`);
    const stationRobot = st.json && st.json.robots.find((x) => x.id === KILLED_ROBOT);
    check(!!stationRobot && stationRobot.lost, `the station's state has robot ${KILLED_ROBOT} lost`);
    console.log(`robot ${KILLED_ROBOT}: killed -> station LOST event ${stationLost}; killed -> shown lost in the page ${shownMs} ms`);
    check(shownMs <= LOST_WITHIN_MS, `the page shows the killed robot lost within ${LOST_WITHIN_MS} ms of the kill (${shownMs} ms)`);
    await sleep(1500);
    fs.mkdirSync(path.dirname(screenshot), { recursive: true });
    await page.screenshot({ path: screenshot });
    console.log(`screenshot: ${screenshot}`);
    const stats = await getJson(`${url}api/stats`);
    console.log(`view counters: ${JSON.stringify(stats.json)}`);
  } catch (e) {
    check(false, String(e.message || e));
  } finally {
    if (browser) await browser.close();
    await stopDemo(demo);
  }
  console.log(failed() === 0 ? 'view browser test: passed' : `view browser test: ${failed()} failed`);
  process.exit(failed() === 0 ? 0 : 1);
}

main();
