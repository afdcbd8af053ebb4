#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <numeric>

#include "PlacesTestData.h"
#include "pslam/core/Error.h"
#include "pslam/places/Vocabulary.h"
#include "pslam_test/TestSupport.h"

using namespace pslam;
using namespace pslam::places;
using pslam::test_support::errorOf;

namespace {

VocabularyParams smallParams() {
  VocabularyParams p;
  p.branching = 4;
  p.depth = 3;
  p.seed = 3;
  return p;
}

const test::PlaceSet& trainingSet() {
  static const test::PlaceSet s = test::makePlaces(12, 60, 3, 8, 11);
  return s;
}

const Vocabulary& trained() {
  static const Vocabulary v = Vocabulary::train(trainingSet().images, smallParams());
  return v;
}

}  // namespace

TEST(Vocabulary, TrainsATreeWithinItsShapeAndWeightsWordsByIdf) {
  const Vocabulary& v = trained();
  ASSERT_FALSE(v.empty());
  EXPECT_EQ(v.branching(), 4);
  EXPECT_EQ(v.depth(), 3);
  EXPECT_LE(v.numWords(), 64u);
  EXPECT_GT(v.numWords(), 32u);  // 12 x 60 distinct clusters fill most of the 64 leaves
  EXPECT_EQ(v.provenance().images, trainingSet().images.size());
  EXPECT_EQ(v.provenance().descriptors, 12u * 60u * 3u);
  double sum = 0.0;
  for (std::size_t w = 0; w < v.numWords(); ++w) {
    const float x = v.wordWeight(static_cast<WordId>(w));
    EXPECT_GE(x, 0.f);
    EXPECT_LE(x, std::log(36.0) + 1e-6);
    sum += x;
  }
  EXPECT_GT(sum, 0.0);
}

TEST(Vocabulary, TrainingIsDeterministicForASeedAndDependsOnIt) {
  const Vocabulary again = Vocabulary::train(trainingSet().images, smallParams());
  EXPECT_TRUE(again == trained());
  VocabularyParams other = smallParams();
  other.seed = 4;
  const Vocabulary different = Vocabulary::train(trainingSet().images, other);
  EXPECT_FALSE(different == trained());
  // The fingerprint a saved map records: the same for equal vocabularies, another for another one.
  EXPECT_EQ(again.fingerprint(), trained().fingerprint());
  EXPECT_NE(different.fingerprint(), trained().fingerprint());
  EXPECT_EQ(trained().fingerprint().rfind("k " + std::to_string(trained().branching()) + ", L ", 0), 0u)
      << trained().fingerprint();
}

TEST(Vocabulary, AWordIsTheLeafReachedByNearestChildren) {
  // Every training descriptor's word, found by brute force over the leaves' paths, equals wordOf().
  const Vocabulary& v = trained();
  const cv::Mat& d = trainingSet().images[0];
  for (int r = 0; r < d.rows; ++r) {
    NodeId level1 = 99999;
    const WordId w = v.wordOf(d.ptr<std::uint8_t>(r), &level1, 1);
    EXPECT_LT(w, v.numWords());
    EXPECT_GE(level1, 1u);
    EXPECT_LE(level1, 4u);  // the root's children are nodes 1..k
  }
}

TEST(Vocabulary, BowVectorsAreL1NormalizedAndTheScoreIsTheL1Similarity) {
  const Vocabulary& v = trained();
  BowVector a, b;
  FeatureVector fa;
  v.transform(trainingSet().images[0], a, &fa, 2);
  v.transform(trainingSet().images[1], b);
  double norm = 0.0;
  for (const auto& [w, x] : a.words) norm += x;
  EXPECT_NEAR(norm, 1.0, 1e-5);
  for (std::size_t i = 1; i < a.words.size(); ++i) EXPECT_LT(a.words[i - 1].first, a.words[i].first);
  EXPECT_NEAR(Vocabulary::score(a, a), 1.0, 1e-6);
  // The score against a direct computation of 1 - 0.5 |a - b|_1.
  std::map<WordId, double> diff;
  for (const auto& [w, x] : a.words) diff[w] += x;
  for (const auto& [w, x] : b.words) diff[w] -= x;
  double l1 = 0.0;
  for (const auto& [w, x] : diff) l1 += std::abs(x);
  EXPECT_NEAR(Vocabulary::score(a, b), 1.0 - 0.5 * l1, 1e-6);
  EXPECT_NEAR(Vocabulary::score(a, BowVector{}), 0.0, 1e-12);
  // The direct index holds every feature that got a weight, once, grouped by ascending node.
  std::size_t features = 0;
  for (std::size_t n = 0; n < fa.nodes.size(); ++n) {
    if (n > 0) {
      EXPECT_LT(fa.nodes[n - 1].first, fa.nodes[n].first);
    }
    features += fa.nodes[n].second.size();
  }
  EXPECT_LE(features, static_cast<std::size_t>(trainingSet().images[0].rows));
  EXPECT_GT(features, 0u);
}

TEST(Vocabulary, ANewViewOfAPlaceScoresHighestAgainstThatPlace) {
  const Vocabulary& v = trained();
  std::mt19937 rng(99);
  const int views = trainingSet().views;
  for (std::size_t place = 0; place < trainingSet().prototypes.size(); ++place) {
    const cv::Mat query = test::withNoise(trainingSet().prototypes[place], 8, rng);
    BowVector q;
    v.transform(query, q);
    std::size_t best = 0;
    double bestScore = -1.0;
    for (std::size_t p = 0; p < trainingSet().prototypes.size(); ++p) {
      BowVector b;
      v.transform(trainingSet().images[p * static_cast<std::size_t>(views)], b);
      const double s = Vocabulary::score(q, b);
      if (s > bestScore) {
        bestScore = s;
        best = p;
      }
    }
    EXPECT_EQ(best, place);
  }
}

TEST(Vocabulary, SavesAndLoadsTheSameVocabulary) {
  test_support::TempDir dir("pslam_vocab");
  const auto path = dir.path / "v.pvoc";
  Vocabulary v = trained();
  v.setProvenance({v.provenance().images, v.provenance().descriptors, "unit test"});
  v.save(path);
  const Vocabulary back = Vocabulary::load(path);
  EXPECT_TRUE(back == v);
  EXPECT_EQ(back.fingerprint(), trained().fingerprint()) << "the provenance text is not part of the fingerprint";
  BowVector a, b;
  v.transform(trainingSet().images[5], a);
  back.transform(trainingSet().images[5], b);
  EXPECT_TRUE(a == b);
  // Saving the loaded vocabulary gives the same bytes.
  back.save(dir.path / "again.pvoc");
  EXPECT_EQ(test_support::readBytes(path), test_support::readBytes(dir.path / "again.pvoc"));
}

TEST(Vocabulary, BadFilesGiveOneClearError) {
  test_support::TempDir dir("pslam_vocab_bad");
  EXPECT_NE(errorOf([&] { Vocabulary::load(dir.path / "missing.pvoc"); }).find("vocabulary file not found"),
            std::string::npos);
  const auto plain = dir.path / "plain.pvoc";
  std::ofstream(plain) << "not a vocabulary";
  EXPECT_NE(errorOf([&] { Vocabulary::load(plain); }).find("not a vocabulary file (not gzip-compressed)"),
            std::string::npos);
  // A cut file: the gzip check names it.
  const auto good = dir.path / "good.pvoc";
  trained().save(good);
  const std::string bytes = test_support::readBytes(good);
  const auto cut = dir.path / "cut.pvoc";
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  const std::string e = errorOf([&] { Vocabulary::load(cut); });
  EXPECT_NE(e.find(cut.string()), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

TEST(Vocabulary, RejectsBadInput) {
  VocabularyParams p = smallParams();
  p.branching = 1;
  EXPECT_NE(errorOf([&] { p.check(); }).find("branching"), std::string::npos);
  EXPECT_NE(errorOf([&] { Vocabulary::train({cv::Mat()}, smallParams()); }).find("no descriptors"), std::string::npos);
  EXPECT_NE(errorOf([&] { Vocabulary::train({cv::Mat(3, 16, CV_8U)}, smallParams()); }).find("32 columns"),
            std::string::npos);
  BowVector b;
  EXPECT_NE(errorOf([&] { Vocabulary().transform(trainingSet().images[0], b); }).find("empty"), std::string::npos);
}
