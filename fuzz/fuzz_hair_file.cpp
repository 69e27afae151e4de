// libFuzzer target: io::parseHair on arbitrary bytes.
// Invariants checked (each violation traps):
//  - a refused input sets a non-empty message and leaves the output object as it was;
//  - an accepted input passes validateHairData, has consistent counts (offsets increasing from 0
//    to the point count, >= 1 point per strand, optional arrays sized per point; coordinates may
//    be non-finite: the import skips those strands);
//  - serializeHair(accepted) succeeds and parses back to the same data (bit for bit; the info
//    string compared up to the 87 characters the writer keeps);
//  - importHairAsGroom (file points kept, resampled to 8 particles, and resampled to 1 cm edges)
//    either refuses with a message, leaving the groom unchanged, or gives a groom that passes
//    Groom::validate whose strands plus the skipped ones are the file's strands.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "wet_curly_hair/io/hair_file.h"

using namespace wet_curly_hair;
using namespace wet_curly_hair::io;

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

bool sameFloats(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

bool sameData(const HairFileData& a, const HairFileData& b, bool cut_info) {
  if (a.strand_offsets != b.strand_offsets) return false;
  if (!sameFloats(a.points, b.points) || !sameFloats(a.thickness, b.thickness) ||
      !sameFloats(a.transparency, b.transparency) || !sameFloats(a.colors, b.colors))
    return false;
  if (a.write_segments_array != b.write_segments_array || a.default_segments != b.default_segments)
    return false;
  if (!sameBits(a.default_thickness, b.default_thickness) ||
      !sameBits(a.default_transparency, b.default_transparency))
    return false;
  for (int k = 0; k < 3; ++k)
    if (!sameBits(a.default_color[k], b.default_color[k])) return false;
  if (cut_info) return a.info.substr(0, kHairInfoBytes - 1) == b.info.substr(0, kHairInfoBytes - 1);
  return a.info == b.info;
}

HairFileData sentinel() {
  HairFileData d;
  d.strand_offsets = {0, 2};
  d.points = {1.f, 2.f, 3.f, 4.f, 5.f, 6.f};
  d.info = "sentinel";
  return d;
}

bool sameGroom(const Groom& a, const Groom& b) {
  return a.strand_offsets == b.strand_offsets && a.points == b.points &&
         a.root_normals == b.root_normals;
}

void checkImport(const HairFileData& file, int resample, double resample_edge_m) {
  // Keep the work per input bounded: resampling walks every point several times.
  if (file.pointCount() > 20000) return;
  if (resample_edge_m > 0.0) {
    // Resampled points follow the strands' lengths (up to 65536 a strand): bound their sum.
    double particles = 0.0;
    for (int i = 0; i + 1 < file.pointCount(); ++i) {
      const Vec3 a(file.points[3 * i], file.points[3 * i + 1], file.points[3 * i + 2]);
      const Vec3 b(file.points[3 * i + 3], file.points[3 * i + 4], file.points[3 * i + 5]);
      const double step = 0.01 * (b - a).norm() / resample_edge_m;
      if (std::isfinite(step)) particles += step;  // a non-finite strand is skipped unsampled
    }
    if (!(particles < 2e4)) return;
  }
  HairImportOptions opts;
  opts.scale = 0.01;
  opts.resample_particles = resample;
  opts.resample_edge_m = resample_edge_m;
  Groom groom;
  groom.strand_offsets = {0, 2};
  groom.points = {Vec3(0, 0, 0), Vec3(0, 0, 1)};
  groom.root_normals = {Vec3(0, 0, 1)};
  const Groom before = groom;
  std::string why;
  HairImportReport report;
  if (importHairAsGroom(file, opts, &groom, &why, &report)) {
    std::string inner;
    check(groom.validate(&inner));
    check(groom.strandCount() == report.strands_imported);
    check(report.strands_imported + static_cast<int>(report.skipped.size()) == file.strandCount());
    check(report.skipped.empty() == report.warning().empty());
    if (resample > 0) check(groom.particleCount() == resample * groom.strandCount());
    for (int s = 0; s < groom.strandCount(); ++s) check(groom.strandSize(s) >= 3);
  } else {
    check(!why.empty());
    check(sameGroom(groom, before));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  HairFileData out = sentinel();
  const HairFileData before = out;
  std::string why;
  if (!parseHair(data, size, &out, &why)) {
    check(!why.empty());
    check(sameData(out, before, false));
    return 0;
  }
  // Counts.
  const int strands = out.strandCount();
  const int points = out.pointCount();
  check(strands >= 1);
  check(out.points.size() == 3 * static_cast<size_t>(points));
  check(out.strand_offsets.front() == 0);
  check(out.strand_offsets.back() == static_cast<uint32_t>(points));
  for (int s = 0; s < strands; ++s) check(out.strand_offsets[s + 1] >= out.strand_offsets[s] + 1);
  check(out.thickness.empty() || out.thickness.size() == static_cast<size_t>(points));
  check(out.transparency.empty() || out.transparency.size() == static_cast<size_t>(points));
  check(out.colors.empty() || out.colors.size() == 3 * static_cast<size_t>(points));
  check(out.info.size() <= kHairInfoBytes);
  // The input must have been large enough to hold what was read.
  check(size >= kHairHeaderBytes + 4 * out.points.size());
  std::string inner;
  check(validateHairData(out, &inner));

  // Round trip through the writer.
  std::vector<uint8_t> bytes;
  check(serializeHair(out, &bytes, &inner));
  check(bytes.size() <= size + 2 * static_cast<size_t>(strands));
  HairFileData back = sentinel();
  check(parseHair(bytes.data(), bytes.size(), &back, &inner));
  check(sameData(out, back, true));

  // Import into a groom.
  checkImport(out, 0, 0.0);
  checkImport(out, 8, 0.0);
  checkImport(out, 0, 0.01);
  return 0;
}
