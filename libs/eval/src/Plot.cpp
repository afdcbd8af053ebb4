#include "pslam/eval/Plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"

namespace pslam::eval {

namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
const cv::Scalar kGridColor(225, 225, 225);
const cv::Scalar kAxisColor(40, 40, 40);

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool valid() const { return lo <= hi; }
  double span() const { return hi - lo; }
};

// Widens a degenerate or empty range so that it has a positive span, then pads it by `padFraction`.
Range finalizeRange(Range r, double padFraction) {
  if (!r.valid()) return Range{0.0, 1.0};
  if (r.span() <= 0.0) {
    const double half = r.lo == 0.0 ? 0.5 : std::abs(r.lo) * 0.1;
    return Range{r.lo - half, r.hi + half};
  }
  const double pad = r.span() * padFraction;
  return Range{r.lo - pad, r.hi + pad};
}

std::string formatTick(double v, double step) {
  char buf[64];
  if (std::abs(v) < step * 1e-9) v = 0.0;  // avoid "-0" and 1e-17 from accumulated rounding
  const double mag = std::max(std::abs(v), step);
  if (mag >= 1e5 || step < 1e-4) {
    std::snprintf(buf, sizeof(buf), "%.3g", v);
  } else {
    const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
    std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  }
  return buf;
}

void putTextCentered(cv::Mat& img, const std::string& text, cv::Point center, double scale, int thickness,
                     cv::Scalar color) {
  int baseline = 0;
  const cv::Size sz = cv::getTextSize(text, kFont, scale, thickness, &baseline);
  cv::putText(img, text, cv::Point(center.x - sz.width / 2, center.y + sz.height / 2), kFont, scale, color,
              thickness, cv::LINE_AA);
}

// Draws `text` rotated by 90 degrees (reading bottom to top) centred at `center`.
void putTextVertical(cv::Mat& img, const std::string& text, cv::Point center, double scale, int thickness,
                     cv::Scalar color) {
  if (text.empty()) return;
  int baseline = 0;
  const cv::Size sz = cv::getTextSize(text, kFont, scale, thickness, &baseline);
  cv::Mat horizontal(sz.height + baseline + 4, sz.width + 4, img.type(), cv::Scalar::all(255));
  cv::putText(horizontal, text, cv::Point(2, sz.height + 2), kFont, scale, color, thickness, cv::LINE_AA);
  cv::Mat vertical;
  cv::rotate(horizontal, vertical, cv::ROTATE_90_COUNTERCLOCKWISE);
  cv::Rect roi(center.x - vertical.cols / 2, center.y - vertical.rows / 2, vertical.cols, vertical.rows);
  roi &= cv::Rect(0, 0, img.cols, img.rows);
  if (roi.area() <= 0) return;
  vertical(cv::Rect(roi.x - (center.x - vertical.cols / 2), roi.y - (center.y - vertical.rows / 2), roi.width,
                    roi.height))
      .copyTo(img(roi));
}

}  // namespace

namespace colors {
cv::Scalar cycle(std::size_t i) {
  static const cv::Scalar kCycle[] = {blue(), orange(), green(), red(), purple(), grey()};
  return kCycle[i % (sizeof(kCycle) / sizeof(kCycle[0]))];
}
}  // namespace colors

std::vector<double> niceTicks(double lo, double hi, int targetCount) {
  std::vector<double> ticks;
  if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= lo || targetCount < 1) return ticks;
  const double rough = (hi - lo) / targetCount;
  const double pow10 = std::pow(10.0, std::floor(std::log10(rough)));
  const double fraction = rough / pow10;
  double step = 10.0 * pow10;
  if (fraction <= 1.0)
    step = pow10;
  else if (fraction <= 2.0)
    step = 2.0 * pow10;
  else if (fraction <= 5.0)
    step = 5.0 * pow10;
  const double first = std::ceil(lo / step - 1e-9) * step;
  for (int k = 0;; ++k) {
    const double t = first + k * step;
    if (t > hi + step * 1e-9) break;
    ticks.push_back(t);
  }
  return ticks;
}

cv::Scalar colormapColor(double v, double vmin, double vmax, int colormap) {
  static thread_local int cachedMap = -1;
  static thread_local cv::Mat lut;  // 256x1 BGR
  if (cachedMap != colormap) {
    cv::Mat ramp(256, 1, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<uchar>(i) = static_cast<uchar>(i);
    cv::applyColorMap(ramp, lut, colormap);
    cachedMap = colormap;
  }
  double u = vmax > vmin ? (v - vmin) / (vmax - vmin) : 0.5;
  if (!std::isfinite(u)) u = 0.0;
  const int i = static_cast<int>(std::lround(std::clamp(u, 0.0, 1.0) * 255.0));
  const cv::Vec3b c = lut.at<cv::Vec3b>(i);
  return cv::Scalar(c[0], c[1], c[2]);
}

void savePngAtomically(const std::filesystem::path& path, const cv::Mat& image) {
  if (image.empty()) throw Error(path.string() + ": refusing to write an empty image");
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) throw Error(path.string() + ": PNG encoding failed");
  writeFileAtomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  });
}

Plot::Plot(std::string title, std::string xLabel, std::string yLabel)
    : title_(std::move(title)), xLabel_(std::move(xLabel)), yLabel_(std::move(yLabel)) {}

void Plot::addLine(std::vector<double> x, std::vector<double> y, std::string label, cv::Scalar color,
                   int thickness) {
  if (x.size() != y.size())
    throw Error("Plot '" + title_ + "': series '" + label + "' has " + std::to_string(x.size()) +
                " x values but " + std::to_string(y.size()) + " y values");
  series_.push_back({std::move(label), std::move(x), std::move(y), {}, SeriesStyle::Line, color,
                     std::max(1, thickness)});
}

void Plot::addScatter(std::vector<double> x, std::vector<double> y, std::string label, cv::Scalar color,
                      int radius) {
  if (x.size() != y.size())
    throw Error("Plot '" + title_ + "': series '" + label + "' has " + std::to_string(x.size()) +
                " x values but " + std::to_string(y.size()) + " y values");
  series_.push_back({std::move(label), std::move(x), std::move(y), {}, SeriesStyle::Scatter, color,
                     std::max(1, radius)});
}

void Plot::addColoredScatter(std::vector<double> x, std::vector<double> y, std::vector<double> values,
                             std::string label, std::string valueLabel, int radius) {
  if (x.size() != y.size() || x.size() != values.size())
    throw Error("Plot '" + title_ + "': series '" + label + "' needs as many values as points (" +
                std::to_string(x.size()) + " x, " + std::to_string(y.size()) + " y, " +
                std::to_string(values.size()) + " values)");
  valueLabel_ = std::move(valueLabel);
  series_.push_back({std::move(label), std::move(x), std::move(y), std::move(values),
                     SeriesStyle::ColoredScatter, colors::black(), std::max(1, radius)});
}

void Plot::setColorRange(double vmin, double vmax) {
  if (!(vmax > vmin)) throw Error("Plot '" + title_ + "': colour range needs max > min");
  hasColorRange_ = true;
  cmin_ = vmin;
  cmax_ = vmax;
}

void Plot::setXRange(double lo, double hi) {
  if (!(hi > lo)) throw Error("Plot '" + title_ + "': x range needs hi > lo");
  hasXRange_ = true;
  xlo_ = lo;
  xhi_ = hi;
}

void Plot::setYRange(double lo, double hi) {
  if (!(hi > lo)) throw Error("Plot '" + title_ + "': y range needs hi > lo");
  hasYRange_ = true;
  ylo_ = lo;
  yhi_ = hi;
}

cv::Mat Plot::render() const {
  const int W = std::max(200, style_.width), H = std::max(150, style_.height);
  cv::Mat img(H, W, CV_8UC3, cv::Scalar::all(255));

  // Colour range of the value-coloured series (if any).
  bool hasColored = false;
  Range crange;
  for (const auto& s : series_)
    if (s.style == SeriesStyle::ColoredScatter) {
      hasColored = true;
      for (double v : s.values) crange.add(v);
    }
  double cmin = cmin_, cmax = cmax_;
  if (!hasColorRange_) {
    const Range r = crange.valid() && crange.span() > 0 ? crange : finalizeRange(crange, 0.0);
    cmin = r.lo;
    cmax = r.hi;
  }

  // Plot area: room for the y tick labels and label on the left, the colour bar on the right.
  const int left = 95, right = hasColored ? 140 : 30, top = 55, bottom = 75;
  const cv::Rect area(left, top, W - left - right, H - top - bottom);

  Range xr, yr;
  for (const auto& s : series_) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xr.add(s.x[i]);
      yr.add(s.y[i]);
    }
  }
  xr = hasXRange_ ? Range{xlo_, xhi_} : finalizeRange(xr, 0.04);
  yr = hasYRange_ ? Range{ylo_, yhi_} : finalizeRange(yr, 0.06);
  if (style_.equalAspect) {
    // Same data units per pixel on both axes: widen the tighter axis around its centre.
    const double upp = std::max(xr.span() / area.width, yr.span() / area.height);
    const double xc = 0.5 * (xr.lo + xr.hi), yc = 0.5 * (yr.lo + yr.hi);
    xr = Range{xc - 0.5 * upp * area.width, xc + 0.5 * upp * area.width};
    yr = Range{yc - 0.5 * upp * area.height, yc + 0.5 * upp * area.height};
  }
  const auto toPixel = [&](double x, double y) {
    return cv::Point2d(area.x + (x - xr.lo) / xr.span() * area.width,
                       area.y + area.height - (y - yr.lo) / yr.span() * area.height);
  };
  // Sub-pixel drawing (shift) keeps thin lines smooth.
  constexpr int kShift = 4;
  constexpr double kScale = 1 << kShift;
  const auto fixedPoint = [&](cv::Point2d p) {
    return cv::Point(static_cast<int>(std::lround(p.x * kScale)), static_cast<int>(std::lround(p.y * kScale)));
  };

  // Grid, ticks and tick labels.
  const auto xticks = niceTicks(xr.lo, xr.hi, std::max(3, area.width / 110));
  const auto yticks = niceTicks(yr.lo, yr.hi, std::max(3, area.height / 80));
  const double xstep = xticks.size() > 1 ? xticks[1] - xticks[0] : xr.span();
  const double ystep = yticks.size() > 1 ? yticks[1] - yticks[0] : yr.span();
  for (double t : xticks) {
    const int px = static_cast<int>(std::lround(toPixel(t, yr.lo).x));
    cv::line(img, {px, area.y}, {px, area.y + area.height}, kGridColor, 1);
    cv::line(img, {px, area.y + area.height}, {px, area.y + area.height + 6}, kAxisColor, 1);
    putTextCentered(img, formatTick(t, xstep), {px, area.y + area.height + 20}, 0.45, 1, kAxisColor);
  }
  for (double t : yticks) {
    const int py = static_cast<int>(std::lround(toPixel(xr.lo, t).y));
    cv::line(img, {area.x, py}, {area.x + area.width, py}, kGridColor, 1);
    cv::line(img, {area.x - 6, py}, {area.x, py}, kAxisColor, 1);
    const std::string label = formatTick(t, ystep);
    int baseline = 0;
    const cv::Size sz = cv::getTextSize(label, kFont, 0.45, 1, &baseline);
    cv::putText(img, label, {area.x - 10 - sz.width, py + sz.height / 2}, kFont, 0.45, kAxisColor, 1,
                cv::LINE_AA);
  }

  // Series, clipped to the plot area.
  cv::Mat canvas = img(area);
  const cv::Point2d origin(area.x, area.y);
  for (const auto& s : series_) {
    if (s.style == SeriesStyle::Line) {
      bool havePrev = false;
      cv::Point2d prev;
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
          havePrev = false;
          continue;
        }
        const cv::Point2d p = toPixel(s.x[i], s.y[i]) - origin;
        if (havePrev) {
          cv::Point a = fixedPoint(prev), b = fixedPoint(p);
          if (cv::clipLine(cv::Size(area.width * kScale, area.height * kScale), a, b))
            cv::line(canvas, a, b, s.color, s.thickness, cv::LINE_AA, kShift);
        }
        prev = p;
        havePrev = true;
      }
    } else {
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
        const cv::Point2d p = toPixel(s.x[i], s.y[i]) - origin;
        if (p.x < 0 || p.y < 0 || p.x > area.width || p.y > area.height) continue;
        const cv::Scalar c = s.style == SeriesStyle::ColoredScatter
                                 ? colormapColor(s.values[i], cmin, cmax, style_.colormap)
                                 : s.color;
        cv::circle(canvas, fixedPoint(p), s.thickness * static_cast<int>(kScale), c, cv::FILLED, cv::LINE_AA,
                   kShift);
      }
    }
  }
  cv::rectangle(img, area, kAxisColor, 1);

  // Title and axis labels.
  putTextCentered(img, title_, {W / 2, 25}, 0.65, 2, kAxisColor);
  putTextCentered(img, xLabel_, {area.x + area.width / 2, H - 25}, 0.55, 1, kAxisColor);
  putTextVertical(img, yLabel_, {20, area.y + area.height / 2}, 0.55, 1, kAxisColor);

  // Legend in the top-right corner of the plot area.
  if (style_.showLegend) {
    std::vector<const PlotSeries*> entries;
    int textWidth = 0;
    for (const auto& s : series_)
      if (!s.label.empty()) {
        entries.push_back(&s);
        int baseline = 0;
        textWidth = std::max(textWidth, cv::getTextSize(s.label, kFont, 0.45, 1, &baseline).width);
      }
    if (!entries.empty()) {
      const int rowH = 20, boxW = textWidth + 50, boxH = rowH * static_cast<int>(entries.size()) + 8;
      const cv::Rect box(area.x + area.width - boxW - 8, area.y + 8, boxW, boxH);
      cv::rectangle(img, box, cv::Scalar::all(255), cv::FILLED);
      cv::rectangle(img, box, cv::Scalar::all(160), 1);
      for (std::size_t k = 0; k < entries.size(); ++k) {
        const PlotSeries& s = *entries[k];
        const int cy = box.y + 4 + rowH * static_cast<int>(k) + rowH / 2;
        if (s.style == SeriesStyle::Line) {
          cv::line(img, {box.x + 8, cy}, {box.x + 36, cy}, s.color, s.thickness, cv::LINE_AA);
        } else {
          const cv::Scalar c = s.style == SeriesStyle::ColoredScatter
                                   ? colormapColor(0.5, 0.0, 1.0, style_.colormap)
                                   : s.color;
          cv::circle(img, {box.x + 22, cy}, std::max(3, s.thickness), c, cv::FILLED, cv::LINE_AA);
        }
        cv::putText(img, s.label, {box.x + 44, cy + 5}, kFont, 0.45, kAxisColor, 1, cv::LINE_AA);
      }
    }
  }

  // Colour bar to the right of the plot area.
  if (hasColored) {
    const cv::Rect bar(area.x + area.width + 20, area.y, 22, area.height);
    for (int r = 0; r < bar.height; ++r) {
      const double v = cmax - (cmax - cmin) * r / std::max(1, bar.height - 1);
      cv::line(img, {bar.x, bar.y + r}, {bar.x + bar.width - 1, bar.y + r},
               colormapColor(v, cmin, cmax, style_.colormap), 1);
    }
    cv::rectangle(img, bar, kAxisColor, 1);
    const auto cticks = niceTicks(cmin, cmax, 6);
    const double cstep = cticks.size() > 1 ? cticks[1] - cticks[0] : cmax - cmin;
    for (double t : cticks) {
      const int py = bar.y + static_cast<int>(std::lround((cmax - t) / (cmax - cmin) * (bar.height - 1)));
      cv::line(img, {bar.x + bar.width, py}, {bar.x + bar.width + 5, py}, kAxisColor, 1);
      cv::putText(img, formatTick(t, cstep), {bar.x + bar.width + 8, py + 5}, kFont, 0.42, kAxisColor, 1,
                  cv::LINE_AA);
    }
    putTextVertical(img, valueLabel_, {W - 18, bar.y + bar.height / 2}, 0.5, 1, kAxisColor);
  }
  return img;
}

void Plot::save(const std::filesystem::path& pngPath) const { savePngAtomically(pngPath, render()); }

}  // namespace pslam::eval
