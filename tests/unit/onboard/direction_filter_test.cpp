// Tests of the fixed-point direction filter (paper eq. 7): hand-computed cases of the paper's rule and
// the gated rule, the stale-team policy, the overflow bounds at the corners of the domain (against an
// exact 128-bit evaluation), and random cases against the double-precision reference.
#include "onboard/core/direction_filter.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <random>

#include "onboard/core/direction_reference.hpp"

namespace teamscan::onboard {
namespace {

__extension__ typedef __int128 i128;

constexpr std::int32_t kE = cone::kDirectionFilterExtentMm;

cone::ConeFixed make_cone(std::int32_t ax, std::int32_t ay, std::int32_t mx, std::int32_t my, double ha_deg,
               cone::DirectionFilterParams p = {}, std::int32_t radius_mm = 360, std::int32_t height_mm = 500) {
  cone::ConeFixed c;
  const cone::Teammate m{2, mx, my, radius_mm, height_mm};
  EXPECT_TRUE(cone::prepare_cone(ax, ay, m, deg_to_rad(ha_deg), p, c));
  return c;
}

// ---- the paper's rule, hand-computed ------------------------------------------------------------

TEST(DirectionFilter, PaperConeHandComputed) {
  // R1 at the origin, R2 5 m ahead on x, ha = 7°: tan 7° = 0.122785, so at 10 m the cone is ±1227.8 mm.
  const cone::ConeFixed c = make_cone(0, 0, 5000, 0, 7.0);
  EXPECT_TRUE(cone::cone_contains(c, 5000, 0, 0));
  EXPECT_TRUE(cone::cone_contains(c, 10000, 1200, 0));   // behind R2, still inside: the paper has no range limit
  EXPECT_TRUE(cone::cone_contains(c, 10000, -1227, 0));
  EXPECT_FALSE(cone::cone_contains(c, 10000, 1229, 0));
  EXPECT_FALSE(cone::cone_contains(c, 10000, -1240, 0));
  EXPECT_TRUE(cone::cone_contains(c, 1000, 100, 0));      // between R1 and R2
  EXPECT_FALSE(cone::cone_contains(c, -1000, 0, 0));      // behind R1
  EXPECT_FALSE(cone::cone_contains(c, 0, 0, 0));          // R1 itself: not ahead
  EXPECT_TRUE(cone::cone_contains(c, 80000, 9800, 5000)); // height is ignored by the paper's rule
  EXPECT_FALSE(cone::cone_contains(c, 80000, 9840, 0));   // 80 m · tan 7° = 9822.8 mm
}

TEST(DirectionFilter, ConeAlongADiagonalAndOffsetApex) {
  // R1 at (1000, −2000), R2 3 m away at 45°. A point 4 m along L, 0.4 m to the side (5.7°) is inside a
  // 7° cone, one 0.6 m to the side (8.5°) is not.
  const double s = std::sqrt(0.5);
  const cone::ConeFixed c = make_cone(1000, -2000, 1000 + static_cast<std::int32_t>(std::lround(3000 * s)),
                           -2000 + static_cast<std::int32_t>(std::lround(3000 * s)), 7.0);
  auto at = [&](double along, double side) {
    return cone::cone_contains(c, 1000 + static_cast<std::int32_t>(std::lround(along * s - side * s)),
                         -2000 + static_cast<std::int32_t>(std::lround(along * s + side * s)), 0);
  };
  EXPECT_TRUE(at(4000, 400));
  EXPECT_TRUE(at(4000, -400));
  EXPECT_FALSE(at(4000, 600));
  EXPECT_FALSE(at(-4000, 0));
}

TEST(DirectionFilter, DegenerateConeIsRefused) {
  cone::ConeFixed c;
  EXPECT_FALSE(cone::prepare_cone(100, 100, cone::Teammate{2, 100, 100, 360, 500}, deg_to_rad(7), {}, c));
  EXPECT_FALSE(cone::prepare_cone(kE + 1, 0, cone::Teammate{2, 100, 100, 360, 500}, deg_to_rad(7), {}, c));
  EXPECT_FALSE(cone::prepare_cone(0, 0, cone::Teammate{2, 0, -kE - 1, 360, 500}, deg_to_rad(7), {}, c));
}

// ---- the gated rule ----------------------------------------------------------------------------------

TEST(DirectionFilter, RangeGateKeepsWhatLiesBehindTheTeammate) {
  cone::DirectionFilterParams p;
  p.range_gate = true;
  p.range_gate_margin_m = 0.3;  // gate = 360 + 300 = 660 mm around |R1R2| = 5000 mm
  const cone::ConeFixed c = make_cone(0, 0, 5000, 0, 7.0, p);
  EXPECT_TRUE(cone::cone_contains(c, 5000, 0, 0));
  EXPECT_TRUE(cone::cone_contains(c, 5660, 0, 0));
  EXPECT_FALSE(cone::cone_contains(c, 5661, 0, 0));
  EXPECT_TRUE(cone::cone_contains(c, 4340, 0, 0));
  EXPECT_FALSE(cone::cone_contains(c, 4339, 0, 0));
  EXPECT_FALSE(cone::cone_contains(c, 10000, 0, 0));  // the paper's rule would filter this wall point
  EXPECT_TRUE(cone::cone_contains(c, 5500, 600, 0));  // the gate measures along L: d_along = 5500
}

TEST(DirectionFilter, HeightGateKeepsWhatLiesAboveTheTeammate) {
  cone::DirectionFilterParams p;
  p.height_gate = true;
  p.height_gate_margin_m = 0.1;  // z_max = 500 + 100
  const cone::ConeFixed c = make_cone(0, 0, 5000, 0, 7.0, p);
  EXPECT_TRUE(cone::cone_contains(c, 5000, 0, 600));
  EXPECT_FALSE(cone::cone_contains(c, 5000, 0, 601));
  EXPECT_TRUE(cone::cone_contains(c, 20000, 0, -300));  // no range gate: far floor point still filtered
}

// ---- the filter with a team state and the stale policy -------------------------------------------

TeamSnapshot team_with(std::int32_t x_mm, std::int32_t y_mm, Time valid, std::uint32_t id = 2) {
  TeamSnapshot t;
  t.count = 1;
  t.members[0].robot_id = id;
  t.members[0].x_mm = x_mm;
  t.members[0].y_mm = y_mm;
  t.members[0].length_mm = 508;
  t.members[0].width_mm = 497;
  t.members[0].height_mm = 500;
  t.members[0].valid_ns = valid.ns();
  return t;
}

const Time kStamp = Time::from_ns(1'000'000'000'000);

TEST(DirectionFilter, CreateRefusesBadParametersNamingThem) {
  cone::DirectionFilterParams p;
  p.half_angle_deg = 0;
  auto r = DirectionFilter::create(p, 1);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(std::string(r.error().what).find("half_angle_deg"), std::string::npos);
  p = {};
  p.half_angle_deg = 61;
  EXPECT_FALSE(DirectionFilter::create(p, 1).ok());
  p = {};
  p.max_team_age = 0ms;
  r = DirectionFilter::create(p, 1);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(std::string(r.error().what).find("max_team_age"), std::string::npos);
  EXPECT_FALSE(DirectionFilter::create({}, 0).ok());
  EXPECT_FALSE(DirectionFilter::create({}, 33).ok());
  EXPECT_TRUE(DirectionFilter::create({}, 32).ok());
}

TEST(DirectionFilter, FreshTeamFiltersWithoutStaleFlag) {
  cone::DirectionFilterParams p;
  p.extrapolate_team = false;
  auto f = DirectionFilter::create(p, 1);
  ASSERT_TRUE(f.ok());
  f->set_team(team_with(5000, 0, kStamp - 100ms));
  ScanPoint pts[4] = {{5000, 0, 0, 0, 0}, {10000, 3000, 0, 1, 0}, {5000, 0, 0, 2, kPointInvalid}, {0, 5000, 0, 3, 0}};
  const auto st = f->apply(0, 0, kStamp, pts, 4);
  EXPECT_EQ(pts[0].flags, kPointDirectionFiltered);
  EXPECT_EQ(pts[1].flags, 0);
  EXPECT_EQ(pts[2].flags, kPointInvalid);  // unplaced points are not judged
  EXPECT_EQ(pts[3].flags, 0);
  EXPECT_EQ(st.filtered, 1u);
  EXPECT_EQ(st.stale_points, 0u);
  EXPECT_EQ(st.cones, 1);
}

TEST(DirectionFilter, StaleTeamWidensTheConeAndSaysSo) {
  cone::DirectionFilterParams p;
  p.extrapolate_team = false;
  p.max_team_age = 500ms;
  p.stale_growth_deg_per_s = 10.0;
  auto f = DirectionFilter::create(p, 1);
  ASSERT_TRUE(f.ok());
  // 2 s old: 1.5 s over the limit -> ha = 7° + 15° = 22°. (10000, 3000) lies at 16.7°.
  f->set_team(team_with(5000, 0, kStamp - 2s));
  EXPECT_NEAR(rad_to_deg(f->effective_half_angle_rad(kStamp - 2s, kStamp)), 22.0, 1e-9);
  ScanPoint pts[2] = {{10000, 3000, 0, 0, 0}, {0, 5000, 0, 1, 0}};
  const auto st = f->apply(0, 0, kStamp, pts, 2);
  EXPECT_EQ(pts[0].flags, kPointDirectionFiltered | kPointTeamStale);
  EXPECT_EQ(pts[1].flags, kPointTeamStale);
  EXPECT_EQ(st.stale_mates, 1);
  EXPECT_EQ(st.stale_points, 2u);
  // The widening stops at 60°.
  EXPECT_NEAR(rad_to_deg(f->effective_half_angle_rad(kStamp - 100s, kStamp)), 60.0, 1e-9);
}

TEST(DirectionFilter, StaleTeamDisablesTheFilterAndSaysSo) {
  cone::DirectionFilterParams p;
  p.stale_policy = cone::StalePolicy::disable;
  auto f = DirectionFilter::create(p, 1);
  ASSERT_TRUE(f.ok());
  f->set_team(team_with(5000, 0, kStamp - 501ms));
  ScanPoint pts[1] = {{5000, 0, 0, 0, 0}};
  const auto st = f->apply(0, 0, kStamp, pts, 1);
  EXPECT_EQ(pts[0].flags, kPointTeamStale);
  EXPECT_EQ(st.skipped_mates, 1);
  // At exactly max_team_age the state is still fresh.
  f->set_team(team_with(5000, 0, kStamp - 500ms));
  ScanPoint fresh_pt[1] = {{5000, 0, 0, 0, 0}};
  (void)f->apply(0, 0, kStamp, fresh_pt, 1);
  EXPECT_EQ(fresh_pt[0].flags, kPointDirectionFiltered);
}

TEST(DirectionFilter, NoTeamStateYetFlagsStaleAndFiltersNothing) {
  auto f = DirectionFilter::create({}, 1);
  ASSERT_TRUE(f.ok());
  ScanPoint pts[1] = {{5000, 0, 0, 0, 0}};
  (void)f->apply(0, 0, kStamp, pts, 1);
  EXPECT_EQ(pts[0].flags, kPointTeamStale);
  // An empty but fresh team: nothing to filter, nothing stale.
  TeamSnapshot empty;
  f->set_team(empty);
  pts[0].flags = 0;
  (void)f->apply(0, 0, kStamp, pts, 1);
  EXPECT_EQ(pts[0].flags, 0);
}

TEST(DirectionFilter, OwnEntryIgnoredLostMemberTreatedAsStale) {
  cone::DirectionFilterParams p;
  p.extrapolate_team = false;
  auto f = DirectionFilter::create(p, 2);
  ASSERT_TRUE(f.ok());
  TeamSnapshot t = team_with(5000, 0, kStamp, 2);  // ourselves
  f->set_team(t);
  ScanPoint pts[1] = {{5000, 0, 0, 0, 0}};
  auto st = f->apply(0, 0, kStamp, pts, 1);
  EXPECT_EQ(pts[0].flags, 0);
  EXPECT_EQ(st.cones, 0);
  // A lost teammate, reported just now: still filtered against (widen policy) but flagged stale.
  t.members[0].robot_id = 3;
  t.members[0].lost = true;
  f->set_team(t);
  pts[0].flags = 0;
  st = f->apply(0, 0, kStamp, pts, 1);
  EXPECT_EQ(pts[0].flags, kPointDirectionFiltered | kPointTeamStale);
  EXPECT_EQ(st.stale_mates, 1);
}

TEST(DirectionFilter, TeammateExtrapolatedToTheScanTime) {
  cone::DirectionFilterParams p;
  p.range_gate = true;
  p.range_gate_margin_m = 0.0;  // gate = body radius = ceil(hypot(508, 497) / 2) = 356 mm
  auto f = DirectionFilter::create(p, 1);
  ASSERT_TRUE(f.ok());
  TeamSnapshot t = team_with(5000, 0, kStamp - 200ms);
  t.members[0].vx_mmps = 1000;  // 200 ms at 1 m/s: R2 is at 5200 mm at the scan's time
  f->set_team(t);
  ScanPoint pts[2] = {{5556, 0, 0, 0, 0}, {5557, 0, 0, 1, 0}};
  (void)f->apply(0, 0, kStamp, pts, 2);
  EXPECT_EQ(pts[0].flags, kPointDirectionFiltered);
  EXPECT_EQ(pts[1].flags, 0);
}

// ---- overflow bounds and agreement with the reference ----------------------------------------------

// The same decision as cone::cone_contains, evaluated in 128 bits: equal results prove no int64 overflow.
bool cone_contains_exact(const cone::ConeFixed& c, std::int32_t x, std::int32_t y, std::int32_t z) {
  if (x > kE || x < -kE || y > kE || y < -kE) return false;
  const i128 vx = i128{x} - c.apex_x_mm, vy = i128{y} - c.apex_y_mm;
  const i128 along = i128{c.ux_mm} * vx + i128{c.uy_mm} * vy;
  if (along <= 0) return false;
  i128 cross = i128{c.ux_mm} * vy - i128{c.uy_mm} * vx;
  if (cross < 0) cross = -cross;
  if (cross * 65536 >= along * c.tan_q16) return false;
  if (c.range_gate && (along * 65536 < c.along_lo_q16 || along * 65536 > c.along_hi_q16)) return false;
  if (c.height_gate && z > c.z_max_mm) return false;
  return true;
}

TEST(DirectionFilter, NoOverflowAtTheCornersOfTheDomain) {
  cone::DirectionFilterParams p;
  p.range_gate = true;
  p.range_gate_margin_m = 131.0;
  p.height_gate = true;
  const std::int32_t vals[] = {-kE, -kE + 1, -1, 0, 1, kE - 1, kE};
  int checked = 0;
  for (std::int32_t ax : {-kE, 0, kE})
    for (std::int32_t ay : {-kE, kE})
      for (std::int32_t mx : {-kE, kE - 1, kE})
        for (std::int32_t my : {-kE, 0, kE})
          for (double ha : {0.5, 7.0, 60.0}) {
            cone::ConeFixed c;
            if (!cone::prepare_cone(ax, ay, cone::Teammate{2, mx, my, cone::kMaxGateMm, 500}, deg_to_rad(ha), p, c)) continue;
            for (std::int32_t x : vals)
              for (std::int32_t y : vals)
                for (std::int32_t z : {-kE, 0, 600, kE}) {
                  ASSERT_EQ(cone::cone_contains(c, x, y, z), cone_contains_exact(c, x, y, z))
                      << ax << "," << ay << " -> " << mx << "," << my << " ha " << ha << " p " << x << "," << y;
                  ++checked;
                }
          }
  EXPECT_GT(checked, 10000);
  // Beyond the extent nothing is judged, even where the cone points.
  const cone::ConeFixed c = make_cone(0, 0, 1000, 0, 60.0);
  EXPECT_FALSE(cone::cone_contains(c, kE + 1, 0, 0));
  EXPECT_TRUE(cone::cone_contains(c, kE, 0, 0));
}

struct Agreement {
  long cases = 0, inside = 0, disagreements = 0, int128_mismatch = 0;
  double max_disagreement_m = 0;
};

// Random R1, R2, p and filter settings; the fixed-point decision against the double reference.
Agreement compare_random(std::uint64_t seed, long n, std::int32_t max_reach_mm) {
  std::mt19937_64 rng{seed};
  std::uniform_int_distribution<std::int32_t> coord(-kE, kE);
  std::uniform_int_distribution<std::int32_t> reach(-max_reach_mm, max_reach_mm);
  std::uniform_real_distribution<double> ha_deg(0.5, 60.0);
  std::uniform_int_distribution<int> coin(0, 3);
  std::uniform_int_distribution<std::int32_t> zs(-1000, 2000);
  auto clampE = [](std::int64_t v) { return static_cast<std::int32_t>(std::clamp<std::int64_t>(v, -kE, kE)); };
  Agreement a;
  for (long i = 0; i < n; ++i) {
    cone::DirectionFilterParams p;
    p.range_gate = coin(rng) == 0;
    p.height_gate = coin(rng) == 0;
    p.range_gate_margin_m = 0.3;
    p.height_gate_margin_m = 0.1;
    const double ha = deg_to_rad(ha_deg(rng));
    const std::int32_t ax = coord(rng), ay = coord(rng);
    const cone::Teammate m{2, clampE(std::int64_t{ax} + reach(rng) / 4), clampE(std::int64_t{ay} + reach(rng) / 4), 360, 500};
    cone::ConeFixed c;
    if (!cone::prepare_cone(ax, ay, m, ha, p, c)) continue;
    // Half the points near L (so that the cone's inside and edges are well sampled), half anywhere.
    std::int32_t x, y;
    if (coin(rng) < 2) {
      const double ux = static_cast<double>(c.ux_mm), uy = static_cast<double>(c.uy_mm);
      const double ulen = std::hypot(ux, uy);
      const double along = std::uniform_real_distribution<double>(-0.1, 1.0)(rng) * max_reach_mm;
      const double side = std::uniform_real_distribution<double>(-1.2, 1.2)(rng) * std::tan(ha) * std::abs(along);
      x = clampE(std::llround(ax + (along * ux - side * uy) / ulen));
      y = clampE(std::llround(ay + (along * uy + side * ux) / ulen));
    } else {
      x = clampE(std::int64_t{ax} + reach(rng));
      y = clampE(std::int64_t{ay} + reach(rng));
    }
    const std::int32_t z = zs(rng);
    const bool fixed = cone::cone_contains(c, x, y, z);
    if (fixed != cone_contains_exact(c, x, y, z)) ++a.int128_mismatch;
    const ConeReference ref{ax * 1e-3, ay * 1e-3, m.x_mm * 1e-3, m.y_mm * 1e-3, ha,
                            p.range_gate, (m.body_radius_mm + 300) * 1e-3, p.height_gate, (m.height_mm + 100) * 1e-3};
    const ConeDecision d = cone_reference(ref, x * 1e-3, y * 1e-3, z * 1e-3);
    ++a.cases;
    if (fixed) ++a.inside;
    if (fixed != d.inside) {
      ++a.disagreements;
      if (std::getenv("TEAMSCAN_DEBUG"))
        std::printf("disagree: fixed %d dist %.4f mm rg %d hg %d ha %.3f apex %d,%d mate %d,%d p %d,%d,%d\n", fixed,
                    d.boundary_distance_m * 1e3, p.range_gate, p.height_gate, rad_to_deg(ha), ax, ay, m.x_mm, m.y_mm, x, y, z);
      a.max_disagreement_m = std::max(a.max_disagreement_m, d.boundary_distance_m);
    }
  }
  return a;
}

TEST(DirectionFilter, AgreesWithReferenceOverTheLmsRange) {
  // Points and teammates within 80 m of R1 (the LMS's cm-mode range), R1 anywhere in the ±2097 m map.
  // Stated bound: decisions agree except within 1 mm of a boundary (tan in Q16: <= 80 m · 2^-17 = 0.61 mm;
  // range gate with |u| to 1/256 mm: < 0.1 mm for teammates more than 0.1 m away).
  const Agreement a = compare_random(20261122, 1'000'000, 80'000);
  std::printf("lms range: %ld cases, %ld inside, %ld disagreements, max %.3f mm from a boundary\n", a.cases, a.inside,
              a.disagreements, a.max_disagreement_m * 1e3);
  EXPECT_GT(a.inside, a.cases / 10);
  EXPECT_EQ(a.int128_mismatch, 0);
  EXPECT_LE(a.max_disagreement_m, 1.0e-3);
}

TEST(DirectionFilter, AgreesWithReferenceOverTheWholeDomain) {
  // Anything in the ±2^21 mm box: no overflow (128-bit check), disagreements within the Q16 bound
  // d_r · 2^-17 / cos²(ha) (+1 mm) of a boundary: at most 4.2 km · 7.6e-6 · 4 + 1 mm = 129 mm.
  const Agreement a = compare_random(42, 300'000, 2 * kE);
  std::printf("whole domain: %ld cases, %ld inside, %ld disagreements, max %.3f mm from a boundary\n", a.cases, a.inside,
              a.disagreements, a.max_disagreement_m * 1e3);
  EXPECT_EQ(a.int128_mismatch, 0);
  EXPECT_LE(a.max_disagreement_m, 0.129);
}

}  // namespace
}  // namespace teamscan::onboard
