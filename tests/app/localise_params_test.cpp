// The follower's --hint parser and the localisation parameter table.

#include "app/localise_params.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace esfleet::app {
namespace {

TEST(ParseHint, ThreeToFiveNumbersDegreesInRadiansOut) {
  const PoseHint h = parse_hint("1.5,-2,90");
  EXPECT_DOUBLE_EQ(h.pose.x, 1.5);
  EXPECT_DOUBLE_EQ(h.pose.y, -2.0);
  EXPECT_NEAR(h.pose.theta, std::numbers::pi / 2, 1e-12);
  EXPECT_DOUBLE_EQ(h.radius, 1.0);  // defaults
  EXPECT_DOUBLE_EQ(h.angle_deg, 30.0);
  const PoseHint g = parse_hint("0,0,270,2.5,45");
  EXPECT_NEAR(g.pose.theta, -std::numbers::pi / 2, 1e-12);  // normalised
  EXPECT_DOUBLE_EQ(g.radius, 2.5);
  EXPECT_DOUBLE_EQ(g.angle_deg, 45.0);
}

TEST(ParseHint, RejectsMalformedTextNamingThePart) {
  for (const std::string bad :
       {"", "1,2", "1,2,3,4,5,6", "1,x,3", "1,2,3m", "1,2,nan", "1,2,3,-1", "1,2,3,1,200"}) {
    try {
      parse_hint(bad);
      FAIL() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("hint"), std::string::npos) << e.what();
    }
  }
}

TEST(LocaliseParams, FlagsReachTheConfigAndBadValuesAreRefusedByValidation) {
  LocaliserConfig c;
  ParamTable t;
  add_localise_params(t, &c);
  CLI::App app;
  t.bind(app);
  const char* argv[] = {"x",  "--localise-search", "es", "--localise-confirm-scans",
                        "6",  "--lost-scans",      "0",  "--localise-coarse-score",
                        "sum"};
  app.parse(9, const_cast<char**>(argv));
  t.apply();
  EXPECT_EQ(c.search.method, GlobalSearchMethod::kEs);
  EXPECT_EQ(c.search.coarse_score, CoarseScore::kSum);
  EXPECT_EQ(c.confirm_scans, 6);
  EXPECT_EQ(c.lost_scans, 0);
  try {
    c.validate();
    FAIL() << "lost_scans 0 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("lost_scans"), std::string::npos) << e.what();
  }
}

TEST(LocaliseParams, ACoarseScoreOutsideTheChoicesIsRefused) {
  LocaliserConfig c;
  ParamTable t;
  add_localise_params(t, &c);
  CLI::App app;
  t.bind(app);
  const char* argv[] = {"x", "--localise-coarse-score", "penalty"};
  app.parse(3, const_cast<char**>(argv));
  try {
    t.apply();
    FAIL() << "coarse score 'penalty' accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("coarse"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("penalty"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace esfleet::app
