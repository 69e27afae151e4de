// Cem Yuksel's `.hair` strand format (http://www.cemyuksel.com/research/hairmodels/): reading,
// writing, import into a Groom (scale, up axis, resampling) and export of simulated frames.
//
// File layout (all little-endian):
//   128-byte header:
//     offset  0  char[4]   "HAIR"
//     offset  4  uint32    strand count
//     offset  8  uint32    total point count
//     offset 12  uint32    flags: bit0 segments array, bit1 points array, bit2 thickness array,
//                          bit3 transparency array, bit4 colour array (other bits are ignored)
//     offset 16  uint32    default segment count (used when there is no segments array)
//     offset 20  float     default thickness
//     offset 24  float     default transparency
//     offset 28  float[3]  default colour
//     offset 40  char[88]  info string (NUL-terminated unless it fills all 88 bytes)
//   then, in this order and each only when its flag is set:
//     segments uint16[strands] (segments of a strand = its points - 1), points float[3 * points],
//     thickness float[points], transparency float[points], colour float[3 * points].
// Bytes after the last array are ignored.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {
namespace io {

/// Size of the `.hair` header, bytes.
constexpr size_t kHairHeaderBytes = 128;
/// Size of the info field of the header, bytes (at most kHairInfoBytes - 1 characters are written).
constexpr size_t kHairInfoBytes = 88;
/// Largest point (and strand) count accepted by the reader and the writer: 2^28.
constexpr uint64_t kHairMaxPoints = uint64_t{1} << 28;

/// Header flag bits.
constexpr uint32_t kHairHasSegments = 1u << 0;
constexpr uint32_t kHairHasPoints = 1u << 1;
constexpr uint32_t kHairHasThickness = 1u << 2;
constexpr uint32_t kHairHasTransparency = 1u << 3;
constexpr uint32_t kHairHasColor = 1u << 4;

/// The contents of a `.hair` file, in file units and file axes. Strand s owns points
/// [strand_offsets[s], strand_offsets[s+1]), its root first.
struct HairFileData {
  std::vector<uint32_t> strand_offsets{0};  ///< strands + 1 point offsets, first 0.
  std::vector<float> points;                ///< xyz per point, file units.
  std::vector<float> thickness;             ///< per point (file units), or empty when absent.
  std::vector<float> transparency;          ///< per point in [0, 1] by convention, or empty.
  std::vector<float> colors;                ///< rgb per point in [0, 1] by convention, or empty.
  /// Whether the segments array is written. When false, every strand must have exactly
  /// default_segments + 1 points. Set by parseHair from the file's flags.
  bool write_segments_array = true;
  uint32_t default_segments = 0;             ///< header default segment count.
  float default_thickness = 1.f;             ///< header default thickness, file units.
  float default_transparency = 0.f;          ///< header default transparency.
  float default_color[3] = {1.f, 1.f, 1.f};  ///< header default colour, rgb.
  std::string info;  ///< header info string; at most 87 chars are written, cut at the first NUL.

  /// Number of strands (strand_offsets.size() - 1, or 0 when strand_offsets is empty).
  int strandCount() const;
  /// Number of points (points.size() / 3).
  int pointCount() const;
  /// Header flags that serializeHair writes for this data (points bit always set).
  uint32_t flags() const;
};

/// Checks that `data` can be written: at least one strand, offsets start at 0 and end at the point
/// count, every strand has >= 1 point (and <= 65536 when the segments array is written, or
/// exactly default_segments + 1 when it is not), optional arrays are empty or sized per point and
/// point count <= 2^28. On failure `*error` names the field. Coordinates may be non-finite and a
/// strand may have a single point: the format holds both, real exporters write them, and the
/// reader keeps them so that importHairAsGroom can skip and name such strands (the writer writes
/// what the reader reads).
bool validateHairData(const HairFileData& data, std::string* error);

/// Parses a whole `.hair` file held in memory. Safe for arbitrary bytes (never reads outside
/// [data, data + size), never allocates more than a small multiple of `size`). Refuses a short
/// header, bad magic, a missing points flag, zero strands, counts above 2^28, truncated arrays and
/// segment counts that do not sum to the point count. Strands of one point and non-finite
/// coordinates are data, not structure: they are kept (importHairAsGroom skips those strands).
/// On failure returns false, sets `*error` (if non-null) to a message naming the field and
/// offset, and leaves `*out` unchanged.
bool parseHair(const uint8_t* data, size_t size, HairFileData* out, std::string* error);

/// Reads and parses the file at `path` (see parseHair). Messages are prefixed with the path.
bool readHairFile(const std::string& path, HairFileData* out, std::string* error);

/// Serializes `data` to `.hair` bytes (replacing `*bytes`). Refuses data that validateHairData
/// rejects; then `*bytes` is unchanged. Floats are written bit-for-bit.
bool serializeHair(const HairFileData& data, std::vector<uint8_t>* bytes, std::string* error);

/// Serializes `data` and writes it to `path` (overwriting it).
bool writeHairFile(const std::string& path, const HairFileData& data, std::string* error);

/// The file axis that points up.
enum class UpAxis { kXUp, kYUp, kZUp, kNegXUp, kNegYUp, kNegZUp };

/// Parses "x", "y", "z", "-x", "-y", "-z" (a leading '+' is also accepted). On failure `*out` is
/// unchanged and `*error` quotes the string.
bool parseUpAxis(const std::string& s, UpAxis* out, std::string* error);

/// Name of an up axis as parseUpAxis accepts it ("x", ..., "-z").
std::string upAxisName(UpAxis up);

/// The proper rotation R (det +1, no mirroring) taking file coordinates to REP-103 (x forward,
/// y left, z up): p_rep = R p_file. It maps the file's up axis to +z:
///   z up:  identity                          (x, y, z) -> ( x,  y,  z)
///   y up:  cyclic permutation                (x, y, z) -> ( z,  x,  y)
///          i.e. file +z (the forward axis of y-up glTF/Blender-export/TressFX data) becomes
///          +x forward, file +x becomes +y left, file +y becomes +z up.
///   x up:  cyclic permutation                (x, y, z) -> ( y,  z,  x)
///   -a up: the +a rotation followed by a half turn about x:  (u, v, w) -> (u, -v, -w),
///          e.g. -y up: (x, y, z) -> (z, -x, -y); -z up: (x, y, z) -> (x, -y, -z).
Mat3 upAxisRotation(UpAxis up);

/// How a `.hair` file is brought into the head frame (metres, REP-103).
struct HairImportOptions {
  double scale = 1.0;            ///< metres per file unit (> 0, finite).
  UpAxis up = UpAxis::kZUp;      ///< the file's up axis; output is REP-103 (z up, x forward).
  Vec3 offset_m = Vec3::Zero();  ///< added after scale and axis change (head frame, m).
  /// 0: keep the file's points; else (>= 2) resample each strand to exactly this many particles
  /// at equal chord length along the polyline (first = root, last = tip).
  int resample_particles = 0;
  /// 0: off; else (> 0, finite) resample each strand at equal chords to about this edge length,
  /// m: max(3, round(L / resample_edge_m) + 1) particles for a strand of arc length L (after
  /// scaling), so particles per strand follow its length. Exclusive with resample_particles.
  double resample_edge_m = 0.0;
  /// 0: off; else the shortest mean edge an imported strand keeps, m. A strand shorter than two
  /// such edges is skipped ("shorter than two edges of min_edge_m"); one whose mean edge is below
  /// it is resampled at equal chords to max(3, floor(L / min_edge_m) + 1) particles, unless
  /// resample_particles or resample_edge_m asks for a resampling of its own. Why: parameters are
  /// per length, so a finer strand is the same hair with stiffer edges, and its explicit substep,
  /// which every strand of the groom shares, shrinks with its shortest edge (docs/physics.md
  /// §2.9): a 0.1 mm strand of 32 points would set 1e-7 s for the whole groom. A strand under
  /// 2 mm cannot bend visibly against a bending smoothing length of 48 mm.
  double min_edge_m = 0.0;
  /// Head centre in the output frame, m: root normals are normalize(root - head_center_m) (or the
  /// direction of the strand's first edge when the root is at the head centre).
  Vec3 head_center_m = Vec3::Zero();
  /// Whether each strand is then moved rigidly so that its root lies on `scalp`, its root normal
  /// the scalp's normal there (placeRootsOnScalp): for a groom authored on another head, whose
  /// roots would otherwise lie inside this one or float above it.
  bool roots_on_scalp = false;
  /// The head's ellipsoid in the output frame: the roots go onto it with roots_on_scalp, and the
  /// report counts the roots inside it (HairImportReport::roots_inside) either way.
  EllipsoidShape scalp;
};

/// Shortest distance between two kept consecutive points of an imported strand, m (after
/// scaling): a point closer than this to the previous kept one is a repeat and is dropped. The
/// same bound as Groom::validate's zero-length edge.
constexpr double kHairRepeatPointM = 1e-9;
/// Shortest strand (arc length after scaling and dropping repeats) that is imported, m. Shorter
/// strands are skipped as "near-zero length": 1 um is far below the thickness of any hair
/// (17-180 um), so such a strand is not hair but a stub or noise, and at head-sized coordinates
/// (~0.1-1 m) it spans only ~10-100 float32 ulps of the file, so its shape is rounding noise.
/// A total length (not "every edge below a tolerance") because a finely sampled real strand may
/// have many short edges; its length is what makes it hair.
constexpr double kHairMinStrandLengthM = 1e-6;
/// Depth inside the head's ellipsoid past which an imported root counts as inside it, m: far
/// above the float32 rounding of a root written on the surface (about 1e-8 m at head size), far
/// below a groom authored on another head (millimetres to centimetres).
constexpr double kHairRootInsideM = 1e-4;
/// Fewest points (distinct, after dropping repeats) of an imported strand: with two points a
/// strand has one edge and no bend, so the bending and curl models have nothing to act on.
constexpr int kHairMinStrandPoints = 3;
/// Most particles a strand gets from HairImportOptions::resample_edge_m (a longer strand is
/// skipped with the reason named): the most a `.hair` segments array can hold.
constexpr int kHairMaxResampledPoints = 65536;
/// Most strands named in HairImportReport::warning(); the rest are counted ("and N more").
constexpr int kHairMaxNamedSkips = 5;

/// A strand of the file that importHairAsGroom did not import.
struct SkippedStrand {
  int index = 0;       ///< the strand's index in the file, 0-based.
  std::string reason;  ///< e.g. "2 points", "non-finite point 3", "length 0 m".
};

/// What importHairAsGroom did with the strands of a file.
struct HairImportReport {
  int strands_in_file = 0;
  int strands_imported = 0;
  int repeated_points_dropped = 0;  ///< consecutive repeats removed from the imported strands.
  std::vector<SkippedStrand> skipped;
  /// With HairImportOptions::roots_on_scalp: the strands moved, the longest move and the
  /// particles left inside the scalp's ellipsoid (all 0 without it).
  ScalpPlacement scalp_placement;
  /// The imported roots more than kHairRootInsideM inside HairImportOptions::scalp (none with
  /// roots_on_scalp).
  RootsInside roots_inside;
  /// One warning naming the skipped strands (the first kHairMaxNamedSkips with their reason,
  /// then "and N more"), or "" when none was skipped.
  std::string warning() const;
  /// What roots_on_scalp did, in a sentence ("" when no root moved).
  std::string scalpSummary() const;
  /// A warning when roots lie inside the head, with the option that moves them ("" when none).
  std::string rootsInsideWarning() const;
};

/// Imports `file` as a Groom: p_head = scale * upAxisRotation(up) * p_file + offset_m, then the
/// optional resampling, then with roots_on_scalp each strand moved onto the scalp. A strand that
/// cannot be simulated is skipped and recorded in `*report` (when non-null), never a reason to
/// refuse the groom: fewer than kHairMinStrandPoints points in the file, a non-finite point (in the
/// file or after scaling), an arc length below kHairMinStrandLengthM, fewer than
/// kHairMinStrandPoints distinct points once repeats (points within kHairRepeatPointM of the
/// previous kept one) are dropped, or a resampling that fails. Refuses invalid options, data that
/// validateHairData rejects, and a file none of whose strands can be imported (the message names
/// why); the result passes Groom::validate. On failure `*groom` and `*report` are unchanged.
bool importHairAsGroom(const HairFileData& file, const HairImportOptions& opts, Groom* groom,
                       std::string* error, HairImportReport* report = nullptr);

/// Resamples the polyline `in` (>= 2 points, total length > 0) to exactly `count` (>= 2) points
/// with equal chord (straight-line) distance between consecutive points, walking along the
/// polyline from in.front() and ending exactly at in.back(). The chord c is found by bisection so
/// that count - 1 chord steps land on the tip; each step goes to the first point further along
/// the polyline at distance c. Returns false with `*error` set when the input is degenerate.
bool resampleEqualChord(const Vec3List& in, int count, Vec3List* out, std::string* error);

/// Converts simulated positions (head or world frame, metres, REP-103 z up) to `.hair` data for
/// export: points in metres, z up, a segments array, info "wet_curly_hair: metres, z up
/// (REP-103)". When `saturation` is non-null (one value per particle):
///   - the transparency array holds the saturation value of each particle (as float), so a reader
///     recovers it exactly;
///   - the colour array holds a blue-to-white display colour rgb = (1 - 0.7 s, 1 - 0.4 s, 1) with
///     s clamped to [0, 1], non-finite s taken as 0 (dry = white, saturated = light blue).
/// Header defaults: no thickness array, default thickness 1, default transparency 0, default
/// colour white; default segment count = the common segment count when all strands have the same
/// number of particles, else 0.
/// Bad input (offsets inconsistent with positions, or saturation of the wrong size) gives data
/// with no strands, which serializeHair refuses; use groomPositionsToHairChecked for a message.
HairFileData groomPositionsToHair(const std::vector<uint32_t>& strand_offsets,
                                  const Vec3List& positions_m,
                                  const std::vector<double>* saturation);

/// As groomPositionsToHair, but reports bad input: returns false, sets `*error`, leaves `*out`
/// unchanged.
bool groomPositionsToHairChecked(const std::vector<uint32_t>& strand_offsets,
                                 const Vec3List& positions_m, const std::vector<double>* saturation,
                                 HairFileData* out, std::string* error);

}  // namespace io
}  // namespace wet_curly_hair
