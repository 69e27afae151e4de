// OctoMap input (.bt / .ot files and octomap_msgs/Octomap payloads) and the signed distance
// field of an OctoMap over the region the hair can reach.
//
// Every reader here validates the whole input itself (header and node stream: sizes, depth,
// truncation, trailing bytes, finite values) before octomap sees a byte, because octomap's own
// readers recurse without a depth limit and read past the end of truncated input. Nothing here
// throws, prints, or changes an output on failure.
#pragma once

#include <octomap/OcTree.h>

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "wet_curly_hair/core/dense_sdf.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {
namespace io {

/// Largest OctoMap file loadOctreeFile reads, bytes (1 GiB).
constexpr int64_t kMaxOctreeFileBytes = int64_t{1} << 30;
/// Accepted range of an OctoMap resolution, m (outside it the key arithmetic is meaningless).
constexpr double kMinOctreeResolution = 1e-6;
constexpr double kMaxOctreeResolution = 1e6;

/// Loads an OctoMap file: a binary .bt ("# Octomap OcTree binary file") or a full .ot
/// ("# Octomap OcTree file") one; the format is told by the first line, not by the extension.
/// Accepted tree ids: "OcTree" (and the deprecated "1"), and "ColorOcTree" (its colours are
/// dropped). Refused with a message naming the problem: a missing, unreadable, empty or oversized
/// file, an unknown first line, a missing or malformed id / size / res / data header line, a
/// resolution that is not a finite number in [kMinOctreeResolution, kMaxOctreeResolution], any
/// other tree id (named), a tree of 0 nodes, a node stream that is truncated, deeper than 16
/// levels, has non-finite log-odds or trailing bytes, or whose node count differs from `size`.
/// On failure *tree is unchanged.
bool loadOctreeFile(const std::string& path, std::unique_ptr<octomap::OcTree>* tree,
                    std::string* error);

/// The same as loadOctreeFile on the bytes of a file already in memory (for fuzzing and tests).
bool octreeFromFileContents(const std::string& contents, std::unique_ptr<octomap::OcTree>* tree,
                            std::string* error);

/// Tree from the payload of an octomap_msgs/Octomap message: binary = true is the .bt bit stream
/// without its ASCII header (octomap's writeBinaryData), binary = false the .ot node stream
/// without header (writeData). id must be "OcTree" or "ColorOcTree" (others are refused, named);
/// resolution in m as in loadOctreeFile. The stream is validated as in loadOctreeFile (an empty
/// payload is an empty tree and refused) and read into a fresh tree. On failure *tree is
/// unchanged.
bool octreeFromMessagePayload(bool binary, const std::string& id, double resolution,
                              const std::vector<int8_t>& data,
                              std::unique_ptr<octomap::OcTree>* tree, std::string* error);

/// How an OctoMap is turned into a dense field.
struct SdfBuildConfig {
  double resolution_m = 0.005;  ///< voxel edge h of the field, m.
  double margin_m = 0.05;       ///< the reach box is grown by this on every side, m.
  /// Treat space no leaf of the tree covers as occupied (true) or free (false).
  bool unknown_is_occupied = false;
  /// Largest number of voxels of the field; a bigger box is refused (memory is ~9 bytes/voxel
  /// at the peak of the build).
  int64_t max_cells = int64_t{1} << 28;
  /// Checks every field; on failure *why = "<prefix><field>: <reason>".
  bool validate(const std::string& prefix, std::string* why) const;
};

/// What buildSdfFromOctree did.
struct SdfBuildStats {
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  ///< voxels along x, y, z (map frame).
  int64_t cells = 0;                               ///< dims.prod().
  int64_t occupied_cells = 0;                      ///< voxels rasterised as occupied.
  int64_t leaves_used = 0;                         ///< tree leaves that touched the grid.
  double rasterise_s = 0.0;                        ///< wall time of the rasterisation, s.
  double edt_s = 0.0;                              ///< wall time of the distance transforms, s.
  double total_s = 0.0;                            ///< wall time of the whole call, s.
  size_t memory_bytes = 0;                         ///< memory of the resulting field, bytes.
};

/// Signed distance field of an OctoMap over the region the hair can reach.
///
/// tree_in_world: the map frame in the world (x_world = R x_map + t); its quaternion is
/// normalised. reach_box_world: the box (world frame, m) the hair can reach. The box is taken
/// into the map frame, replaced by its axis-aligned bounding box there, grown by cfg.margin_m and
/// snapped outwards to multiples of cfg.resolution_m (so that the voxels line up with the
/// octree's own voxels whenever the two resolutions are in a power-of-two ratio).
///
/// Rasterisation, per voxel of the field: occupied if any occupied leaf (isNodeOccupied) overlaps
/// it with non-zero volume (a leaf coarser than the field fills all its voxels; a finer leaf marks
/// the voxel it lies in); otherwise free if its centre lies in a free leaf; otherwise unknown,
/// which counts as cfg.unknown_is_occupied says. Then buildSignedDistanceField (core/edt.h).
///
/// On success *sdf holds the field in the map frame (origin_m etc. in map coordinates) and
/// *sdf_in_world = tree_in_world (normalised). stats may be null. Refused (false, *error names
/// the problem, outputs unchanged): an invalid cfg, a non-finite pose or zero quaternion, an
/// empty or non-finite box, a tree without nodes, a box no leaf of the tree touches (the map's
/// bounds are named), a grid of more than cfg.max_cells voxels.
bool buildSdfFromOctree(const octomap::OcTree& tree, const Pose& tree_in_world,
                        const Eigen::AlignedBox3d& reach_box_world, const SdfBuildConfig& cfg,
                        DenseSdf* sdf, Pose* sdf_in_world, SdfBuildStats* stats,
                        std::string* error);

}  // namespace io
}  // namespace wet_curly_hair
