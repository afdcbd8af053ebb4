#include <gtest/gtest.h>

#include "PlacesTestData.h"
#include "pslam/places/KeyFrameDatabase.h"
#include "pslam/places/Vocabulary.h"

using namespace pslam::places;

namespace {

struct Fixture {
  test::PlaceSet places = test::makePlaces(10, 80, 2, 8, 21);
  Vocabulary vocabulary;
  KeyFrameDatabase db;
  Fixture() {
    VocabularyParams p;
    p.branching = 5;
    p.depth = 3;
    vocabulary = Vocabulary::train(places.images, p);
    // Keyframe id = image index.
    for (std::size_t i = 0; i < places.images.size(); ++i) {
      BowVector b;
      vocabulary.transform(places.images[i], b);
      db.add(i, b);
    }
  }
  BowVector query(std::size_t place, std::uint32_t seed) const {
    std::mt19937 rng(seed);
    BowVector q;
    vocabulary.transform(test::withNoise(places.prototypes[place], 8, rng), q);
    return q;
  }
};

}  // namespace

TEST(KeyFrameDatabase, RelocalizationCandidatesStartWithAViewOfTheQueriedPlace) {
  Fixture f;
  for (std::size_t place = 0; place < f.places.prototypes.size(); ++place) {
    const auto cands = f.db.relocalizationCandidates(f.query(place, 100 + static_cast<std::uint32_t>(place)), {});
    ASSERT_FALSE(cands.empty());
    EXPECT_EQ(cands.front().keyFrame / 2, place);  // two views per place
    for (std::size_t i = 1; i < cands.size(); ++i)
      EXPECT_GE(cands[i - 1].accumulatedScore, cands[i].accumulatedScore);
  }
}

TEST(KeyFrameDatabase, CovisibleGroupsAccumulateTheirScores) {
  Fixture f;
  // The two views of a place are covisible: the group's accumulated score is the sum of both, and its best view
  // represents it.
  auto covisible = [](KeyFrameKey kf) { return std::vector<KeyFrameKey>{kf ^ 1u}; };
  const BowVector q = f.query(3, 7);
  const auto cands = f.db.relocalizationCandidates(q, covisible);
  ASSERT_FALSE(cands.empty());
  const double s6 = Vocabulary::score(q, f.db.bow(6)), s7 = Vocabulary::score(q, f.db.bow(7));
  EXPECT_EQ(cands.front().keyFrame, s6 >= s7 ? 6u : 7u);
  EXPECT_NEAR(cands.front().accumulatedScore, s6 + s7, 1e-9);
  EXPECT_NEAR(cands.front().score, std::max(s6, s7), 1e-9);
}

TEST(KeyFrameDatabase, ErasedKeyFramesAreNeverCandidates) {
  Fixture f;
  f.db.erase(4);
  f.db.erase(5);
  EXPECT_FALSE(f.db.contains(4));
  EXPECT_EQ(f.db.size(), f.places.images.size() - 2);
  for (const auto& c : f.db.relocalizationCandidates(f.query(2, 5), {})) {
    EXPECT_NE(c.keyFrame, 4u);
    EXPECT_NE(c.keyFrame, 5u);
  }
  f.db.erase(12345);  // absent: no-op
  f.db.clear();
  EXPECT_TRUE(f.db.relocalizationCandidates(f.query(2, 5), {}).empty());
}

TEST(KeyFrameDatabase, LoopCandidatesLeaveOutTheExcludedAndThoseBelowTheMinimumScore) {
  Fixture f;
  const BowVector q = f.query(4, 31);  // place 4: keyframes 8 and 9
  const auto all = f.db.loopCandidates(q, {}, {}, 0.0);
  ASSERT_FALSE(all.empty());
  EXPECT_EQ(all.front().keyFrame / 2, 4u);
  // Excluding the place's two views: they never come back.
  for (const auto& c : f.db.loopCandidates(q, {}, {8, 9}, 0.0)) {
    EXPECT_NE(c.keyFrame, 8u);
    EXPECT_NE(c.keyFrame, 9u);
  }
  // A minimum score above every score: nothing; at the best score: only keyframes reaching it.
  const double best = std::max(Vocabulary::score(q, f.db.bow(8)), Vocabulary::score(q, f.db.bow(9)));
  EXPECT_TRUE(f.db.loopCandidates(q, {}, {}, best + 1e-6).empty());
  for (const auto& c : f.db.loopCandidates(q, {}, {}, best)) EXPECT_GE(c.score, best);
}
