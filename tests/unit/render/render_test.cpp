// The renderer on a tiny hand-made data set: where a point must land (orthographic fits computed by
// hand), its colour in each mode, the background elsewhere, the PNG header, determinism and errors.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/render/render.hpp"

namespace teamscan::render {
namespace {

constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kBlack{0, 0, 0};

// Floor grid over [0, 10] x [0, 6] m every 0.5 m (robot 1 on the left half, robot 2 on the right),
// one ghost point 0.3 m up at the centre (5, 3) that robot 1 measured on robot 2.
Dataset tiny_dataset() {
  Dataset d;
  d.scenario = "tiny";
  DatasetRobot r1, r2;
  r1.id = 1; r1.name = "robot1"; r1.role = "down-laser";
  r2.id = 2; r2.name = "robot2"; r2.role = "up-laser";
  d.robots = {r1, r2};
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 12; ++j) {
      if (i == 10 && j == 6) continue;
      LabelledPoint p;
      p.x = 0.5f * static_cast<float>(i);
      p.y = 0.5f * static_cast<float>(j);
      p.z = 0;
      p.robot = i < 10 ? 1 : 2;
      p.label = PointClass::floor;
      d.points.push_back(p);
    }
  LabelledPoint g;
  g.x = 5; g.y = 3; g.z = 0.3f; g.robot = 1; g.label = PointClass::robot; g.hit_robot = 2;
  d.points.push_back(g);
  return d;
}

RenderOptions small(View v, ColorMode c) {
  RenderOptions o;
  o.view = v;
  o.color = c;
  o.width_px = 400;
  o.height_px = 300;
  o.draw_tracks = false;
  return o;
}

// The orthographic top view by hand: scale = 0.96 * min(plot width / 10 m, plot height / 6 m),
// the box centre (5, 3) at the plot centre, y up.
struct HandTop {
  double cu, cv, s;
  explicit HandTop(const RenderOptions& o) {
    const PlotRect r = plot_rect(o);
    cu = (r.x0 + r.x1) / 2.0;
    cv = (r.y0 + r.y1) / 2.0;
    s = 0.96 * std::min((r.x1 - r.x0) / 10.0, (r.y1 - r.y0) / 6.0);
  }
  [[nodiscard]] int u(double x) const { return static_cast<int>(std::floor(cu + (x - 5) * s)); }
  [[nodiscard]] int v(double y) const { return static_cast<int>(std::floor(cv - (y - 3) * s)); }
};

TEST(RenderLayout, PlotRectLeavesRoomForTitleAndLegend) {
  RenderOptions o = small(View::top, ColorMode::class_label);
  const PlotRect r = plot_rect(o);
  EXPECT_GT(r.x0, 0);
  EXPECT_LT(r.x1, o.width_px);
  EXPECT_LT(r.y1, o.height_px);  // legend band below
  o.title = "title";
  EXPECT_GT(plot_rect(o).y0, r.y0);  // title band above
}

TEST(RenderCamera, TopViewMatchesHandFit) {
  const auto d = tiny_dataset();
  const auto o = small(View::top, ColorMode::class_label);
  const Camera cam = camera_for(input_from_dataset(d), o);
  const HandTop hand(o);
  for (const Vec3 p : {Vec3{0, 0, 0}, Vec3{10, 6, 0}, Vec3{5, 3, 0.3}, Vec3{2.5, 4.5, 0}}) {
    const auto px = cam.project(p);
    ASSERT_TRUE(px.visible);
    EXPECT_NEAR(px.u, hand.cu + (p.x - 5) * hand.s, 1e-9);
    EXPECT_NEAR(px.v, hand.cv - (p.y - 3) * hand.s, 1e-9);
  }
  EXPECT_NEAR(cam.pixels_per_metre(), hand.s, 1e-12);
  // Seen from above, higher is nearer.
  EXPECT_LT(cam.project({1, 1, 2}).depth, cam.project({1, 1, 0}).depth);
}

TEST(RenderPixels, ClassModeGhostBlackSceneGreyBackgroundWhite) {
  const auto d = tiny_dataset();
  const auto o = small(View::top, ColorMode::class_label);
  const auto img = render(input_from_dataset(d), o);
  ASSERT_TRUE(img.ok()) << img.error().what;
  EXPECT_EQ(img->width_px, 400);
  EXPECT_EQ(img->height_px, 300);
  ASSERT_EQ(img->rgb.size(), 400u * 300u * 3u);
  const HandTop hand(o);
  EXPECT_EQ(img->at(hand.u(5), hand.v(3)), kBlack);                    // the ghost
  const Rgb floor = img->at(hand.u(1), hand.v(1));                     // a floor point: light grey
  EXPECT_EQ(floor.r, floor.g);
  EXPECT_EQ(floor.g, floor.b);
  EXPECT_GT(floor.r, 150);
  EXPECT_LT(floor.r, 230);
  EXPECT_EQ(img->at(hand.u(1.25), hand.v(1.25)), kWhite);              // between grid points
  const PlotRect r = plot_rect(o);
  EXPECT_EQ(img->at(r.x0 + 1, (r.y0 + r.y1) / 2), kWhite);             // outside the cloud
}

TEST(RenderPixels, GhostDrawnAboveTheFloorEvenWhenFloorIsDrawnLater) {
  auto d = tiny_dataset();
  // Move the ghost first and put a floor point under it: the ghost must still show.
  std::rotate(d.points.rbegin(), d.points.rbegin() + 1, d.points.rend());
  LabelledPoint under;
  under.x = 5; under.y = 3; under.z = 0.5f; under.robot = 2; under.label = PointClass::wall;
  d.points.push_back(under);
  const auto o = small(View::top, ColorMode::class_label);
  const auto img = render(input_from_dataset(d), o);
  ASSERT_TRUE(img.ok());
  const HandTop hand(o);
  EXPECT_EQ(img->at(hand.u(5), hand.v(3)), kBlack);
}

TEST(RenderPixels, RobotModeGivesDownLaserDarkAndUpLaserLight) {
  const auto d = tiny_dataset();
  const auto o = small(View::top, ColorMode::robot);
  const auto img = render(input_from_dataset(d), o);
  ASSERT_TRUE(img.ok());
  const HandTop hand(o);
  const Rgb down = img->at(hand.u(1), hand.v(1));   // robot 1, down-laser
  const Rgb up = img->at(hand.u(9), hand.v(1));     // robot 2, up-laser
  EXPECT_EQ(down.r, down.g);
  EXPECT_EQ(up.r, up.g);
  EXPECT_LT(down.r, up.r);
  EXPECT_LT(up.r, 255);
  EXPECT_EQ(img->at(hand.u(5), hand.v(3)), kBlack);
}

TEST(RenderPixels, FilterModeWhiteForFilteredBlackForMissedGhosts) {
  const auto d = tiny_dataset();
  std::vector<std::uint8_t> keep(d.points.size(), 1);
  // Filter the floor point at (1, 1): index i*13 + j with i = j = 2.
  ASSERT_EQ(d.points[2 * 13 + 2].x, 1.0f);
  ASSERT_EQ(d.points[2 * 13 + 2].y, 1.0f);
  keep[2 * 13 + 2] = 0;
  const auto o = small(View::top, ColorMode::filter);
  const auto img = render(input_from_dataset(d, keep), o);
  ASSERT_TRUE(img.ok());
  const HandTop hand(o);
  EXPECT_EQ(img->at(hand.u(1), hand.v(1)), kWhite);
  EXPECT_EQ(img->at(hand.u(5), hand.v(3)), kBlack);  // ghost not filtered: missed, black
  const Rgb bg = img->at(hand.u(1.25), hand.v(1.25));
  EXPECT_NE(bg, kWhite);                              // a background white points show on
  EXPECT_LT(int{bg.r} + bg.g + bg.b, 3 * 160);
  // The ghost filtered: white too.
  keep.back() = 0;
  const auto img2 = render(input_from_dataset(d, keep), o);
  ASSERT_TRUE(img2.ok());
  EXPECT_EQ(img2->at(hand.u(5), hand.v(3)), kWhite);
}

TEST(RenderPixels, FilterModeWithoutMaskUsesDirectionFilteredFlag) {
  auto d = tiny_dataset();
  d.points[2 * 13 + 2].flags = point_flags::kDirectionFiltered;
  d.points[3 * 13 + 2].flags = point_flags::kDazzled;  // another flag: still kept
  const auto o = small(View::top, ColorMode::filter);
  const auto img = render(input_from_dataset(d), o);
  ASSERT_TRUE(img.ok());
  const HandTop hand(o);
  EXPECT_EQ(img->at(hand.u(1), hand.v(1)), kWhite);
  EXPECT_NE(img->at(hand.u(1.5), hand.v(1)), kWhite);
}

TEST(RenderPixels, SideViewPutsTheGhostAboveTheFloorLine) {
  const auto d = tiny_dataset();
  const auto o = small(View::side, ColorMode::class_label);
  const auto img = render(input_from_dataset(d), o);
  ASSERT_TRUE(img.ok());
  // Side view by hand: x across, z up; box z 0..0.3 (the 0.1 m minimum does not apply), centre z 0.15.
  const PlotRect r = plot_rect(o);
  const double cu = (r.x0 + r.x1) / 2.0, cv = (r.y0 + r.y1) / 2.0;
  const double s = 0.96 * std::min((r.x1 - r.x0) / 10.0, (r.y1 - r.y0) / 0.3);
  const auto u = [&](double x) { return static_cast<int>(std::floor(cu + (x - 5) * s)); };
  const auto v = [&](double z) { return static_cast<int>(std::floor(cv - (z - 0.15) * s)); };
  EXPECT_EQ(img->at(u(5), v(0.3)), kBlack);
  EXPECT_NE(img->at(u(2), v(0)), kWhite);   // the floor seen edge-on
  EXPECT_EQ(img->at(u(2), v(0.15)), kWhite);
}

TEST(RenderCamera, PerspectiveSeesTheWholeBoxFromTheNearCorner) {
  const auto d = tiny_dataset();
  auto o = small(View::perspective, ColorMode::class_label);
  const Camera cam = camera_for(input_from_dataset(d), o);
  const PlotRect r = plot_rect(o);
  for (const auto& p : d.points) {
    const auto px = cam.project({p.x, p.y, p.z});
    ASSERT_TRUE(px.visible);
    EXPECT_GE(px.u, r.x0);
    EXPECT_LT(px.u, r.x1);
    EXPECT_GE(px.v, r.y0);
    EXPECT_LT(px.v, r.y1);
  }
  // The camera sits at azimuth -120 deg (the -x, -y side) above the box: (0,0) is nearer than (10,6),
  // and a point higher up appears higher in the picture.
  EXPECT_LT(cam.project({0, 0, 0}).depth, cam.project({10, 6, 0}).depth);
  EXPECT_LT(cam.project({5, 3, 1}).v, cam.project({5, 3, 0}).v);
  const auto img = render(input_from_dataset(d), o);
  ASSERT_TRUE(img.ok());
  const auto g = cam.project({5, 3, 0.3});
  EXPECT_EQ(img->at(static_cast<int>(std::floor(g.u)), static_cast<int>(std::floor(g.v))), kBlack);
}

TEST(RenderPixels, TracksAreDrawnInColourInTheTopView) {
  auto d = tiny_dataset();
  for (int k = 0; k <= 10; ++k) {
    TrajectorySample t;
    t.robot = 1;
    t.pose = {1.0 + 0.8 * k, 4.25, 0};
    d.truth.push_back(t);
  }
  auto o = small(View::top, ColorMode::class_label);
  o.draw_tracks = true;
  const auto img = render(input_from_dataset(d), o);
  ASSERT_TRUE(img.ok());
  const HandTop hand(o);  // the track lies inside the grid's box, so the fit is unchanged
  const Rgb c = img->at(hand.u(3.2), hand.v(4.25));
  EXPECT_FALSE(c.r == c.g && c.g == c.b) << int{c.r} << "," << int{c.g} << "," << int{c.b};
  o.draw_tracks = false;
  const auto plain = render(input_from_dataset(d), o);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->at(hand.u(3.2), hand.v(4.25)), kWhite);
}

TEST(RenderPng, HeaderSizeAndDeterminism) {
  const auto d = tiny_dataset();
  auto o = small(View::perspective, ColorMode::robot);
  o.title = "Lap2 top view: 1 ghost";
  const auto a = render(input_from_dataset(d), o);
  const auto b = render(input_from_dataset(d), o);
  ASSERT_TRUE(a.ok());
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(a->rgb, b->rgb);
  const auto pa = encode_png(*a), pb = encode_png(*b);
  ASSERT_TRUE(pa.ok());
  EXPECT_EQ(*pa, *pb);
  // PNG signature, then the IHDR chunk: length 13, "IHDR", width and height big-endian, depth 8, type 2 (RGB).
  const std::vector<std::uint8_t> head(pa->begin(), pa->begin() + 26);
  const std::vector<std::uint8_t> expect = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A, 0, 0, 0, 13, 'I', 'H', 'D',
                                            'R', 0, 0, 0x01, 0x90, 0, 0, 0x01, 0x2C, 8, 2};
  EXPECT_EQ(head, expect);
}

TEST(RenderText, DrawsInkInsideItsBox) {
  Image img;
  img.width_px = 40;
  img.height_px = 10;
  img.rgb.assign(40 * 10 * 3, 255);
  draw_text(img, 1, 1, "Hi 5", kBlack, 1);
  EXPECT_EQ(text_width_px("Hi 5", 1), 23);
  int ink = 0;
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 40; ++x)
      if (img.at(x, y) == kBlack) {
        ++ink;
        EXPECT_GE(x, 1);
        EXPECT_LT(x, 1 + 23);
        EXPECT_GE(y, 1);
        EXPECT_LT(y, 8);
      }
  EXPECT_GT(ink, 20);
  EXPECT_EQ(img.at(0, 0), kWhite);
  // 'H' has its left column fully inked.
  for (int y = 1; y < 8; ++y) EXPECT_EQ(img.at(1, y), kBlack);
}

TEST(RenderErrors, BadSizeAndMaskLength) {
  const auto d = tiny_dataset();
  auto o = small(View::top, ColorMode::class_label);
  o.width_px = 8;
  EXPECT_FALSE(render(input_from_dataset(d), o).ok());
  o.width_px = 400;
  std::vector<std::uint8_t> keep(3, 1);
  EXPECT_FALSE(render(input_from_dataset(d, keep), o).ok());
  EXPECT_FALSE(view_from_string("front").ok());
  EXPECT_FALSE(color_from_string("rainbow").ok());
  EXPECT_EQ(*view_from_string("perspective"), View::perspective);
  EXPECT_EQ(*color_from_string("filter"), ColorMode::filter);
}

TEST(RenderEmpty, AnEmptyCloudGivesABackgroundPicture) {
  Dataset d;
  const auto img = render(input_from_dataset(d), small(View::perspective, ColorMode::class_label));
  ASSERT_TRUE(img.ok());
  const PlotRect r = plot_rect(small(View::perspective, ColorMode::class_label));
  EXPECT_EQ(img->at((r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2), kWhite);
}

TEST(RenderPcdScene, UsesRobotLabelFlagsAndKeepFields) {
  PcdCloud c;
  c.fields = {"x", "y", "z", "robot", "label", "keep"};
  c.xyz = {1, 2, 3, 4, 5, 6};
  c.columns = {{1, 4}, {2, 5}, {3, 6}, {2, 300}, {5, 9}, {0, 1}};
  const auto s = scene_from_pcd(c);
  ASSERT_EQ(s.points.size(), 2u);
  EXPECT_TRUE(s.has_labels);
  EXPECT_EQ(s.points[0].robot, 2);
  EXPECT_EQ(s.points[0].label, PointClass::robot);
  EXPECT_EQ(s.points[1].robot, 0);                // 300 does not fit a robot id: left 0
  EXPECT_EQ(s.points[1].label, PointClass::none);  // 9 is not a class
  EXPECT_EQ(s.keep, (std::vector<std::uint8_t>{0, 1}));
  PcdCloud plain;
  plain.fields = {"x", "y", "z"};
  plain.xyz = {1, 2, 3};
  plain.columns = {{1}, {2}, {3}};
  const auto p = scene_from_pcd(plain);
  EXPECT_FALSE(p.has_labels);
  EXPECT_TRUE(p.keep.empty());
}

}  // namespace
}  // namespace teamscan::render
