#include <gtest/gtest.h>

#include "TestUtil.h"
#include "pslam/core/Error.h"
#include "pslam/eval/Association.h"

using namespace pslam;
using namespace pslam::eval;

namespace {
Trajectory stamps(std::initializer_list<double> ts) {
  Trajectory t;
  for (double s : ts) {
    StampedPose p;
    p.timestamp = s;
    t.push_back(p);
  }
  return t;
}
}  // namespace

TEST(Association, NearestIsNotOneToOneAndSearchesTheShorterTrajectory) {
  // Ground truth sparser than the estimate: evo searches the GT stamps (shorter) in the estimate.
  const Trajectory gt = stamps({1.0, 2.0});
  const Trajectory est = stamps({0.99, 1.005, 1.5, 2.03});
  AssociationOptions o;  // nearest, 0.01 s (evo's defaults)
  const Association a = associate(gt, est, o);
  ASSERT_EQ(a.size(), 1u);  // 2.0 -> 2.03 is 0.03 s away
  EXPECT_EQ(a.gtIndex[0], 0u);
  EXPECT_EQ(a.estIndex[0], 1u);  // nearest of 0.99 (0.01) and 1.005 (0.005)

  // Estimate shorter: two estimate stamps may take the same GT stamp (no one-to-one constraint).
  const Trajectory gt2 = stamps({1.0, 2.0, 3.0, 4.0, 5.0});
  const Trajectory est2 = stamps({0.995, 1.006, 3.0});
  const Association b = associate(gt2, est2, o);
  ASSERT_EQ(b.size(), 3u);
  EXPECT_EQ(b.gtIndex[0], 0u);
  EXPECT_EQ(b.gtIndex[1], 0u);  // reused
  EXPECT_EQ(b.gtIndex[2], 2u);
  EXPECT_EQ(b.estIndex[1], 1u);
}

TEST(Association, NearestAcceptsEqualToMaxDiffAndPrefersTheFirstOnTies) {
  // Binary fractions keep |dt| exact, so the <= boundary is really tested.
  const Trajectory gt = stamps({1.0, 1.5, 2.0, 2.5});
  const Trajectory est = stamps({1.25, 2.25 + 0.25});
  AssociationOptions o;
  o.maxTimeDifference = 0.25;
  const Association a = associate(gt, est, o);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a.gtIndex[0], 0u);  // 1.25 is 0.25 from 1.0 and 1.5: the first wins (numpy argmin)
  EXPECT_EQ(a.gtIndex[1], 3u);
}

TEST(Association, TumRuleIsOneToOneGreedyAndStrict) {
  const Trajectory gt = stamps({1.0, 2.0, 3.0, 4.0, 5.0});
  const Trajectory est = stamps({0.995, 1.006, 3.0});
  AssociationOptions o;
  o.rule = AssociationRule::OneToOneGreedy;
  const Association a = associate(gt, est, o);
  ASSERT_EQ(a.size(), 2u);  // 1.006 loses GT 1.0 to the closer 0.995
  EXPECT_EQ(a.estIndex[0], 0u);
  EXPECT_EQ(a.gtIndex[1], 2u);
  // Strict < maxDiff for TUM, <= for evo: the same exact 0.25 s difference is refused / accepted.
  o.maxTimeDifference = 0.25;
  EXPECT_THROW(associate(stamps({1.0}), stamps({1.25}), o), pslam::Error);
  o.rule = AssociationRule::Nearest;
  EXPECT_EQ(associate(stamps({1.0}), stamps({1.25}), o).size(), 1u);
}

TEST(Association, TumRuleTieBreaksByStamps) {
  // est 1.5 is 0.5 from both GT 1.0 and 2.0: the candidate with the smaller gt stamp wins; est 2.5 then
  // takes GT 2.0 (0.5) rather than nothing.
  const Trajectory gt = stamps({1.0, 2.0});
  const Trajectory est = stamps({1.5, 2.5});
  AssociationOptions o;
  o.rule = AssociationRule::OneToOneGreedy;
  o.maxTimeDifference = 0.75;
  const Association a = associate(gt, est, o);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a.gtIndex[0], 0u);
  EXPECT_EQ(a.estIndex[0], 0u);
  EXPECT_EQ(a.gtIndex[1], 1u);
  EXPECT_EQ(a.estIndex[1], 1u);
}

TEST(Association, OffsetIsAddedToTheEstimate) {
  AssociationOptions o;
  o.offset = 10.0;
  const Association a = associate(stamps({11.0, 12.0}), stamps({1.0, 2.0, 3.0}), o);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a.estIndex[1], 1u);
  o.rule = AssociationRule::OneToOneGreedy;
  EXPECT_EQ(associate(stamps({11.0, 12.0}), stamps({1.0, 2.0, 3.0}), o).size(), 2u);
}

TEST(Association, ByIndexAndErrors) {
  AssociationOptions o;
  o.rule = AssociationRule::ByIndex;
  EXPECT_EQ(associate(stamps({0, 1, 2}), stamps({5, 6, 7}), o).size(), 3u);
  EXPECT_THROW(associate(stamps({0, 1, 2}), stamps({5, 6}), o), pslam::Error);
  o.rule = AssociationRule::Nearest;
  EXPECT_THROW(associate(stamps({}), stamps({1.0}), o), pslam::Error);
  EXPECT_THROW(associate(stamps({1.0}), stamps({}), o), pslam::Error);
  try {
    associate(stamps({1.0}), stamps({5.0}), o);
    ADD_FAILURE();
  } catch (const pslam::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no matching timestamps"), std::string::npos);
  }
  EXPECT_THROW(parseAssociationRule("closest"), pslam::Error);
  EXPECT_EQ(parseAssociationRule("evo"), AssociationRule::Nearest);
}

TEST(Association, UnsortedTargetGivesTheSameFirstMinimumAsALinearScan) {
  const Trajectory gt = stamps({3.0, 1.0, 2.0, 1.0});  // unsorted with a duplicate
  const Trajectory est = stamps({1.001});
  const Association a = associate(gt, est, AssociationOptions{});
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a.gtIndex[0], 1u);  // first of the two equal 1.0 stamps
}
