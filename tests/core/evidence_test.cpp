#include "esfleet/core/evidence.hpp"

#include <gtest/gtest.h>

namespace esfleet {
namespace {

TEST(Evidence, ContradictionIsTheShareOfEndPointsOnKnownFreeCells) {
  FitnessValue v;
  EXPECT_EQ(contradiction(v), 0.0f);  // no end points
  v.n_points = 200;
  v.n_known = 150;
  v.n_hit = 120;
  EXPECT_FLOAT_EQ(contradiction(v), 30.0f / 200.0f);
  EXPECT_FLOAT_EQ(evidence(v), 120.0f / 200.0f);
}

}  // namespace
}  // namespace esfleet
