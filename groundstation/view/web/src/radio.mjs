// A robot's radio state as the view's robot table shows it (docs/view.md, docs/radio.md "What the operator
// sees"), from the state message's shadow fields: in a shadow, back-filling after it, whole again. Pure
// (no DOM), so that node runs its test (tests/unit/view/view_radio_test.mjs).

// 3200 -> "3 200" (the docs' and the status line's thin grouping).
export function groupDigits(n) {
  return String(Math.round(n)).replace(/\B(?=(\d{3})+(?!\d))/g, ' ');
}

function seconds(s) {
  return s >= 10 ? `${Math.round(s)} s` : `${s.toFixed(1)} s`;
}

// The text for robot state `r` (the fields shadow_s, scans_buffered, backfill_pct, last_shadow_s,
// whole_again_ns) at the state's instant `stampNs` (CLOCK_REALTIME, ns, a number or BigInt); '' when the
// robot never was in a shadow. `whole again` is shown for wholeForS after it happened.
export function radioText(r, stampNs, wholeForS = 60) {
  if (!r) return '';
  const buffered = typeof r.scans_buffered === 'number' ? r.scans_buffered : 0;
  if (typeof r.shadow_s === 'number' && r.shadow_s > 0) {
    return `in shadow for ${seconds(r.shadow_s)}, ${groupDigits(buffered)} scans buffered`;
  }
  if (typeof r.backfill_pct === 'number' && r.backfill_pct >= 0) {
    const after = r.last_shadow_s > 0 ? ` after a shadow of ${seconds(r.last_shadow_s)}` : '';
    return `back-filling ${Math.floor(r.backfill_pct)} %${after}, ${groupDigits(buffered)} scans buffered`;
  }
  if (typeof r.whole_again_ns === 'number' && r.whole_again_ns > 0 && stampNs) {
    const agoS = (Number(stampNs) - r.whole_again_ns) / 1e9;
    if (agoS >= 0 && agoS <= wholeForS) {
      const after = r.last_shadow_s > 0 ? ` after a shadow of ${seconds(r.last_shadow_s)}` : '';
      return `whole again ${seconds(agoS)} ago${after}`;
    }
  }
  return '';
}
