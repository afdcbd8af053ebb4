// semantic-model-plot: Figure 3.4 of the thesis reproduced with the keypoint model: inlier ratio over the
// observations of a point with a static / dynamic semantic prior under consistent or inconsistent depth
// measurements, and the Beta posteriors of phi of the dynamic-prior point after several observations.
#include <CLI/CLI.hpp>
#include <cmath>
#include <exception>
#include <iostream>

#include "pslam/eval/Plot.h"
#include "pslam/landmarks/ActivationSimulation.h"

namespace {
double betaPdf(double phi, double a, double b) {
  return std::exp((a - 1) * std::log(phi) + (b - 1) * std::log1p(-phi) + std::lgamma(a + b) - std::lgamma(a) -
                  std::lgamma(b));
}
}  // namespace

int main(int argc, char** argv) {
  using namespace pslam::landmarks;
  namespace colors = pslam::eval::colors;
  CLI::App cli{"Plot the inlier-ratio evolution of the probabilistic keypoint model (thesis Figure 3.4)"};
  std::string out = "semantic_fig34.png", outBeta;
  unsigned seed = 1;
  ActivationScenario base;
  cli.add_option("--out", out, "PNG of the inlier ratio over observations")->capture_default_str();
  cli.add_option("--out-beta", outBeta, "PNG of the Beta posteriors of the dynamic-prior point (optional)");
  using pslam::params::cliCheck;
  cli.add_option("--seed", seed, "seed of the measurement noise")->check(cliCheck<unsigned>())->capture_default_str();
  cli.add_option("--observations", base.observations, "observations per point")
      ->check(cliCheck<int>(pslam::params::inClosed(1, 100000)))
      ->capture_default_str();
  cli.add_option("--alpha", base.alpha, "matching accuracy of every observation")
      ->check(cliCheck<double>(pslam::params::inClosed(0, 1)))
      ->capture_default_str();
  cli.add_option("--tau", base.measurementStd, "measurement std-dev (inverse depth)")
      ->check(cliCheck<double>(pslam::params::greaterThan(0)))
      ->capture_default_str();
  CLI11_PARSE(cli, argc, argv);
  try {
    const KeypointModel model{KeypointModelParams{}};
    struct Run {
      const char* label;
      ClassVector cnn;
      bool consistent;
      cv::Scalar color;
    };
    const Run runs[] = {{"static prior, consistent", {0.9, 0.05, 0.05}, true, colors::green()},
                        {"dynamic prior, consistent", {0.05, 0.9, 0.05}, true, colors::red()},
                        {"no semantics (uniform), consistent", {1.0 / 3, 1.0 / 3, 1.0 / 3}, true, colors::blue()},
                        {"static prior, inconsistent", {0.9, 0.05, 0.05}, false, colors::orange()},
                        {"dynamic prior, inconsistent", {0.05, 0.9, 0.05}, false, colors::purple()}};
    pslam::eval::Plot plot("Inlier ratio of one map point (cf. thesis Fig. 3.4)", "observation", "inlier ratio phi");
    plot.setYRange(0.0, 1.0);
    std::vector<ActivationStep> dynamicSteps;
    for (const Run& r : runs) {
      ActivationScenario sc = base;
      sc.cnn = r.cnn;
      sc.consistent = r.consistent;
      std::mt19937 rng(seed);
      const auto steps = simulateActivation(model, sc, rng);
      if (std::string(r.label) == "dynamic prior, consistent") dynamicSteps = steps;
      std::vector<double> x, y;
      for (const auto& s : steps) x.push_back(s.observation), y.push_back(s.inlierRatio);
      plot.addLine(x, y, r.label, r.color);
      std::cout << r.label << ": active from observation " << firstActiveObservation(steps)
                << ", final phi " << steps.back().inlierRatio << "\n";
    }
    plot.addLine({0.0, double(base.observations)}, {model.params().psiMin, model.params().psiMin},
                 "psi_min (activation)", colors::black(), 1);
    plot.save(out);
    std::cout << "wrote " << out << "\n";
    if (!outBeta.empty()) {
      pslam::eval::Plot beta("Beta posterior of phi, dynamic-prior point, consistent depths", "inlier ratio phi",
                             "density");
      for (std::size_t i = 0; i < dynamicSteps.size(); i += 3) {
        std::vector<double> x, y;
        for (int k = 1; k < 400; ++k) {
          x.push_back(k / 400.0);
          y.push_back(betaPdf(k / 400.0, dynamicSteps[i].a, dynamicSteps[i].b));
        }
        beta.addLine(x, y, "after " + std::to_string(dynamicSteps[i].observation) + " obs.", colors::cycle(i / 3));
      }
      beta.addLine({model.params().psiMin, model.params().psiMin}, {0.0, 8.0}, "psi_min", colors::black(), 1);
      beta.save(outBeta);
      std::cout << "wrote " << outBeta << "\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "semantic-model-plot: error: " << e.what() << "\n";
    return 1;
  }
}
