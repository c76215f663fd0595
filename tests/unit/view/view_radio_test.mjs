// The view's radio line per robot (groundstation/view/web/src/radio.mjs): in a shadow, back-filling, whole
// again, nothing, from the state message's fields as the station sends them (docs/view.md).
// usage: node view_radio_test.mjs
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { radioText, groupDigits } from '../../../groundstation/view/web/src/radio.mjs';

const NOW = 1796150186439096546;  // a state's stamp_ns (CLOCK_REALTIME)
const heard = { shadow_s: 0, scans_buffered: 0, backfill_pct: -1, last_shadow_s: 0, whole_again_ns: 0 };

test('digits are grouped as in the docs', () => {
  assert.equal(groupDigits(3200), '3 200');
  assert.equal(groupDigits(480), '480');
  assert.equal(groupDigits(1234567), '1 234 567');
});

test('a robot never in a shadow shows nothing', () => {
  assert.equal(radioText(heard, NOW), '');
  assert.equal(radioText(undefined, NOW), '');
});

test('in a shadow: how long and what its ring holds', () => {
  assert.equal(radioText({ ...heard, shadow_s: 43.2, scans_buffered: 3200 }, NOW), 'in shadow for 43 s, 3 200 scans buffered');
  assert.equal(radioText({ ...heard, shadow_s: 2.5, scans_buffered: 190 }, NOW), 'in shadow for 2.5 s, 190 scans buffered');
});

test('back-filling after it: the share done and the shadow', () => {
  assert.equal(radioText({ ...heard, backfill_pct: 37.4, last_shadow_s: 12.7, scans_buffered: 302 }, NOW),
    'back-filling 37 % after a shadow of 13 s, 302 scans buffered');
  assert.equal(radioText({ ...heard, backfill_pct: 0, scans_buffered: 480 }, NOW), 'back-filling 0 %, 480 scans buffered');
});

test('whole again: shown for a minute after it', () => {
  const r = { ...heard, last_shadow_s: 12.7, whole_again_ns: NOW - 6e9 };
  assert.equal(radioText(r, NOW), 'whole again 6.0 s ago after a shadow of 13 s');
  assert.equal(radioText(r, NOW + 120e9), '');
  assert.equal(radioText(r, BigInt('1796150186439096546')), 'whole again 6.0 s ago after a shadow of 13 s');
});
