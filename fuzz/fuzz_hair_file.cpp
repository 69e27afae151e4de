// libFuzzer target: io::parseHair on arbitrary bytes.
// Invariants checked (each violation traps):
//  - a refused input sets a non-empty message and leaves the output object as it was;
//  - an accepted input passes validateHairData, has consistent counts (offsets increasing from 0
//    to the point count, >= 2 points per strand, optional arrays sized per point, finite points);
//  - serializeHair(accepted) succeeds and parses back to the same data (bit for bit; the info
//    string compared up to the 87 characters the writer keeps);
//  - importHairAsGroom (file points kept, and resampled to 8 particles) either refuses with a
//    message, leaving the groom unchanged, or gives a groom that passes Groom::validate.
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
  if (a.write_segments_array != b.write_segments_array ||
      a.default_segments != b.default_segments)
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

void checkImport(const HairFileData& file, int resample) {
  // Keep the work per input bounded: resampling walks every point several times.
  if (file.pointCount() > 20000) return;
  HairImportOptions opts;
  opts.scale = 0.01;
  opts.resample_particles = resample;
  Groom groom;
  groom.strand_offsets = {0, 2};
  groom.points = {Vec3(0, 0, 0), Vec3(0, 0, 1)};
  groom.root_normals = {Vec3(0, 0, 1)};
  const Groom before = groom;
  std::string why;
  if (importHairAsGroom(file, opts, &groom, &why)) {
    std::string inner;
    check(groom.validate(&inner));
    check(groom.strandCount() == file.strandCount());
    if (resample > 0) check(groom.particleCount() == resample * file.strandCount());
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
  for (int s = 0; s < strands; ++s)
    check(out.strand_offsets[s + 1] >= out.strand_offsets[s] + 2);
  check(out.thickness.empty() || out.thickness.size() == static_cast<size_t>(points));
  check(out.transparency.empty() || out.transparency.size() == static_cast<size_t>(points));
  check(out.colors.empty() || out.colors.size() == 3 * static_cast<size_t>(points));
  for (float f : out.points) check(std::isfinite(f));
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
  checkImport(out, 0);
  checkImport(out, 8);
  return 0;
}
