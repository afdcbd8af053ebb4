#include "pslam/synth/Texture.h"

#include <algorithm>
#include <cmath>

namespace pslam::synth {

namespace {

inline std::uint32_t mixBits(std::uint32_t h) {
  // Integer finaliser (lowbias32): good avalanche at a few instructions, so lattice values look independent.
  h ^= h >> 16;
  h *= 0x7feb352dU;
  h ^= h >> 15;
  h *= 0x846ca68bU;
  h ^= h >> 16;
  return h;
}

inline float lattice(std::int64_t x, std::int64_t y, std::uint32_t seed) {
  // Odd multipliers decorrelate the axes before one finaliser round (hot path: 4 calls per noise octave).
  const std::uint32_t h = mixBits(static_cast<std::uint32_t>(x) * 0x8da6b343U + static_cast<std::uint32_t>(y) * 0xd8163841U +
                                  seed * 0xcb1ab31fU);
  return static_cast<float>(h) * (1.0f / 4294967296.0f);
}

/// floor() without a libm call (the x86-64 baseline has no SSE4.1 round instruction).
inline double fastFloor(double x) {
  const double t = static_cast<double>(static_cast<std::int64_t>(x));
  return t > x ? t - 1.0 : t;
}

inline float valueNoiseInline(double x, double y, std::uint32_t seed) {
  const double fx = fastFloor(x), fy = fastFloor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  const float u0 = static_cast<float>(x - fx), v0 = static_cast<float>(y - fy);
  const float u = u0 * u0 * (3.0f - 2.0f * u0), v = v0 * v0 * (3.0f - 2.0f * v0);
  const float a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
  const float c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
  const float ab = a + (b - a) * u, cd = c + (d - c) * u;
  return ab + (cd - ab) * v;
}

inline double clamp01(double v) { return v < 0 ? 0 : (v > 1 ? 1 : v); }
inline double smooth(double u) { return u * u * (3.0 - 2.0 * u); }

/// Coverage in [0,1] of the grout/mortar line of width `gap` centred on multiples of `period`, box-filtered
/// over `footprint` (analytic anti-aliasing); `index` receives the cell number. Beyond the Nyquist limit the
/// line is replaced by its mean coverage.
double gridLine(double x, double period, double gap, double footprint, std::int64_t& index) {
  const double q = std::floor(x / period);
  index = static_cast<std::int64_t>(q);
  if (footprint > 0.5 * period) return gap / period;
  const double u = x - q * period;
  const double d = std::min(u, period - u);
  return clamp01((0.5 * gap - d) / std::max(footprint, 1e-6) + 0.5);
}

/// Box-filtered indicator of [a,b] at x.
double interval(double x, double a, double b, double footprint) {
  const double fp = std::max(footprint, 1e-6);
  return clamp01((x - a) / fp + 0.5) * clamp01((b - x) / fp + 0.5);
}

double rectCoverage(const SurfacePoint& p, double s0, double s1, double t0, double t1) {
  return interval(p.s, s0, s1, p.footprint) * interval(p.t, t0, t1, p.footprint);
}

double lerp(double a, double b, double w) { return a + (b - a) * w; }

/// Ink coverage of printed text lines inside a block (posters, notices, plates): rows of "words".
double textInk(double s, double t, double lineHeight, std::uint32_t seed, double footprint) {
  if (footprint > 0.4 * lineHeight) return 0.25;  // unresolved: mean ink
  const double row = std::floor(t / lineHeight);
  const double v = t / lineHeight - row;
  const double wordLen = 2.5 * lineHeight;
  const double word = std::floor(s / wordLen);
  if (hashUnit(static_cast<std::int64_t>(word), static_cast<std::int64_t>(row), seed) < 0.3f) return 0.0;
  const double inRow = interval(v * lineHeight, 0.2 * lineHeight, 0.8 * lineHeight, footprint);
  const double inWord = interval(s - word * wordLen, 0.0, 0.8 * wordLen, footprint);
  return inRow * inWord;
}

/// Printed artwork (advertisements, vehicle wraps): sharp-edged high-contrast blobs of `frequency` cycles/m
/// with text lines of height `line` over the part below `textBelow` (surface t, metres).
double artwork(const SurfacePoint& p, std::uint32_t seed, double frequency, double line, double textBelow) {
  const double blob = 0.5 + 0.5 * std::tanh(7.0 * fractalNoise(p.s, p.t, seed, frequency, 5, p.footprint));
  const double art = lerp(0.1, 0.9, blob);
  if (p.t > textBelow) return art;
  return lerp(art, 0.05, 0.9 * textInk(p.s, p.t, line, seed + 1, p.footprint));
}

float bricks(const Material& m, const SurfacePoint& p) {
  const double L = 0.25, H = 0.075, gap = 0.012;
  std::int64_t row = 0, col = 0;
  const double mortarT = gridLine(p.t, H + gap, gap, p.footprint, row);
  const double offset = (row & 1) ? 0.5 * (L + gap) : 0.0;
  const double mortarS = gridLine(p.s + offset, L + gap, gap, p.footprint, col);
  const double mortar = std::max(mortarT, mortarS);
  const double tint = m.albedo * (0.75 + 0.5 * hashUnit(col, row, m.seed));
  const double brick = tint * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed + 7, 8.0, 4, p.footprint));
  return static_cast<float>(lerp(brick, 0.72, mortar));
}

float facade(const Material& m, const SurfacePoint& p) {
  // param: [0] storey height, [1] window pitch, [2] window width fraction, [3] 1 = bricks, else plaster.
  double base = m.param[3] > 0.5f ? bricks(m, p)
                                  : m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 1.0, 7, p.footprint));
  const double storey = m.param[0] > 0 ? m.param[0] : 3.2;
  const double pitch = m.param[1] > 0 ? m.param[1] : 2.6;
  const double widthFrac = m.param[2] > 0 ? m.param[2] : 0.5;
  if (p.s < 0.6 || p.s > p.sizeS - 0.6 || p.t > p.sizeT - 0.8) return static_cast<float>(base);
  const auto floorIdx = static_cast<std::int64_t>(std::floor(p.t / storey));
  const auto col = static_cast<std::int64_t>(std::floor((p.s - 0.6) / pitch));
  const double cs = 0.6 + (col + 0.5) * pitch;  // window centre along s
  const double ws = 0.5 * widthFrac * pitch * (floorIdx == 0 ? 1.4 : 1.0);
  const double t0 = floorIdx * storey + (floorIdx == 0 ? 0.4 : 0.9);
  const double t1 = floorIdx * storey + storey - 0.5;
  const double frame = rectCoverage(p, cs - ws - 0.08, cs + ws + 0.08, t0 - 0.08, t1 + 0.08);
  if (frame <= 0) return static_cast<float>(base);
  const double glassCov = rectCoverage(p, cs - ws, cs + ws, t0, t1);
  // Glass: dark with a soft sky reflection; some windows lit or with blinds (per-window hash).
  const float h = hashUnit(col, floorIdx, m.seed + 31);
  double glass = 0.10 + 0.12 * (0.5 + 0.5 * fractalNoise(p.s * 0.5, p.t * 0.5, m.seed + 3, 0.6, 3, p.footprint));
  if (h > 0.8f) glass = 0.55;                                         // lit
  else if (h > 0.6f) glass = lerp(glass, 0.6, interval(std::fmod(p.t, 0.08), 0.0, 0.05, p.footprint));  // blinds
  const double mullion = interval(p.s, cs - 0.03, cs + 0.03, p.footprint);
  glass = lerp(glass, 0.8, mullion);
  const double framed = lerp(0.82, glass, glassCov);
  return static_cast<float>(lerp(base, framed, frame));
}

float road(const Material& m, const SurfacePoint& p) {
  // Asphalt; s along the road, t across. Lane lines relative to the centre t = sizeT/2:
  // centre double line, dashed lane dividers at +-3 m, solid parking edges at +-6 m.
  // param: [0],[1] zebra crossing start/end along s, [2] stop line s (ego side, t < centre), [3] unused.
  double a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 0.7, 9, p.footprint));
  const double y = p.t - 0.5 * p.sizeT;
  const double fp = p.footprint;
  double paint = 0;
  paint = std::max(paint, interval(std::abs(y), 0.06, 0.18, fp));  // double centre line
  paint = std::max(paint, interval(std::abs(y), 5.92, 6.08, fp));  // parking edges
  const double dash = interval(std::fmod(std::fmod(p.s, 9.0) + 9.0, 9.0), 0.0, 3.0, fp);
  if (fp < 3.0) paint = std::max(paint, dash * interval(std::abs(y), 2.94, 3.06, fp));
  else paint = std::max(paint, interval(std::abs(y), 2.94, 3.06, fp) / 3.0);
  if (m.param[1] > m.param[0]) {
    const double inZebra = interval(p.s, m.param[0], m.param[1], fp) * interval(std::abs(y), 0.0, 6.0, fp);
    const double band = fp < 0.5 ? interval(std::fmod(y + 100.0, 1.0), 0.0, 0.5, fp) : 0.5;
    paint = std::max(paint, inZebra * band);
  }
  if (m.param[2] > 0) paint = std::max(paint, interval(p.s, m.param[2] - 0.4, m.param[2], fp) * interval(y, -6.0, 0.0, fp));
  if (paint <= 0) return static_cast<float>(a);
  // Worn paint: a noisy reflectance so markings are not perfectly uniform.
  const double wear = 0.8 + 0.15 * fractalNoise(p.s, p.t, m.seed + 5, 3.0, 4, fp);
  return static_cast<float>(lerp(a, wear, paint));
}

float carBody(const Material& m, const SurfacePoint& p) {
  double a = m.albedo * (1.0 + 0.05 * fractalNoise(p.s, p.t, m.seed, 2.0, 3, p.footprint));
  const double fp = p.footprint;
  if (m.param[1] > 0.5f) {  // livery: a printed wrap along the doors, a sticker on the back
    if (p.face == 2 || p.face == 3) {
      const double wrap = rectCoverage(p, 0.12 * p.sizeS, 0.88 * p.sizeS, 0.2 * p.sizeT, 0.9 * p.sizeT);
      if (wrap > 0) a = lerp(a, artwork(p, m.seed + 40, 3.0, 0.08, 0.45 * p.sizeT), 0.85 * wrap);
    } else if (p.face == 0) {
      const double sticker = rectCoverage(p, 0.6 * p.sizeS, 0.85 * p.sizeS, 0.78 * p.sizeT, 0.95 * p.sizeT);
      if (sticker > 0) a = lerp(a, artwork(p, m.seed + 41, 12.0, 0.03, 1e9), sticker);
    }
  }
  if (p.face == 2 || p.face == 3) {  // sides: door seams, sills, wheels
    const double seam = std::max({interval(p.s, 0.42 * p.sizeS - 0.006, 0.42 * p.sizeS + 0.006, fp),
                                  interval(p.s, 0.66 * p.sizeS - 0.006, 0.66 * p.sizeS + 0.006, fp),
                                  interval(p.t, 0.62 * p.sizeT - 0.005, 0.62 * p.sizeT + 0.005, fp)});
    a = lerp(a, 0.05, 0.8 * seam);
    a = lerp(a, 0.08, interval(p.t, 0.0, 0.12, fp));  // dark sill
    for (double cs : {0.75, p.sizeS - 0.75}) {
      const double r = std::hypot(p.s - cs, p.t - 0.18);
      const double tyre = clamp01((0.34 - r) / std::max(fp, 1e-6) + 0.5);
      const double rim = clamp01((0.2 - r) / std::max(fp, 1e-6) + 0.5);
      a = lerp(a, lerp(0.05, 0.55, rim), tyre);
    }
    const double handle = rectCoverage(p, 0.47 * p.sizeS, 0.47 * p.sizeS + 0.15, 0.55 * p.sizeT, 0.58 * p.sizeT);
    a = lerp(a, 0.2, handle);
  } else if (p.face == 0 || p.face == 1) {  // back / front: lamps and number plate
    const bool front = p.face == 1;
    const double lamp = std::max(rectCoverage(p, 0.08, 0.38, 0.5 * p.sizeT, 0.72 * p.sizeT),
                                 rectCoverage(p, p.sizeS - 0.38, p.sizeS - 0.08, 0.5 * p.sizeT, 0.72 * p.sizeT));
    a = lerp(a, front ? 0.9 : 0.3, lamp);
    const double c = 0.5 * p.sizeS;
    const double plate = rectCoverage(p, c - 0.26, c + 0.26, 0.2 * p.sizeT, 0.2 * p.sizeT + 0.11);
    if (plate > 0) {
      const double ink = textInk(p.s - (c - 0.24), p.t - 0.2 * p.sizeT - 0.01, 0.09, m.seed + 11, fp);
      a = lerp(a, lerp(0.85, 0.1, ink), plate);
    }
    a = lerp(a, 0.1, interval(p.t, 0.0, 0.1, fp));  // bumper shadow
  }
  return static_cast<float>(a);
}

float carCabin(const Material& m, const SurfacePoint& p) {
  if (p.face >= 4) return static_cast<float>(m.albedo);  // roof
  const double fp = p.footprint;
  const double glass = 0.12 + 0.15 * (0.5 + 0.5 * fractalNoise(p.s, p.t, m.seed + 9, 0.8, 3, fp));
  double inGlass = rectCoverage(p, 0.1, p.sizeS - 0.1, 0.06, p.sizeT - 0.06);
  if (p.face == 2 || p.face == 3) inGlass *= 1.0 - interval(p.s, 0.5 * p.sizeS - 0.05, 0.5 * p.sizeS + 0.05, fp);  // B pillar
  return static_cast<float>(lerp(m.albedo, glass, inGlass));
}

/// Rear doors of a cargo box (param[1] of BusBody without windows): two doors with a seam, locking bars,
/// hinges, a printed logo block with text, a number plate and tail lamps. `a` is the plain paint.
double cargoRear(const Material& m, const SurfacePoint& p, double a) {
  const double fp = p.footprint, W = p.sizeS, H = p.sizeT;
  const double logo = rectCoverage(p, 0.18 * W, 0.82 * W, 0.5 * H, 0.86 * H);
  if (logo > 0) {
    const double blob = 0.5 + 0.5 * std::tanh(4.0 * fractalNoise(p.s, p.t, m.seed + 21, 1.6, 5, fp));
    const double ink = textInk(p.s - 0.18 * W, p.t - 0.5 * H, 0.16, m.seed + 22, fp);
    const double inLower = p.t < 0.62 * H ? 1.0 : 0.0;
    a = lerp(a, lerp(lerp(0.12, 0.9, blob), 0.05, ink * inLower), logo);
  }
  double dark = interval(p.s, 0.5 * W - 0.012, 0.5 * W + 0.012, fp);  // door seam
  for (double cs : {0.3 * W, 0.42 * W, 0.58 * W, 0.7 * W})            // locking bars
    dark = std::max(dark, interval(p.s, cs - 0.018, cs + 0.018, fp) * interval(p.t, 0.08 * H, 0.95 * H, fp));
  for (double ct : {0.2 * H, 0.5 * H, 0.8 * H})                        // hinges
    for (double cs : {0.03 * W, 0.97 * W}) dark = std::max(dark, rectCoverage(p, cs - 0.04, cs + 0.04, ct - 0.05, ct + 0.05));
  a = lerp(a, 0.08, 0.85 * dark);
  const double c = 0.5 * W;
  const double plate = rectCoverage(p, c - 0.26, c + 0.26, 0.02 * H + 0.05, 0.02 * H + 0.16);
  if (plate > 0) a = lerp(a, lerp(0.85, 0.1, textInk(p.s - (c - 0.24), p.t - 0.02 * H - 0.06, 0.09, m.seed + 23, fp)), plate);
  for (double cs : {0.08 * W, 0.92 * W})  // tail lamps
    a = lerp(a, 0.3, rectCoverage(p, cs - 0.08, cs + 0.08, 0.03 * H, 0.03 * H + 0.22));
  return a;
}

float busBody(const Material& m, const SurfacePoint& p) {
  const double fp = p.footprint;
  double a = m.albedo * (1.0 + 0.05 * fractalNoise(p.s, p.t, m.seed, 1.0, 3, fp));
  if (p.face >= 4) return static_cast<float>(a);
  const bool windows = m.param[0] > 0.5f;
  if (p.face == 2 || p.face == 3) {
    if (windows) {
      double band = rectCoverage(p, 0.3, p.sizeS - 0.3, 0.45 * p.sizeT, 0.88 * p.sizeT);
      if (fp < 0.05) band *= 1.0 - interval(std::fmod(p.s, 1.3), 0.0, 0.1, fp);
      a = lerp(a, 0.12 + 0.12 * (0.5 + 0.5 * fractalNoise(p.s, p.t, m.seed + 1, 0.5, 3, fp)), band);
      if (m.param[1] > 0.5f) {  // livery: an advertisement panel below the windows
        const double panel = rectCoverage(p, 1.9, p.sizeS - 2.3, 0.14 * p.sizeT, 0.4 * p.sizeT);
        if (panel > 0) a = lerp(a, artwork(p, m.seed + 40, 2.0, 0.12, 0.27 * p.sizeT), panel);
      }
    } else if (m.param[1] > 0.5f) {
      // Livery: the whole cargo side printed, sharp artwork with text lines in its lower part.
      const double ad = rectCoverage(p, 0.3, p.sizeS - 0.3, 0.22 * p.sizeT, 0.94 * p.sizeT);
      if (ad > 0) a = lerp(a, artwork(p, m.seed + 2, 1.4, 0.2, 0.5 * p.sizeT), ad);
    } else {
      // Cargo box with a printed advertisement: large high-contrast blobs and text.
      const double ad = rectCoverage(p, 0.8, p.sizeS - 0.8, 0.3 * p.sizeT, 0.9 * p.sizeT);
      if (ad > 0) {
        const double blob = 0.5 + 0.5 * std::tanh(4.0 * fractalNoise(p.s, p.t, m.seed + 2, 0.8, 5, fp));
        const double ink = textInk(p.s, p.t, 0.25, m.seed + 3, fp);
        a = lerp(a, lerp(lerp(0.15, 0.85, blob), 0.05, ink * (p.t < 0.45 * p.sizeT ? 1.0 : 0.0)), ad);
      }
    }
    for (double cs : {1.3, p.sizeS - 1.6}) {
      const double r = std::hypot(p.s - cs, p.t - 0.15);
      a = lerp(a, 0.05, clamp01((0.5 - r) / std::max(fp, 1e-6) + 0.5));
    }
  } else if (windows || p.face == 1) {
    a = lerp(a, 0.15, rectCoverage(p, 0.15, p.sizeS - 0.15, 0.45 * p.sizeT, 0.92 * p.sizeT));
  } else if (m.param[1] > 0.5f && p.face == 0) {
    a = cargoRear(m, p, a);
  }
  return static_cast<float>(a);
}

float person(const Material& m, const SurfacePoint& p) {
  const double h = p.t / std::max(p.sizeT, 1e-6);
  const double fp = p.footprint;
  double a;
  if (h < 0.47) a = m.param[0];
  else if (h < 0.84) a = m.param[1];
  else if (h < 0.93) a = 0.55;
  else a = 0.15;  // hair
  if (h < 0.47 && (p.face == 0 || p.face == 1))  // gap between the legs
    a = lerp(a, 0.25, interval(p.s, 0.45 * p.sizeS, 0.55 * p.sizeS, fp) * interval(h, 0.0, 0.4, fp / p.sizeT));
  return static_cast<float>(a * (1.0 + 0.15 * fractalNoise(p.s, p.t, m.seed, 4.0, 4, fp)));
}

float corridorWall(const Material& m, const SurfacePoint& p) {
  // param: [0] door pitch along s (m).
  const double fp = p.footprint;
  double a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 1.0, 7, fp));
  const double pitch = m.param[0] > 0 ? m.param[0] : 5.0;
  const double cell = std::floor(p.s / pitch);
  const double u = p.s - cell * pitch;
  const auto ci = static_cast<std::int64_t>(cell);
  const double doorAt = 0.4 + (pitch - 2.0) * hashUnit(ci, 0, m.seed + 1);
  const bool hasDoor = hashUnit(ci, 1, m.seed + 1) < 0.7f;
  if (hasDoor) {
    const double frameCov = interval(u, doorAt - 0.06, doorAt + 0.96, fp) * interval(p.t, 0.0, 2.11, fp);
    const double doorCov = interval(u, doorAt, doorAt + 0.9, fp) * interval(p.t, 0.0, 2.05, fp);
    const double wood = 0.35 + 0.1 * hashUnit(ci, 2, m.seed) +
                        0.08 * fractalNoise(u * 0.3, p.t * 6.0, m.seed + ci, 2.0, 5, fp);
    const double handle = rectCoverage(p, cell * pitch + doorAt + 0.75, cell * pitch + doorAt + 0.85, 1.0, 1.04);
    a = lerp(a, 0.85, frameCov);
    a = lerp(a, lerp(wood, 0.8, handle), doorCov);
    // Room number plate beside the door.
    const double plate = interval(u, doorAt + 1.05, doorAt + 1.25, fp) * interval(p.t, 1.5, 1.62, fp);
    if (plate > 0) a = lerp(a, lerp(0.9, 0.1, textInk(u, p.t, 0.04, m.seed + ci, fp)), plate);
  } else {
    // Notice board with papers.
    const double b0 = 0.5, b1 = std::min(pitch - 0.3, 2.0);
    const double board = interval(u, b0, b1, fp) * interval(p.t, 1.0, 1.8, fp);
    if (board > 0) {
      double cork = 0.45 + 0.12 * fractalNoise(u, p.t, m.seed + 5, 20.0, 3, fp);
      for (int k = 0; k < 4; ++k) {
        const double ps = b0 + 0.05 + (b1 - b0 - 0.3) * hashUnit(ci, 10 + k, m.seed);
        const double pt = 1.05 + 0.4 * hashUnit(ci, 20 + k, m.seed);
        const double paper = interval(u, ps, ps + 0.21, fp) * interval(p.t, pt, pt + 0.3, fp);
        if (paper > 0) cork = lerp(cork, lerp(0.92, 0.15, textInk(u - ps, p.t - pt, 0.02, m.seed + k, fp)), paper);
      }
      a = lerp(a, cork, board);
    }
  }
  a = lerp(a, 0.2, interval(p.t, -1.0, 0.1, fp));  // skirting board
  return static_cast<float>(a);
}

float posterWall(const Material& m, const SurfacePoint& p) {
  const double fp = p.footprint;
  double a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 1.0, 8, fp));
  const double cellW = 1.4;
  const auto ci = static_cast<std::int64_t>(std::floor(p.s / cellW));
  if (hashUnit(ci, 0, m.seed + 3) > 0.8f) return static_cast<float>(a);
  const double w = 0.5 + 0.75 * hashUnit(ci, 1, m.seed + 3) * (cellW - 0.5) / 0.9;
  const double h = 0.55 + 0.6 * hashUnit(ci, 2, m.seed + 3);
  const double s0 = ci * cellW + (cellW - w) * hashUnit(ci, 3, m.seed + 3);
  const double t0 = 0.9 + 0.5 * hashUnit(ci, 4, m.seed + 3);
  const double cov = rectCoverage(p, s0, s0 + w, t0, t0 + h);
  if (cov <= 0) return static_cast<float>(a);
  // Poster: a picture of contrasted blobs in the upper part, text lines below, and a light border.
  const std::uint32_t ps = m.seed + 1000u * static_cast<std::uint32_t>(ci);
  const double picture = 0.5 + 0.45 * std::tanh(3.0 * fractalNoise(p.s, p.t, ps, 3.0, 6, fp));
  const double textZone = interval(p.t, t0 + 0.08, t0 + 0.3 * h, fp) * interval(p.s, s0 + 0.05, s0 + w - 0.05, fp);
  double content = lerp(picture, lerp(0.9, 0.1, textInk(p.s - s0, p.t, 0.03, ps + 1, fp)), textZone);
  const double inner = rectCoverage(p, s0 + 0.03, s0 + w - 0.03, t0 + 0.03, t0 + h - 0.03);
  content = lerp(0.92, content, inner);
  return static_cast<float>(lerp(a, content, cov));
}

/// Value noise whose lattice wraps every `period` cells along x: the pattern repeats exactly.
float periodicValueNoise(double x, double y, std::uint32_t seed, std::int64_t period) {
  const double fx = fastFloor(x), fy = fastFloor(y);
  const auto ix = static_cast<std::int64_t>(fx), iy = static_cast<std::int64_t>(fy);
  auto wrap = [period](std::int64_t i) { return ((i % period) + period) % period; };
  const float u0 = static_cast<float>(x - fx), v0 = static_cast<float>(y - fy);
  const float u = u0 * u0 * (3.0f - 2.0f * u0), v = v0 * v0 * (3.0f - 2.0f * v0);
  const float a = lattice(wrap(ix), iy, seed), b = lattice(wrap(ix + 1), iy, seed);
  const float c = lattice(wrap(ix), iy + 1, seed), d = lattice(wrap(ix + 1), iy + 1, seed);
  const float ab = a + (b - a) * u, cd = c + (d - c) * u;
  return ab + (cd - ab) * v;
}

float hedge(const Material& m, const SurfacePoint& p) {
  // param: [0] repeat length along s (m). The fractal noise lives on a lattice that wraps every repeat, so every
  // stretch of param[0] metres looks the same (instanced vegetation): many similar descriptors, few unique ones.
  // Octaves are band-limited by the footprint as in fractalNoise.
  const double P = m.param[0] > 0 ? m.param[0] : 3.0;
  const double u = p.s / P;
  float sum = 0, norm = 0, amp = 1;
  std::int64_t cells = std::max<std::int64_t>(1, std::llround(1.5 * P));  // about 1.5 cycles per metre
  for (int o = 0; o < 6; ++o, amp *= 0.55f, cells *= 2) {
    norm += amp;
    const double f = static_cast<double>(cells) / P;  // cycles per metre
    const double r = f * p.footprint;
    const double w = r < 0.15 ? 1.0 : (r > 0.3 ? 0.0 : (0.3 - r) / 0.15);
    if (w <= 0) continue;
    sum += amp * static_cast<float>(w) *
           (periodicValueNoise(u * cells + 3.7 * o, p.t * f - 9.71 * o, m.seed + 101U * o, cells) - 0.5f);
  }
  const double n = 2.0 * sum / norm;
  // Darker towards the ground (shade under the bushes), no other structure.
  const double base = m.albedo * (1.0 - 0.25 * interval(p.t, -1.0, 0.3, p.footprint));
  return static_cast<float>(base * (1.0 + m.contrast * std::tanh(2.0 * n)));
}

/// Asphalt aggregate: light stones of 2-5 cm and varied brightness scattered over a 0.1 m grid (about one in
/// four cells), blended into `base`; towards the resolution limit they fade into their mean brightening.
double aggregate(double s, double t, std::uint32_t seed, double fp, double base) {
  constexpr double cell = 0.1, density = 0.25, lift = 0.16;
  const double meanCover = density * M_PI * 0.0175 * 0.0175 / (cell * cell) * 0.75;
  if (fp >= 0.03) return base + lift * meanCover;
  const auto ci = static_cast<std::int64_t>(std::floor(s / cell)), cj = static_cast<std::int64_t>(std::floor(t / cell));
  double stone = 0;
  for (std::int64_t di = -1; di <= 1; ++di)
    for (std::int64_t dj = -1; dj <= 1; ++dj) {
      const std::int64_t i = ci + di, j = cj + dj;
      if (hashUnit(i, j, seed) > density) continue;
      const double cs = (i + 0.2 + 0.6 * hashUnit(i, j, seed + 1)) * cell;
      const double ct = (j + 0.2 + 0.6 * hashUnit(i, j, seed + 2)) * cell;
      const double r = 0.01 + 0.015 * hashUnit(i, j, seed + 3);
      const double cover = clamp01((r - std::hypot(s - cs, t - ct)) / std::max(fp, 1e-6) + 0.5);
      stone = std::max(stone, cover * (0.5 + hashUnit(i, j, seed + 4)));
    }
  const double w = fp < 0.015 ? 1.0 : 1.0 - (fp - 0.015) / 0.015;  // fade towards the mean before aliasing
  return base + lift * (w * stone + (1.0 - w) * meanCover);
}

float highway(const Material& m, const SurfacePoint& p) {
  // Carriageway; s along the road, t across from its right edge. param: [0] lane width, [1] number of lanes,
  // [2] dash length, [3] dash period (m). Solid edge lines 0.15 m wide, dashed dividers 0.15 m wide.
  const double fp = p.footprint;
  double a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 0.7, 9, fp));
  a = aggregate(p.s, p.t, m.seed + 9, fp, a);
  const double lane = m.param[0] > 0 ? m.param[0] : 3.5;
  const int lanes = m.param[1] > 0 ? static_cast<int>(m.param[1]) : 2;
  const double dashLen = m.param[2] > 0 ? m.param[2] : 6.0, period = m.param[3] > 0 ? m.param[3] : 18.0;
  double paint = std::max(interval(p.t, 0.1, 0.25, fp), interval(p.t, p.sizeT - 0.25, p.sizeT - 0.1, fp));
  const double along = std::fmod(std::fmod(p.s, period) + period, period);
  const double dash = fp < 0.3 * dashLen ? interval(along, 0.0, dashLen, fp) : dashLen / period;
  for (int k = 1; k < lanes; ++k) paint = std::max(paint, dash * interval(p.t, k * lane - 0.075, k * lane + 0.075, fp));
  if (paint <= 0) return static_cast<float>(a);
  const double wear = 0.78 + 0.08 * fractalNoise(p.s, p.t, m.seed + 5, 3.0, 4, fp);
  return static_cast<float>(lerp(a, wear, paint));
}

float guardrail(const Material& m, const SurfacePoint& p) {
  // W-beam seen from the road: t across the beam height. param: [0] bolt spacing along s (m).
  const double fp = p.footprint, h = std::max(p.sizeT, 1e-3);
  const double v = p.t / h;
  // Profile: bright ridges at 1/4 and 3/4 of the height and a dark groove in the middle.
  const double fpV = fp / h;
  const double ridge = std::max(interval(v, 0.12, 0.38, fpV), interval(v, 0.62, 0.88, fpV));
  const double groove = interval(v, 0.44, 0.56, fpV);
  double a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 2.0, 4, fp));
  a = lerp(a, std::min(1.0, 1.35 * m.albedo), ridge);
  a = lerp(a, 0.45 * m.albedo, groove);
  const double spacing = m.param[0] > 0 ? m.param[0] : 2.0;
  const double along = std::fmod(std::fmod(p.s, spacing) + spacing, spacing);
  if (fp < 0.05) {
    const double bolts = interval(along, 0.0, 0.05, fp) * (interval(v, 0.22, 0.3, fpV) + interval(v, 0.7, 0.78, fpV));
    a = lerp(a, 0.12, std::min(1.0, bolts));
  }
  return static_cast<float>(a);
}

}  // namespace

int semanticGroupOfTrainId(std::uint8_t id) {
  if (id <= 9) return 0;
  if (id == static_cast<std::uint8_t>(TrainId::Sky)) return 2;
  if (id <= 18) return 1;
  return 2;  // unlabeled: no evidence either way; treat as invalid (never used for mapping)
}

float hashUnit(std::int64_t a, std::int64_t b, std::uint32_t seed) {
  return lattice(a * 0x632BE5ABLL + 17, b, seed ^ 0x5bd1e995U);
}

float fractalNoise(double x, double y, std::uint32_t seed, double baseFrequency, int octaves, double footprint) {
  // Normalisation over all octaves (not only the resolved ones) keeps the contrast of the coarse octaves
  // independent of distance; the persistence 0.55 gives a roughly 1/f spectrum like natural surfaces.
  float sum = 0, norm = 0, amp = 1;
  float f = static_cast<float>(baseFrequency);
  const float fp = static_cast<float>(footprint);
  bool active = true;
  for (int o = 0; o < octaves; ++o) {
    norm += amp;
    if (active) {
      // Fade octaves as their nominal frequency nears Nyquist (0.5 cycles per footprint): value noise has
      // energy up to about twice its nominal frequency, so the fade runs over r in [0.15, 0.3].
      const float r = f * fp;
      const float w = r < 0.15f ? 1.0f : (r > 0.3f ? 0.0f : (0.3f - r) * (1.0f / 0.15f));
      if (w <= 0) active = false;
      else sum += amp * w * (valueNoiseInline(x * f + 17.13 * o, y * f - 9.71 * o, seed + 101U * o) - 0.5f);
    }
    amp *= 0.55f;
    f *= 2.0f;
  }
  return 2.0f * sum / norm;
}

double smoothNoise1D(double x, std::uint32_t seed) {
  const double fx = fastFloor(x);
  const auto ix = static_cast<std::int64_t>(fx);
  const double u = smooth(x - fx);
  return 2.0 * lerp(lattice(ix, 7, seed), lattice(ix + 1, 7, seed), u) - 1.0;
}

float albedoAt(const Material& m, const SurfacePoint& p) {
  double a = m.albedo;
  switch (m.kind) {
    case TextureKind::Uniform:
      a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 0.5, 6, p.footprint));
      break;
    case TextureKind::Plaster:
      a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 1.0, 8, p.footprint));
      break;
    case TextureKind::Bricks: a = bricks(m, p); break;
    case TextureKind::Tiles: {
      std::int64_t i = 0, j = 0;
      const double g = std::max(gridLine(p.s, 0.4, 0.006, p.footprint, i), gridLine(p.t, 0.4, 0.006, p.footprint, j));
      const double tile = m.albedo * (0.85 + 0.3 * hashUnit(i, j, m.seed)) *
                          (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed + 1, 3.0, 6, p.footprint));
      a = lerp(tile, 0.3, g);
      break;
    }
    case TextureKind::Sidewalk: {
      std::int64_t i = 0, j = 0;
      const double g = std::max(gridLine(p.s, 0.6, 0.01, p.footprint, i), gridLine(p.t, 0.6, 0.01, p.footprint, j));
      const double slab = m.albedo * (0.9 + 0.2 * hashUnit(i, j, m.seed)) *
                          (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed + 1, 2.0, 7, p.footprint));
      a = lerp(slab, 0.25, g);
      break;
    }
    case TextureKind::PosterWall: a = posterWall(m, p); break;
    case TextureKind::Facade: a = facade(m, p); break;
    case TextureKind::Road: a = road(m, p); break;
    case TextureKind::CarBody: a = carBody(m, p); break;
    case TextureKind::CarCabin: a = carCabin(m, p); break;
    case TextureKind::BusBody: a = busBody(m, p); break;
    case TextureKind::Person: a = person(m, p); break;
    case TextureKind::Ceiling: {
      std::int64_t i = 0, j = 0;
      const double g = std::max(gridLine(p.s, 0.6, 0.015, p.footprint, i), gridLine(p.t, 0.6, 0.015, p.footprint, j));
      double panel = m.albedo * (1.0 + m.contrast * fractalNoise(p.s, p.t, m.seed, 4.0, 5, p.footprint));
      // Every fourth panel along s and every other across holds a light fitting.
      if (((i % 4) + 4) % 4 == 1 && ((j % 2) + 2) % 2 == 0) {
        const double lamp = rectCoverage(p, i * 0.6 + 0.05, i * 0.6 + 0.55, j * 0.6 + 0.05, j * 0.6 + 0.55);
        panel = lerp(panel, 1.0, lamp);
      }
      a = lerp(panel, 0.35, g);
      break;
    }
    case TextureKind::CorridorWall: a = corridorWall(m, p); break;
    case TextureKind::Wood:
      a = m.albedo * (1.0 + m.contrast * fractalNoise(p.s * 0.25, p.t * 8.0, m.seed, 2.0, 6, p.footprint * 8.0));
      break;
    case TextureKind::Foliage:
      a = m.albedo * (1.0 + 0.6 * std::tanh(2.5 * fractalNoise(p.s, p.t, m.seed, 2.0, 6, p.footprint)));
      break;
    case TextureKind::Hedge: a = hedge(m, p); break;
    case TextureKind::Highway: a = highway(m, p); break;
    case TextureKind::Guardrail: a = guardrail(m, p); break;
  }
  return static_cast<float>(clamp01(a));
}

}  // namespace pslam::synth
