#pragma once
// Procedural surface appearance for the synthetic scenes. Every texture is a pure function of a point in the
// surface's own 2-D coordinates (metres), so it sticks to the surface as the camera or the object moves, and
// of a seed, so a sequence is reproducible byte for byte.
//
// Anti-aliasing of the texture itself: octaves of the multi-scale noise whose wavelength is shorter than two
// pixel footprints are faded out (a mip-map in closed form); sharp patterns (mortar, markings, windows) are
// smoothed by the renderer's supersampling.
#include <cstdint>

namespace pslam::synth {

/// Cityscapes trainIds (the 19 evaluation classes), the fine ground-truth labels written per frame.
enum class TrainId : std::uint8_t {
  Road = 0, Sidewalk = 1, Building = 2, Wall = 3, Fence = 4, Pole = 5, TrafficLight = 6, TrafficSign = 7,
  Vegetation = 8, Terrain = 9, Sky = 10, Person = 11, Rider = 12, Car = 13, Truck = 14, Bus = 15, Train = 16,
  Motorcycle = 17, Bicycle = 18, Unlabeled = 255
};

/// Table 3.1 grouping: 0 static, 1 (potentially) dynamic, 2 invalid (sky); unlabeled counts as invalid.
int semanticGroupOfTrainId(std::uint8_t trainId);

enum class TextureKind {
  Uniform,       ///< constant albedo (+ optional faint noise): low-texture structures
  Plaster,       ///< multi-scale value noise
  Bricks,        ///< running-bond bricks with mortar and per-brick tint
  Tiles,         ///< square floor tiles with grout and speckle
  PosterWall,    ///< plaster with randomly placed high-contrast posters
  Facade,        ///< building front: storeys of windows with frames over plaster or bricks
  Road,          ///< asphalt with lane markings and a zebra crossing (see Material::param)
  Sidewalk,      ///< concrete slabs
  CarBody,       ///< paint with door seams, wheels, lights (box faces); param[1] = 1: printed door wrap, sticker
  CarCabin,      ///< glass with pillars
  BusBody,       ///< paint with a band of windows (param[0] = 1) or a printed cargo box; param[1] = 1: livery
                 ///< (advertisement panel under the windows, cargo printed all over, textured rear doors)
  Person,        ///< trousers, shirt, head
  Ceiling,       ///< panels with bright light fittings
  CorridorWall,  ///< plaster with doors, notice boards and a skirting board
  Wood,          ///< anisotropic grain (furniture)
  Foliage,       ///< high-frequency blotchy noise (tree canopies)
  Hedge,         ///< low-contrast vegetation that repeats exactly every param[0] metres along s (similar-looking)
  Highway,       ///< asphalt with light aggregate stones, dashed lane dividers and solid edge lines (param: lane
                 ///< width, lanes, dash length, dash period in metres)
  Guardrail,     ///< galvanized W-beam: two bright ridges, a dark groove, bolts every param[0] metres (repetitive)
};

struct Material {
  TextureKind kind = TextureKind::Plaster;
  std::uint8_t trainId = static_cast<std::uint8_t>(TrainId::Building);
  std::uint32_t seed = 1;
  float albedo = 0.6f;    ///< mean reflectance in [0,1]
  float contrast = 0.2f;  ///< amplitude of the texture around the mean
  /// Kind-specific parameters (documented where the kind is built, e.g. Road: zebra start/end along s).
  float param[4] = {0.f, 0.f, 0.f, 0.f};
};

/// A point on a surface: (s, t) in metres in the surface's own frame (t is "up" on vertical surfaces),
/// the face of a box (0..5 = -x,+x,-y,+y,-z,+z; 0 for planes) with its extent, and the pixel footprint in
/// metres on the surface (for band-limiting).
struct SurfacePoint {
  double s = 0, t = 0;
  int face = 0;
  double sizeS = 1, sizeT = 1;
  double footprint = 0.001;
};

/// Reflectance in [0,1] of `material` at `p`.
float albedoAt(const Material& material, const SurfacePoint& p);

/// Fractal sum of `octaves` value-noise octaves starting at `baseFrequency` cycles/m, centred on 0 (range
/// about [-1,1], std about 0.25); octaves near the Nyquist limit of the footprint fade out, so the mean is kept
/// and nothing aliases.
float fractalNoise(double x, double y, std::uint32_t seed, double baseFrequency, int octaves, double footprint);
/// Smooth 1-D noise in [-1,1] (for exposure drift, handheld jitter), C1 in x.
double smoothNoise1D(double x, std::uint32_t seed);
/// Uniform hash of integers and a seed to [0,1).
float hashUnit(std::int64_t a, std::int64_t b, std::uint32_t seed);

}  // namespace pslam::synth
