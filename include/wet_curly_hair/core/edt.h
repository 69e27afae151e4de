// Exact Euclidean distance transforms on dense grids and the signed distance field built from an
// occupancy grid (Felzenszwalb & Huttenlocher 2012, "Distance transforms of sampled functions").
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "wet_curly_hair/core/dense_sdf.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Largest number of cells a grid given to the transforms below may have (2^31).
constexpr int64_t kMaxEdtCells = int64_t{1} << 31;
/// Largest number of voxels along one axis (2^24, where float voxel indices stop being exact).
/// Squared distances, kept as floats, are exact integers below 2^24, i.e. on any grid of up to
/// ~2300 voxels along its longest axis; beyond that they are rounded.
constexpr int kMaxEdtAxis = 1 << 24;

/// In-place exact squared Euclidean distance transform of a sampled function, in voxel units:
/// on return grid[p] = min_q (f[q] + |p - q|^2) over all cells q, where f is the input (x
/// fastest, dims.x() * dims.y() * dims.z() entries). Give f = 0 at sites and +infinity elsewhere
/// for the plain squared distance to the nearest site; a cell with no finite input anywhere stays
/// +infinity. Inputs must be >= 0 or +infinity (negative or NaN values are refused); results are
/// exact while inputs plus squared distances stay below 2^24, and merely defined beyond.
///
/// Three separable 1-D lower-envelope passes (x, y, z), O(cells), each parallelised over lines
/// with OpenMP (per-thread scratch allocated once per call); the result does not depend on the
/// number of threads. Returns false and names the problem for dims <= 0, an axis longer than
/// kMaxEdtAxis, a size mismatch, more than kMaxEdtCells cells, or invalid input values; grid is
/// then unchanged.
bool squaredDistanceTransform(std::vector<float>* grid, const Eigen::Vector3i& dims,
                              std::string* error);

/// Signed distance field of an occupancy grid.
///
/// occupied: one entry per voxel, x fastest; nonzero = occupied (1 by convention), 0 = free.
/// dims: voxels along x, y, z. voxel_m: voxel edge h, m. origin_m: centre of voxel (0, 0, 0), m.
///
/// With d_out the distance (m) from a free voxel centre to the nearest occupied voxel centre and
/// d_in that from an occupied centre to the nearest free centre, both exact and restricted to the
/// grid (nothing outside the grid counts as occupied or free), the field is
///   sdf = d_out - h/2 on free voxels,  sdf = -(d_in - h/2) on occupied voxels,
/// so the zero level lies on the voxel faces between the two. Against the surface made of those
/// voxel faces, the error at voxel centres is at most h/2 (0 next to a flat face, (sqrt(3)-1)/2 h
/// off a convex corner); trilinear interpolation between centres stays within h/2 near faces and
/// smooth surfaces but reaches 0.62 h right at a convex voxel corner. The voxelisation adds its
/// own error on top.
///
/// Passes: z straight from the occupancy (a branch-free scan), then exact lower envelopes along
/// y and x; d_in only over the occupied voxels' bounding box, lines that cannot matter skipped.
/// Parallel over lines with OpenMP; the result does not depend on the number of threads.
/// A grid with no occupied voxel gets +D everywhere and one with no free voxel -D, where
/// D = h * |dims| is the diagonal of the grid's box (larger than any distance inside it).
///
/// Refuses (false, *error names the problem, *out unchanged) a null out, a non-positive or
/// non-finite voxel_m, a non-finite origin, dims <= 0, an axis longer than kMaxEdtAxis,
/// occupied.size() != dims.prod() and more than kMaxEdtCells cells. Memory: the field (4
/// bytes/cell) plus a float grid over the bounding box of the occupied voxels grown by one voxel,
/// plus per-thread line scratch.
bool buildSignedDistanceField(const std::vector<uint8_t>& occupied, const Eigen::Vector3i& dims,
                              double voxel_m, const Vec3& origin_m, DenseSdf* out,
                              std::string* error);

}  // namespace wet_curly_hair
