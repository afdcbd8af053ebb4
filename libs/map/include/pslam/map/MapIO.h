#pragma once
// Saving / loading the whole map as a `.slammap` file: one versioned MRPT CSerializable object
// (pslam::map::CSlamMapArchive) in a gz-compressed MRPT archive. Format: doc/map_and_optimization.md.
#include <cstdint>
#include <filesystem>
#include <string>

#include <mrpt/serialization/CSerializable.h>

#include "pslam/map/Map.h"

namespace pslam::map {

/// The serializable wrapper. serializeGetVersion() is the format version; serializeFrom() refuses any
/// other version with a pslam::Error naming both versions.
class CSlamMapArchive : public mrpt::serialization::CSerializable {
  DEFINE_SERIALIZABLE(CSlamMapArchive, pslam::map)
 public:
  /// 1 adds the vocabulary fingerprint (Map::vocabulary) after the points; 2 adds the extensions (Map::extensions:
  /// lines, loop edges, direct points) after it. Versions 0 and 1 are still read.
  static constexpr std::uint8_t kFormatVersion = 2;
  Map map;
  /// Why the last serializeFrom() failed (MRPT replaces the message of exceptions thrown inside it).
  std::string readFailure;
  /// The format version of the last object read (serializeFrom).
  std::uint8_t readVersion = kFormatVersion;

 private:
  void readContent(mrpt::serialization::CArchive& in, std::uint8_t version);
};

/// Writes `map` to `path` atomically (temporary file + rename), gzip-compressed (level 1, in 1 MiB members compressed
/// on two threads: GzipOutputStream). The same map gives the same bytes. Throws pslam::Error naming the
/// path when the map violates its invariants or the file cannot be written.
void saveMap(Map map, const std::filesystem::path& path);

/// Reads a map written by saveMap(). Throws pslam::Error naming the file when it is missing, not a
/// .slammap, truncated, corrupt (the gzip stream is verified to its end: CRC-32 and length), of an unsupported
/// version, or its content is invalid: every count, id, flag and index is checked (flags are 0 or 1, ids below
/// the map's next ids, keypoints within one image size around their keyframe's image, values finite) and the
/// whole map must satisfy the map invariants.
/// `formatVersion` (optional) receives the file's format version.
Map loadMap(const std::filesystem::path& path, std::uint8_t* formatVersion = nullptr);

}  // namespace pslam::map
