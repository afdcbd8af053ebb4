#pragma once
// A small 2-D plotting module drawn with OpenCV (no Python, no gnuplot): line and scatter series on linear
// axes with "nice" ticks, axis labels, title, legend and an optional colour bar for value-coloured scatter
// series. Used by slam-eval for its figures and by other libraries (semantic model, Manhattan tracker) for
// theirs. Saving is atomic (pslam::writeFileAtomically).
//
// Example:
//   pslam::eval::Plot p("ATE over time", "time [s]", "error [m]");
//   p.addLine(t, err, "ATE", pslam::eval::colors::blue());
//   p.save("ate.png");
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace pslam::eval {

/// Colours are BGR as everywhere in OpenCV.
namespace colors {
inline cv::Scalar blue() { return {180, 119, 31}; }    // matplotlib tab:blue
inline cv::Scalar orange() { return {14, 127, 255}; }  // tab:orange
inline cv::Scalar green() { return {44, 160, 44}; }    // tab:green
inline cv::Scalar red() { return {40, 39, 214}; }      // tab:red
inline cv::Scalar purple() { return {189, 103, 148}; } // tab:purple
inline cv::Scalar grey() { return {127, 127, 127}; }
inline cv::Scalar black() { return {0, 0, 0}; }
/// The i-th colour of a fixed cycle (for many series).
cv::Scalar cycle(std::size_t i);
}  // namespace colors

enum class SeriesStyle { Line, Scatter, ColoredScatter };

struct PlotSeries {
  std::string label;           ///< legend text; empty = not in the legend
  std::vector<double> x, y;
  std::vector<double> values;  ///< ColoredScatter only: one value per point, mapped through the colour bar
  SeriesStyle style = SeriesStyle::Line;
  cv::Scalar color = colors::blue();
  int thickness = 2;           ///< line thickness or marker radius, pixels
};

/// Options of the rendered image.
struct PlotStyle {
  int width = 1000;
  int height = 700;
  bool equalAspect = false;  ///< same metres per pixel on both axes (top views of trajectories)
  bool showLegend = true;
  int colormap = 2;          ///< an OpenCV cv::ColormapTypes value (2 = COLORMAP_JET)
};

class Plot {
 public:
  Plot(std::string title, std::string xLabel, std::string yLabel);

  /// Polyline through the points in order. Non-finite points break the line. Throws pslam::Error if the
  /// x and y sizes differ.
  void addLine(std::vector<double> x, std::vector<double> y, std::string label, cv::Scalar color,
               int thickness = 2);
  /// Filled circles of radius `radius` pixels.
  void addScatter(std::vector<double> x, std::vector<double> y, std::string label, cv::Scalar color,
                  int radius = 3);
  /// Circles coloured by `values` through the colour map; adds a colour bar titled `valueLabel`.
  /// The colour range is [min, max] of all coloured values unless setColorRange() was called.
  void addColoredScatter(std::vector<double> x, std::vector<double> y, std::vector<double> values,
                         std::string label, std::string valueLabel, int radius = 3);
  void setColorRange(double vmin, double vmax);
  /// Fixes an axis range instead of fitting the data (e.g. y from 0).
  void setXRange(double lo, double hi);
  void setYRange(double lo, double hi);

  PlotStyle& style() { return style_; }

  /// Renders to a CV_8UC3 image. An empty plot renders empty axes over [0,1]^2.
  cv::Mat render() const;
  /// Renders and writes a PNG atomically. Throws pslam::Error naming the path on failure.
  void save(const std::filesystem::path& pngPath) const;

 private:
  std::string title_, xLabel_, yLabel_, valueLabel_;
  std::vector<PlotSeries> series_;
  PlotStyle style_;
  bool hasColorRange_ = false, hasXRange_ = false, hasYRange_ = false;
  double cmin_ = 0, cmax_ = 1, xlo_ = 0, xhi_ = 1, ylo_ = 0, yhi_ = 1;
};

/// "Nice" tick positions (steps of 1, 2 or 5 times a power of ten) covering [lo, hi] with about
/// `targetCount` ticks. Exposed for tests.
std::vector<double> niceTicks(double lo, double hi, int targetCount = 6);

/// Maps value v in [vmin, vmax] to a BGR colour of an OpenCV colour map (values outside are clamped).
cv::Scalar colormapColor(double v, double vmin, double vmax, int colormap = 2);

/// Encodes `image` as PNG and writes it atomically. Throws pslam::Error naming the path on failure.
void savePngAtomically(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace pslam::eval
