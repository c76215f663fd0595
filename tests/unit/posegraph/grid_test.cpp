// The submap grid: a return's Gaussian around it, growth that keeps what was inserted.
#include <gtest/gtest.h>

#include <cmath>

#include "groundstation/posegraph/grid.hpp"

namespace teamscan::posegraph {
namespace {

TEST(Grid, ReturnIsAGaussianAroundIt) {
  Grid g(0.05, 0.05);
  EXPECT_TRUE(g.empty());
  g.insert({{1.0, 2.0}});
  EXPECT_FLOAT_EQ(g.at(20, 40), 1.0f);  // (1.0, 2.0) is cell (20, 40)
  EXPECT_NEAR(g.at(21, 40), std::exp(-0.5), 1e-6);  // one sigma away
  EXPECT_FLOAT_EQ(g.at(30, 40), 0.0f);
  EXPECT_FLOAT_EQ(g.at(-1000, 5), 0.0f);  // outside the box
}

TEST(Grid, GrowsAndKeepsWhatWasInserted) {
  Grid g(0.05, 0.05);
  g.insert({{0.0, 0.0}});
  const CellBox first = g.box();
  g.insert({{-5.0, 7.0}, {9.0, -3.0}});
  EXPECT_FLOAT_EQ(g.at(0, 0), 1.0f);
  EXPECT_FLOAT_EQ(g.at(-100, 140), 1.0f);
  EXPECT_FLOAT_EQ(g.at(180, -60), 1.0f);
  EXPECT_GT(g.box().width, first.width);
  EXPECT_TRUE(g.box().contains(-100 - 8, 140 + 8));  // the empty border
}

}  // namespace
}  // namespace teamscan::posegraph
