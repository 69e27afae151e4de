// Tests of the `.hair` reader/writer, the up-axis rotation, the Groom import and frame export.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/scene.h"

namespace wet_curly_hair {
namespace io {
namespace {

// ------------------------------------------------------------------------------ helpers

/// Optional parts of a small test file.
struct Parts {
  bool segments = true;
  bool thickness = false;
  bool transparency = false;
  bool colors = false;
};

/// Two strands: 3 and 4 points with a segments array, 3 and 3 without (default_segments = 2).
/// Values include -0, a denormal and awkward fractions so that round trips are checked bitwise.
HairFileData makeSmall(const Parts& parts) {
  HairFileData d;
  const uint32_t second = parts.segments ? 4 : 3;
  d.strand_offsets = {0, 3, 3 + second};
  const int n = static_cast<int>(d.strand_offsets.back());
  for (int i = 0; i < n; ++i) {
    d.points.push_back(0.1f * static_cast<float>(i) + 1.f / 3.f);
    d.points.push_back(i == 1 ? -0.f : -2.5f * static_cast<float>(i));
    d.points.push_back(i == 2 ? std::numeric_limits<float>::denorm_min()
                              : 7.f + static_cast<float>(i) / 7.f);
  }
  if (parts.thickness) {
    for (int i = 0; i < n; ++i) d.thickness.push_back(0.01f * static_cast<float>(i + 1) / 3.f);
  }
  if (parts.transparency) {
    for (int i = 0; i < n; ++i) d.transparency.push_back(static_cast<float>(i) / 11.f);
  }
  if (parts.colors) {
    for (int i = 0; i < 3 * n; ++i) d.colors.push_back(static_cast<float>(i % 5) / 9.f);
  }
  d.write_segments_array = parts.segments;
  d.default_segments = parts.segments ? 5 : 2;
  d.default_thickness = 0.125f / 3.f;
  d.default_transparency = 0.3f;
  d.default_color[0] = 0.1f;
  d.default_color[1] = -0.f;
  d.default_color[2] = 1.f / 7.f;
  d.info = "test file, cm, y up";
  return d;
}

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof(float)) == 0; }

/// Bitwise equality of every field.
::testing::AssertionResult identical(const HairFileData& a, const HairFileData& b) {
  if (a.strand_offsets != b.strand_offsets) return ::testing::AssertionFailure() << "offsets";
  if (!sameBits(a.points, b.points)) return ::testing::AssertionFailure() << "points";
  if (!sameBits(a.thickness, b.thickness)) return ::testing::AssertionFailure() << "thickness";
  if (!sameBits(a.transparency, b.transparency)) {
    return ::testing::AssertionFailure() << "transparency";
  }
  if (!sameBits(a.colors, b.colors)) return ::testing::AssertionFailure() << "colors";
  if (a.write_segments_array != b.write_segments_array) {
    return ::testing::AssertionFailure() << "write_segments_array";
  }
  if (a.default_segments != b.default_segments) {
    return ::testing::AssertionFailure() << "default_segments";
  }
  if (!sameBits(a.default_thickness, b.default_thickness)) {
    return ::testing::AssertionFailure() << "default_thickness";
  }
  if (!sameBits(a.default_transparency, b.default_transparency)) {
    return ::testing::AssertionFailure() << "default_transparency";
  }
  for (int k = 0; k < 3; ++k) {
    if (!sameBits(a.default_color[k], b.default_color[k])) {
      return ::testing::AssertionFailure() << "default_color[" << k << "]";
    }
  }
  if (a.info != b.info) {
    return ::testing::AssertionFailure() << "info '" << a.info << "' vs '" << b.info << "'";
  }
  return ::testing::AssertionSuccess();
}

std::vector<uint8_t> serialized(const HairFileData& d) {
  std::vector<uint8_t> bytes;
  std::string error;
  EXPECT_TRUE(serializeHair(d, &bytes, &error)) << error;
  return bytes;
}

void putU32(std::vector<uint8_t>* b, size_t offset, uint32_t v) {
  for (int i = 0; i < 4; ++i) (*b)[offset + i] = static_cast<uint8_t>(v >> (8 * i));
}

void putU16(std::vector<uint8_t>* b, size_t offset, uint16_t v) {
  (*b)[offset] = static_cast<uint8_t>(v);
  (*b)[offset + 1] = static_cast<uint8_t>(v >> 8);
}

void putF32(std::vector<uint8_t>* b, size_t offset, float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, 4);
  putU32(b, offset, bits);
}

uint32_t getU32(const std::vector<uint8_t>& b, size_t offset) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(b[offset + i]) << (8 * i);
  return v;
}

/// A recognisable output that a refused parse must leave as it is.
HairFileData sentinel() {
  Parts p;
  p.thickness = p.colors = true;
  HairFileData d = makeSmall(p);
  d.info = "sentinel";
  return d;
}

/// Expects parseHair to refuse `bytes` with a message containing every one of `needles`, and to
/// leave the output untouched.
void expectRefused(const std::vector<uint8_t>& bytes, const std::vector<std::string>& needles) {
  HairFileData out = sentinel();
  std::string error;
  EXPECT_FALSE(parseHair(bytes.data(), bytes.size(), &out, &error));
  for (const std::string& needle : needles) {
    EXPECT_NE(error.find(needle), std::string::npos)
        << "message '" << error << "' lacks '" << needle << "'";
  }
  EXPECT_TRUE(identical(out, sentinel()));
}

std::string tempPath(const std::string& name) { return ::testing::TempDir() + name; }

std::string sintelPath() { return WCH_SOURCE_DIR "/../shared/data/sintel_lite.hair"; }

bool fileExists(const std::string& path) { return std::ifstream(path).good(); }

std::vector<double> edgeLengths(const Vec3List& p, uint32_t b, uint32_t e) {
  std::vector<double> out;
  for (uint32_t i = b; i + 1 < e; ++i) out.push_back((p[i + 1] - p[i]).norm());
  return out;
}

void expectEqualEdges(const std::vector<double>& edges, double rel) {
  ASSERT_FALSE(edges.empty());
  const double ref = edges.front();
  for (size_t i = 0; i < edges.size(); ++i) {
    EXPECT_NEAR(edges[i], ref, rel * ref) << "edge " << i;
  }
}

// ------------------------------------------------------------------------------ round trips

TEST(HairFileRoundTrip, ExactForEveryCombinationOfOptionalArrays) {
  for (int mask = 0; mask < 16; ++mask) {
    Parts parts;
    parts.segments = (mask & 1) != 0;
    parts.thickness = (mask & 2) != 0;
    parts.transparency = (mask & 4) != 0;
    parts.colors = (mask & 8) != 0;
    SCOPED_TRACE("mask " + std::to_string(mask));
    const HairFileData in = makeSmall(parts);
    const std::vector<uint8_t> bytes = serialized(in);
    const size_t n = in.points.size() / 3;
    const size_t expected_size = kHairHeaderBytes + (parts.segments ? 2 * 2 : 0) + 12 * n +
                                 (parts.thickness ? 4 * n : 0) + (parts.transparency ? 4 * n : 0) +
                                 (parts.colors ? 12 * n : 0);
    EXPECT_EQ(bytes.size(), expected_size);
    EXPECT_EQ(getU32(bytes, 12), in.flags());
    HairFileData out;
    std::string error;
    ASSERT_TRUE(parseHair(bytes.data(), bytes.size(), &out, &error)) << error;
    EXPECT_TRUE(identical(in, out));
    EXPECT_EQ(serialized(out), bytes);
  }
}

TEST(HairFileRoundTrip, ThroughTheFileSystem) {
  Parts parts;
  parts.thickness = parts.transparency = parts.colors = true;
  const HairFileData in = makeSmall(parts);
  const std::string path = tempPath("wch_test_roundtrip.hair");
  std::string error;
  ASSERT_TRUE(writeHairFile(path, in, &error)) << error;
  HairFileData out;
  ASSERT_TRUE(readHairFile(path, &out, &error)) << error;
  EXPECT_TRUE(identical(in, out));
  std::remove(path.c_str());
}

TEST(HairFileRoundTrip, InfoKeepsAtMost87Characters) {
  HairFileData in = makeSmall(Parts());
  in.info = std::string(100, 'a');
  const std::vector<uint8_t> bytes = serialized(in);
  EXPECT_EQ(bytes[40 + 87], 0);
  HairFileData out;
  std::string error;
  ASSERT_TRUE(parseHair(bytes.data(), bytes.size(), &out, &error)) << error;
  EXPECT_EQ(out.info, std::string(87, 'a'));

  // A foreign file may fill all 88 bytes without a NUL: read them all, no further.
  std::vector<uint8_t> full = bytes;
  for (size_t i = 0; i < kHairInfoBytes; ++i) full[40 + i] = 'b';
  ASSERT_TRUE(parseHair(full.data(), full.size(), &out, &error)) << error;
  EXPECT_EQ(out.info, std::string(88, 'b'));
}

TEST(HairFileRoundTrip, TrailingBytesAreIgnored) {
  const HairFileData in = makeSmall(Parts());
  std::vector<uint8_t> bytes = serialized(in);
  bytes.push_back(0xab);
  HairFileData out;
  std::string error;
  ASSERT_TRUE(parseHair(bytes.data(), bytes.size(), &out, &error)) << error;
  EXPECT_TRUE(identical(in, out));
}

// ------------------------------------------------------------------------------ refusals

TEST(HairFileRefusal, ShorterThanHeader) {
  const std::vector<uint8_t> bytes(100, 0);
  expectRefused(bytes, {"header", "100 bytes", "128"});
  HairFileData out = sentinel();
  std::string error;
  EXPECT_FALSE(parseHair(nullptr, 0, &out, &error));
  EXPECT_NE(error.find("header"), std::string::npos) << error;
  EXPECT_TRUE(identical(out, sentinel()));
}

TEST(HairFileRefusal, BadMagic) {
  std::vector<uint8_t> bytes = serialized(makeSmall(Parts()));
  bytes[3] = 'X';
  expectRefused(bytes, {"magic", "offset 0", "HAIR"});
}

TEST(HairFileRefusal, TruncatedArraysNameArrayOffsetAndSize) {
  Parts parts;
  parts.thickness = parts.transparency = parts.colors = true;
  const std::vector<uint8_t> full = serialized(makeSmall(parts));  // 7 points, 2 strands.
  // Offsets: segments 128 (4 bytes), points 132 (84), thickness 216 (28), transparency 244 (28),
  // colours 272 (84), end 356.
  ASSERT_EQ(full.size(), 356u);
  struct Case {
    size_t size;
    std::string message;
  };
  const std::vector<Case> cases = {
      {129, "segments array: needs 4 bytes at offset 128, file has only 129 bytes"},
      {200, "points array: needs 84 bytes at offset 132, file has only 200 bytes"},
      {216, "thickness array: needs 28 bytes at offset 216, file has only 216 bytes"},
      {250, "transparency array: needs 28 bytes at offset 244, file has only 250 bytes"},
      {355, "color array: needs 84 bytes at offset 272, file has only 355 bytes"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    expectRefused(std::vector<uint8_t>(full.begin(), full.begin() + c.size), {c.message});
  }
}

TEST(HairFileRefusal, EveryTruncationOfAValidFile) {
  for (int mask : {0, 1, 15}) {
    Parts parts;
    parts.segments = (mask & 1) != 0;
    parts.thickness = parts.transparency = parts.colors = mask == 15;
    const std::vector<uint8_t> full = serialized(makeSmall(parts));
    for (size_t size = 0; size < full.size(); ++size) {
      // A fresh heap copy of exactly `size` bytes, so a sanitizer sees any over-read.
      std::vector<uint8_t> cut(full.begin(), full.begin() + size);
      HairFileData out = sentinel();
      std::string error;
      EXPECT_FALSE(parseHair(cut.data(), cut.size(), &out, &error)) << "size " << size;
      EXPECT_FALSE(error.empty()) << "size " << size;
      EXPECT_TRUE(identical(out, sentinel())) << "size " << size;
    }
  }
}

TEST(HairFileRefusal, MissingPointsFlag) {
  std::vector<uint8_t> bytes = serialized(makeSmall(Parts()));
  putU32(&bytes, 12, getU32(bytes, 12) & ~kHairHasPoints);
  expectRefused(bytes, {"flags", "offset 12", "points"});
}

TEST(HairFileRefusal, SegmentCountsThatDoNotSumToThePointCount) {
  const std::vector<uint8_t> good = serialized(makeSmall(Parts()));  // segments {2, 3}, 7 points.
  std::vector<uint8_t> too_many = good;
  putU16(&too_many, 130, 4);  // strand 1 would need 5 points: 8 > 7.
  expectRefused(too_many, {"segments array", "strand 1", "8", "7"});
  std::vector<uint8_t> too_few = good;
  putU16(&too_few, 130, 2);  // 3 + 3 = 6 < 7.
  expectRefused(too_few, {"segments array", "strand 1", "6", "7"});

  // Without a segments array the default segment count must match.
  std::vector<uint8_t> no_seg = serialized(makeSmall([] {
    Parts p;
    p.segments = false;
    return p;
  }()));
  putU32(&no_seg, 16, 3);  // 2 x 4 = 8 != 6.
  expectRefused(no_seg, {"default segment count", "8", "6"});
}

TEST(HairFileRefusal, ZeroStrands) {
  std::vector<uint8_t> bytes = serialized(makeSmall(Parts()));
  putU32(&bytes, 4, 0);
  expectRefused(bytes, {"strand count", "offset 4", "0"});
}

// Non-finite coordinates are data the format holds: the reader keeps them bit for bit (and the
// writer writes them back), so that the import can skip and name the strand (HairImportSkips).
TEST(HairFileRoundTrip, NonFiniteCoordinatesAreKept) {
  const std::vector<uint8_t> good = serialized(makeSmall(Parts()));
  std::vector<uint8_t> bytes = good;
  putF32(&bytes, 132 + 12 * 4 + 4, std::numeric_limits<float>::quiet_NaN());  // point 4, y.
  putF32(&bytes, 132, -std::numeric_limits<float>::infinity());               // point 0, x.
  HairFileData out;
  std::string error;
  ASSERT_TRUE(parseHair(bytes.data(), bytes.size(), &out, &error)) << error;
  EXPECT_TRUE(std::isnan(out.points[3 * 4 + 1]));
  EXPECT_EQ(out.points[0], -std::numeric_limits<float>::infinity());
  EXPECT_EQ(serialized(out), bytes);
}

TEST(HairFileRefusal, AbsurdCountsBeforeAllocating) {
  const std::vector<uint8_t> good = serialized(makeSmall(Parts()));
  std::vector<uint8_t> bytes = good;
  putU32(&bytes, 8, (1u << 28) + 1);
  expectRefused(bytes, {"point count", "offset 8", "268435457", "limit"});
  putU32(&bytes, 8, 0xffffffffu);
  expectRefused(bytes, {"point count", "4294967295"});
  bytes = good;
  putU32(&bytes, 4, 0xffffffffu);
  expectRefused(bytes, {"strand count", "4294967295"});
  // Exactly at the limit the counts pass, and the missing bytes are reported instead.
  bytes = good;
  putU32(&bytes, 4, 1);
  putU32(&bytes, 8, 1u << 28);
  putU16(&bytes, 128, 0xffff);
  expectRefused(bytes, {"strand 0", "65536", "268435456"});
  bytes = good;
  putU32(&bytes, 12, kHairHasPoints);
  putU32(&bytes, 4, 1u << 20);
  putU32(&bytes, 8, 1u << 28);
  putU32(&bytes, 16, 255);
  expectRefused(bytes, {"points array: needs 3221225472 bytes at offset 128"});
}

// A strand of one point (0 segments) is data too: kept by the reader, skipped by the import.
TEST(HairFileRoundTrip, OnePointStrandsAreKept) {
  HairFileData in = makeSmall(Parts());  // strands of 3 and 4 points.
  in.strand_offsets = {0, 1, 3, 7};      // now 1, 2 and 4 points.
  const std::vector<uint8_t> bytes = serialized(in);
  HairFileData out;
  std::string error;
  ASSERT_TRUE(parseHair(bytes.data(), bytes.size(), &out, &error)) << error;
  EXPECT_TRUE(identical(in, out));

  // Without a segments array, a default segment count of 0 makes every strand one point.
  Parts parts;
  parts.segments = false;
  std::vector<uint8_t> single = serialized(makeSmall(parts));  // 6 points.
  putU32(&single, 16, 0);
  putU32(&single, 4, 6);  // 6 strands x 1 point.
  ASSERT_TRUE(parseHair(single.data(), single.size(), &out, &error)) << error;
  EXPECT_EQ(out.strand_offsets, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 6}));
  // ... and the points array must exist before the offsets are allocated.
  putU32(&single, 4, 1u << 28);
  putU32(&single, 8, 1u << 28);
  expectRefused(single, {"points array: needs 3221225472 bytes at offset 128"});
}

TEST(HairFileRefusal, RandomMutationsNeverCrash) {
  Parts parts;
  parts.thickness = parts.colors = true;
  const std::vector<uint8_t> good = serialized(makeSmall(parts));
  std::mt19937 rng(12345);
  int accepted = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<uint8_t> bytes = good;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) {
      bytes[rng() % bytes.size()] = static_cast<uint8_t>(rng());
    }
    bytes.resize(rng() % (bytes.size() + 8));
    HairFileData out = sentinel();
    std::string error;
    if (parseHair(bytes.data(), bytes.size(), &out, &error)) {
      ++accepted;
      std::vector<uint8_t> again;
      EXPECT_TRUE(serializeHair(out, &again, &error)) << error;
    } else {
      EXPECT_FALSE(error.empty());
      EXPECT_TRUE(identical(out, sentinel()));
    }
  }
  RecordProperty("accepted_mutations", accepted);
}

TEST(HairFileRefusal, SerializeRefusesInconsistentData) {
  struct Case {
    std::string name;
    HairFileData data;
    std::string needle;
  };
  std::vector<Case> cases;
  {
    HairFileData d;  // no strands.
    cases.push_back({"zero strands", d, "zero strands"});
  }
  {
    HairFileData d = makeSmall(Parts());
    d.strand_offsets.back() = 6;
    cases.push_back({"offsets end early", d, "7 points"});
  }
  {
    HairFileData d = makeSmall(Parts());
    d.strand_offsets = {0, 3, 3, 7};
    cases.push_back({"zero-point strand", d, "strand 1 has 0 points"});
  }
  {
    HairFileData d = makeSmall(Parts());
    d.thickness.assign(3, 1.f);
    cases.push_back({"thickness size", d, "thickness has 3 values"});
  }
  {
    HairFileData d = makeSmall(Parts());
    d.colors.assign(7, 1.f);
    cases.push_back({"colors size", d, "colors has 7 values"});
  }
  {
    HairFileData d = makeSmall(Parts());
    d.write_segments_array = false;
    d.default_segments = 2;
    cases.push_back({"non-uniform strands without segments array", d, "strand 1 has 3 segments"});
  }
  {
    HairFileData d = makeSmall(Parts());
    d.points.push_back(1.f);
    cases.push_back({"points not xyz", d, "not a multiple of 3"});
  }
  {
    HairFileData d;
    d.strand_offsets = {0, 65537};
    d.points.assign(3 * 65537, 0.f);
    cases.push_back({"too many segments for uint16", d, "strand 0 has 65536 segments"});
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    std::vector<uint8_t> bytes = {1, 2, 3};
    std::string error;
    EXPECT_FALSE(serializeHair(c.data, &bytes, &error));
    EXPECT_NE(error.find(c.needle), std::string::npos) << error;
    EXPECT_EQ(bytes, (std::vector<uint8_t>{1, 2, 3}));
  }
}

TEST(HairFileRefusal, ReadMissingFileNamesThePath) {
  HairFileData out = sentinel();
  std::string error;
  EXPECT_FALSE(readHairFile("/nonexistent/dir/x.hair", &out, &error));
  EXPECT_NE(error.find("/nonexistent/dir/x.hair"), std::string::npos) << error;
  EXPECT_TRUE(identical(out, sentinel()));
}

// ------------------------------------------------------------------------------ up axis

TEST(HairUpAxis, ParseAcceptsTheSixAxesAndRefusesOthers) {
  const std::vector<std::pair<std::string, UpAxis>> good = {
      {"x", UpAxis::kXUp},     {"y", UpAxis::kYUp},     {"z", UpAxis::kZUp},
      {"-x", UpAxis::kNegXUp}, {"-y", UpAxis::kNegYUp}, {"-z", UpAxis::kNegZUp},
      {"+y", UpAxis::kYUp}};
  for (const auto& g : good) {
    UpAxis a = UpAxis::kZUp;
    std::string error;
    EXPECT_TRUE(parseUpAxis(g.first, &a, &error)) << g.first << ": " << error;
    EXPECT_EQ(a, g.second) << g.first;
  }
  for (const std::string bad : {"", "w", "Y", "--y", "yy", "-"}) {
    UpAxis a = UpAxis::kNegXUp;
    std::string error;
    EXPECT_FALSE(parseUpAxis(bad, &a, &error)) << bad;
    EXPECT_NE(error.find("\"" + bad + "\""), std::string::npos) << error;
    EXPECT_EQ(a, UpAxis::kNegXUp);
  }
  for (UpAxis a : {UpAxis::kXUp, UpAxis::kYUp, UpAxis::kZUp, UpAxis::kNegXUp, UpAxis::kNegYUp,
                   UpAxis::kNegZUp}) {
    UpAxis back = UpAxis::kZUp;
    EXPECT_TRUE(parseUpAxis(upAxisName(a), &back, nullptr));
    EXPECT_EQ(back, a);
  }
}

TEST(HairUpAxis, EveryMappingIsAProperRotationTakingUpToZ) {
  const std::vector<std::pair<UpAxis, Vec3>> axes = {
      {UpAxis::kXUp, Vec3::UnitX()},     {UpAxis::kYUp, Vec3::UnitY()},
      {UpAxis::kZUp, Vec3::UnitZ()},     {UpAxis::kNegXUp, -Vec3::UnitX()},
      {UpAxis::kNegYUp, -Vec3::UnitY()}, {UpAxis::kNegZUp, -Vec3::UnitZ()}};
  for (const auto& a : axes) {
    SCOPED_TRACE(upAxisName(a.first));
    const Mat3 R = upAxisRotation(a.first);
    EXPECT_TRUE((R.transpose() * R).isApprox(Mat3::Identity(), 1e-15));
    EXPECT_NEAR(R.determinant(), 1.0, 1e-15);
    EXPECT_TRUE((R * a.second).isApprox(Vec3::UnitZ(), 1e-15));
  }
  // y up (glTF / Blender export / TressFX): file +z forward -> +x, file +x -> +y (left).
  const Mat3 Ry = upAxisRotation(UpAxis::kYUp);
  EXPECT_TRUE((Ry * Vec3(1, 2, 3)).isApprox(Vec3(3, 1, 2)));
  EXPECT_TRUE((upAxisRotation(UpAxis::kZUp) * Vec3(1, 2, 3)).isApprox(Vec3(1, 2, 3)));
  EXPECT_TRUE((upAxisRotation(UpAxis::kNegYUp) * Vec3(1, 2, 3)).isApprox(Vec3(3, -1, -2)));
}

// ------------------------------------------------------------------------------ resampling

Vec3List helix(int n, double radius, double pitch, double turns) {
  Vec3List p;
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * M_PI * turns * i / (n - 1);
    // Uneven parameter spacing so that the input edges differ.
    const double u =
        t * (1.0 + 0.3 * std::sin(0.37 * t)) / (1.0 + 0.3 * std::sin(0.37 * 2.0 * M_PI * turns));
    p.emplace_back(radius * std::cos(u), radius * std::sin(u), -pitch * u / (2.0 * M_PI));
  }
  return p;
}

TEST(HairResample, EqualChordsOnAHelixWithUnevenInput) {
  const Vec3List in = helix(40, 0.01, 0.03, 3.0);
  for (int count : {2, 3, 16, 33, 100}) {
    SCOPED_TRACE(count);
    Vec3List out;
    std::string error;
    ASSERT_TRUE(resampleEqualChord(in, count, &out, &error)) << error;
    ASSERT_EQ(static_cast<int>(out.size()), count);
    EXPECT_EQ(out.front(), in.front());
    EXPECT_EQ(out.back(), in.back());
    expectEqualEdges(edgeLengths(out, 0, out.size()), 1e-9);
  }
}

TEST(HairResample, DegenerateSegmentsAreSkippedAndZeroLengthIsRefused) {
  Vec3List in = {Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 0, 0), Vec3(1, 2, 0)};
  Vec3List out;
  std::string error;
  ASSERT_TRUE(resampleEqualChord(in, 7, &out, &error)) << error;
  expectEqualEdges(edgeLengths(out, 0, out.size()), 1e-9);
  EXPECT_EQ(out.back(), Vec3(1, 2, 0));

  const Vec3List zero = {Vec3(1, 1, 1), Vec3(1, 1, 1), Vec3(1, 1, 1)};
  out = {Vec3(9, 9, 9)};
  EXPECT_FALSE(resampleEqualChord(zero, 4, &out, &error));
  EXPECT_NE(error.find("length is 0"), std::string::npos) << error;
  EXPECT_EQ(out.size(), 1u);
  EXPECT_FALSE(resampleEqualChord(in, 1, &out, &error));
  EXPECT_NE(error.find("below 2"), std::string::npos) << error;
}

TEST(HairResample, StraightLineGivesUniformSpacing) {
  const Vec3List in = {Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(1, 0, 0)};
  Vec3List out;
  std::string error;
  ASSERT_TRUE(resampleEqualChord(in, 11, &out, &error)) << error;
  for (int i = 0; i < 11; ++i) EXPECT_NEAR(out[i].x(), 0.1 * i, 1e-12);
}

// ------------------------------------------------------------------------------ import

TEST(HairImport, ScaleAxisOffsetAndRootNormals) {
  HairFileData file;
  file.strand_offsets = {0, 3};
  file.points = {0, 10, 0, 0, 5, 1, 0, 0, 2};  // y up, cm: hangs down from y = 10.
  HairImportOptions opts;
  opts.scale = 0.01;
  opts.up = UpAxis::kYUp;
  opts.offset_m = Vec3(0, 0, 1);
  opts.head_center_m = Vec3(0, 0, 0.5);
  Groom g;
  std::string error;
  ASSERT_TRUE(importHairAsGroom(file, opts, &g, &error)) << error;
  ASSERT_EQ(g.strandCount(), 1);
  ASSERT_EQ(g.particleCount(), 3);
  EXPECT_TRUE(g.points[0].isApprox(Vec3(0, 0, 1.1)));
  EXPECT_TRUE(g.points[1].isApprox(Vec3(0.01, 0, 1.05)));
  EXPECT_TRUE(g.points[2].isApprox(Vec3(0.02, 0, 1.0)));
  EXPECT_TRUE(g.root_normals[0].isApprox(Vec3::UnitZ()));
  std::string why;
  EXPECT_TRUE(g.validate(&why)) << why;

  // Root at the head centre: the first edge direction is used.
  opts.head_center_m = g.points[0];
  ASSERT_TRUE(importHairAsGroom(file, opts, &g, &error)) << error;
  EXPECT_TRUE(g.root_normals[0].isApprox(Vec3(0.01, 0, -0.05).normalized()));
}

TEST(HairImport, RootsOnTheScalpMoveEachStrandOntoTheHeadAndSaySo) {
  // Two strands in cm, y up, authored on a head 1 cm smaller: both roots 1 cm inside a sphere
  // of radius 10 cm, one on top and one in front.
  HairFileData file;
  file.strand_offsets = {0, 3, 6};
  file.points = {0, 9, 0, 0, 12, 1,  0, 15, 2,    // on top, rising and leaning forward
                 0, 0, 9, 0, -2, 11, 0, -4, 13};  // in front, hanging down and forward
  HairImportOptions opts;
  opts.scale = 0.01;
  opts.up = UpAxis::kYUp;
  opts.scalp.radii_m = Vec3::Constant(0.1);
  Groom as_authored, placed;
  std::string error;
  HairImportReport report;
  ASSERT_TRUE(importHairAsGroom(file, opts, &as_authored, &error, &report)) << error;
  EXPECT_EQ(report.scalp_placement.strands_moved, 0);
  EXPECT_EQ(report.scalpSummary(), "");
  EXPECT_EQ(report.roots_inside.count, 2);
  EXPECT_NEAR(report.roots_inside.deepest_m, 0.01, 1e-9);
  EXPECT_NE(report.rootsInsideWarning().find("2 of 2 roots lie inside"), std::string::npos)
      << report.rootsInsideWarning();
  EXPECT_NE(report.rootsInsideWarning().find("roots_on_scalp"), std::string::npos);
  opts.roots_on_scalp = true;
  ASSERT_TRUE(importHairAsGroom(file, opts, &placed, &error, &report)) << error;
  EXPECT_EQ(report.scalp_placement.strands_moved, 2);
  EXPECT_NEAR(report.scalp_placement.largest_move_m, 0.01, 1e-9);
  EXPECT_EQ(report.scalp_placement.particles_inside, 0);
  EXPECT_NE(report.scalpSummary().find("moved 2 of 2 strands"), std::string::npos)
      << report.scalpSummary();
  EXPECT_EQ(report.roots_inside.count, 0);
  EXPECT_EQ(report.rootsInsideWarning(), "");
  // Radially out by 1 cm (y up: the top root is +z, the front one +x), shapes kept.
  const Vec3 moves[2] = {Vec3(0, 0, 0.01), Vec3(0.01, 0, 0)};
  for (int s = 0; s < 2; ++s) {
    EXPECT_TRUE(placed.root_normals[s].isApprox(moves[s] / 0.01)) << placed.root_normals[s];
    for (int i = 3 * s; i < 3 * s + 3; ++i)
      EXPECT_LT((placed.points[i] - (as_authored.points[i] + moves[s])).norm(), 1e-12);
  }
}

TEST(HairImport, RefusalsLeaveTheGroomUnchanged) {
  HairFileData file = makeSmall(Parts());
  Groom original;
  original.strand_offsets = {0, 2};
  original.points = {Vec3(1, 2, 3), Vec3(4, 5, 6)};
  original.root_normals = {Vec3::UnitZ()};
  struct Case {
    std::string name;
    HairFileData file;
    HairImportOptions opts;
    std::string needle;
  };
  std::vector<Case> cases;
  HairImportOptions o;
  o.scale = 0;
  cases.push_back({"zero scale", file, o, "scale"});
  o = HairImportOptions();
  o.scale = std::numeric_limits<double>::infinity();
  cases.push_back({"infinite scale", file, o, "scale"});
  o = HairImportOptions();
  o.resample_particles = 1;
  cases.push_back({"resample 1", file, o, "resample_particles is 1"});
  o = HairImportOptions();
  o.offset_m.x() = std::nan("");
  cases.push_back({"offset", file, o, "offset_m"});
  for (double edge : {-0.01, std::nan(""), std::numeric_limits<double>::infinity()}) {
    o = HairImportOptions();
    o.resample_edge_m = edge;
    cases.push_back({"resample_edge_m " + std::to_string(edge), file, o, "resample_edge_m is"});
  }
  o = HairImportOptions();
  o.resample_edge_m = 0.01;
  o.resample_particles = 8;
  cases.push_back({"both resamplings", file, o, "resample_particles (8) and resample_edge_m"});
  for (const Vec3& radii : {Vec3(0.1, 0.0, 0.1), Vec3(0.1, -0.1, 0.1), Vec3(0.1, NAN, 0.1)}) {
    o = HairImportOptions();
    o.roots_on_scalp = true;
    o.scalp.radii_m = radii;
    cases.push_back({"scalp radii", file, o, "import option scalp needs"});
  }
  o = HairImportOptions();  // checked with roots_on_scalp off too: the report counts roots inside
  o.scalp.center_m.z() = INFINITY;
  cases.push_back({"scalp centre", file, o, "import option scalp needs"});
  {
    // Skipped strands never refuse a groom, but a file with no strand left is refused.
    HairFileData f = file;
    for (int i = 0; i < 7; ++i) {
      for (int k = 0; k < 3; ++k) f.points[3 * i + k] = 5.f;
    }
    cases.push_back({"every strand zero length", f, HairImportOptions(),
                     "none of the 2 strands can be simulated: skipped 2 of 2 strands"});
  }
  {
    HairFileData f = file;
    f.strand_offsets = {0};
    cases.push_back({"no strands", f, HairImportOptions(), "zero strands"});
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Groom g = original;
    std::string error;
    EXPECT_FALSE(importHairAsGroom(c.file, c.opts, &g, &error));
    EXPECT_NE(error.find(c.needle), std::string::npos) << error;
    EXPECT_EQ(g.strand_offsets, original.strand_offsets);
    EXPECT_EQ(g.points, original.points);
    EXPECT_EQ(g.root_normals, original.root_normals);
  }
}

// ------------------------------------------------------------------------------ skipped strands

/// Appends a strand (file units) to `d`.
void addStrand(HairFileData* d, const std::vector<Vec3>& pts) {
  for (const Vec3& p : pts) {
    for (int k = 0; k < 3; ++k) d->points.push_back(static_cast<float>(p[k]));
  }
  d->strand_offsets.push_back(static_cast<uint32_t>(d->points.size() / 3));
}

/// `n` points on a straight line from `root` along +x, `length` long (file units).
std::vector<Vec3> line(const Vec3& root, double length, int n) {
  std::vector<Vec3> p;
  for (int i = 0; i < n; ++i) p.push_back(root + Vec3(length * i / (n - 1), 0, 0));
  return p;
}

/// A file in centimetres (scale 0.01) with eleven strands: four that import and seven that
/// cannot be simulated, one of each kind.
HairFileData mixedFile() {
  HairFileData d;
  d.strand_offsets = {0};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  addStrand(&d, line(Vec3(0, 0, 11), 10.0, 5));  // 0: 10 cm, 5 points.
  addStrand(&d, line(Vec3(1, 0, 11), 10.0, 2));  // 1: 2 points.
  std::vector<Vec3> curl;                        // 2: a helix, 20 points.
  for (int i = 0; i < 20; ++i) {
    const double t = 0.6 * i;
    curl.emplace_back(2 + std::cos(t), std::sin(t), 11 - 0.5 * t);
  }
  addStrand(&d, curl);
  addStrand(&d, std::vector<Vec3>(4, Vec3(3, 0, 11)));  // 3: zero length.
  addStrand(&d, line(Vec3(4, 0, 11), 0.01, 4));         // 4: 0.1 mm: kept.
  // 5: repeated consecutive points (root, middle and tip): 4 distinct ones are kept.
  addStrand(&d, {Vec3(5, 0, 11), Vec3(5, 0, 11), Vec3(5, 0, 9), Vec3(5, 0, 9), Vec3(5, 1, 8),
                 Vec3(5, 2, 8), Vec3(5, 2, 8)});
  // 6: repeats that leave 2 distinct points.
  addStrand(&d, {Vec3(6, 0, 11), Vec3(6, 0, 11), Vec3(6, 0, 11), Vec3(6, 0, 8), Vec3(6, 0, 8)});
  addStrand(&d, {Vec3(7, 0, 11), Vec3(7, 0, 10), Vec3(7, nan, 9), Vec3(7, 0, 8)});  // 7: NaN.
  addStrand(&d, line(Vec3(0, 0, 0), 5e-5, 3));  // 8: 0.5 um: near zero.
  addStrand(&d, {Vec3(9, 0, 11)});              // 9: 1 point.
  addStrand(&d, line(Vec3(0, 0, 0), 2e-4, 3));  // 10: 2 um: kept.
  return d;
}

TEST(HairImportSkips, MixedFileLoadsWithCountNamesAndRemainingStrands) {
  // Written to and read from a file, as a user's groom would be.
  const std::string path = tempPath("wch_test_mixed.hair");
  std::string error;
  ASSERT_TRUE(writeHairFile(path, mixedFile(), &error)) << error;
  HairFileData file;
  ASSERT_TRUE(readHairFile(path, &file, &error)) << error;
  std::remove(path.c_str());
  ASSERT_EQ(file.strandCount(), 11);
  HairImportOptions opts;
  opts.scale = 0.01;
  Groom g;
  HairImportReport report;
  ASSERT_TRUE(importHairAsGroom(file, opts, &g, &error, &report)) << error;

  EXPECT_EQ(report.strands_in_file, 11);
  EXPECT_EQ(report.strands_imported, 5);
  EXPECT_EQ(report.repeated_points_dropped, 3);
  ASSERT_EQ(report.skipped.size(), 6u);
  const std::vector<int> skipped_index = {1, 3, 6, 7, 8, 9};
  for (size_t k = 0; k < skipped_index.size(); ++k) {
    EXPECT_EQ(report.skipped[k].index, skipped_index[k]) << k;
  }
  EXPECT_EQ(report.skipped[0].reason, "2 points");
  EXPECT_EQ(report.skipped[1].reason, "length 0 m, below 1e-06 m");
  EXPECT_EQ(report.skipped[2].reason, "2 distinct points once 3 repeated ones are dropped");
  EXPECT_EQ(report.skipped[3].reason, "non-finite point 2 in the file");
  EXPECT_EQ(report.skipped[4].reason.rfind("length 5", 0), 0u) << report.skipped[4].reason;
  EXPECT_NE(report.skipped[4].reason.find("e-07 m, below 1e-06 m"), std::string::npos)
      << report.skipped[4].reason;
  EXPECT_EQ(report.skipped[5].reason, "1 point");
  // One warning: five strands named with their reason, then the count of the rest.
  const std::string w = report.warning();
  EXPECT_EQ(w.rfind("skipped 6 of 11 strands of the file (not simulated): strand 1 (2 points), "
                    "strand 3 (length 0 m, below 1e-06 m), strand 6 (2 distinct points once 3 "
                    "repeated ones are dropped), strand 7 (non-finite point 2 in the file), "
                    "strand 8 (length 5",
                    0),
            0u)
      << w;
  EXPECT_EQ(w.substr(w.size() - 12), ", and 1 more") << w;
  EXPECT_EQ(w.find("strand 9"), std::string::npos) << w;

  // The remaining strands, in file order, with their own point counts and lengths.
  ASSERT_EQ(g.strandCount(), 5);
  const std::vector<int> sizes = {5, 20, 4, 4, 3};
  const std::vector<int> file_index = {0, 2, 4, 5, 10};
  for (int s = 0; s < 5; ++s) {
    SCOPED_TRACE("groom strand " + std::to_string(s));
    EXPECT_EQ(g.strandSize(s), sizes[s]);
    const uint32_t b = file.strand_offsets[file_index[s]];
    const Vec3 root(file.points[3 * b], file.points[3 * b + 1], file.points[3 * b + 2]);
    EXPECT_TRUE(g.points[g.strand_offsets[s]].isApprox(0.01 * root, 1e-12));
  }
  double length4 = 0.0;
  for (uint32_t i = g.strand_offsets[2]; i + 1 < g.strand_offsets[3]; ++i) {
    length4 += (g.points[i + 1] - g.points[i]).norm();
  }
  // The 0.1 mm strand is hair: kept (to the float32 rounding of its 4 cm file coordinates).
  EXPECT_NEAR(length4, 1e-4, 1e-8);
  // Strand 5 keeps its distinct points in order: (5,0,11), (5,0,9), (5,1,8), (5,2,8) cm.
  const Vec3List expect5 = {Vec3(0.05, 0, 0.11), Vec3(0.05, 0, 0.09), Vec3(0.05, 0.01, 0.08),
                            Vec3(0.05, 0.02, 0.08)};
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(g.points[g.strand_offsets[3] + i].isApprox(expect5[i], 1e-6)) << i;
  }
  std::string why;
  EXPECT_TRUE(g.validate(&why)) << why;
}

TEST(HairImportSkips, MinEdgeSkipsStubsAndCoarsensFineStrandsSoTheDefaultsRunIt) {
  // The scene's default groom_file.min_edge_m (1 mm): the 0.1 mm and 2 um strands are skipped as
  // too short to bend, named; the rest keep mean edges of at least 1 mm, so the model builds with
  // the default parameters and its explicit substep is that of millimetre edges, not of the
  // micrometre ones (which would set about 1e-7 s for the whole groom, docs/physics.md §2.9).
  HairImportOptions opts;
  opts.scale = 0.01;
  opts.min_edge_m = io::GroomFileConfig().min_edge_m;
  ASSERT_EQ(opts.min_edge_m, 0.001);
  HairFileData file = mixedFile();
  addStrand(&file, line(Vec3(8, 0, 11), 1.0, 40));  // 11: 1 cm in 39 edges of 0.26 mm.
  Groom g;
  HairImportReport report;
  std::string error;
  ASSERT_TRUE(importHairAsGroom(file, opts, &g, &error, &report)) << error;
  ASSERT_EQ(report.skipped.size(), 8u);
  EXPECT_EQ(report.skipped[2].index, 4);
  EXPECT_EQ(report.skipped[2].reason.rfind("length 0.0001", 0), 0u) << report.skipped[2].reason;
  EXPECT_NE(report.skipped[2].reason.find("shorter than two edges of min_edge_m 0.001 m"),
            std::string::npos)
      << report.skipped[2].reason;
  EXPECT_EQ(report.skipped.back().index, 10);
  ASSERT_EQ(g.strandCount(), 4);
  for (int s = 0; s < g.strandCount(); ++s) {
    double length = 0.0;
    for (uint32_t i = g.strand_offsets[s]; i + 1 < g.strand_offsets[s + 1]; ++i)
      length += (g.points[i + 1] - g.points[i]).norm();
    EXPECT_GE(length / (g.strandSize(s) - 1), opts.min_edge_m * (1.0 - 1e-9)) << s;
  }
  // The 1 cm strand: floor(L / 1 mm) + 1 points, 10 or 11 as its float32 length rounds.
  EXPECT_GE(g.strandSize(3), 10);
  EXPECT_LE(g.strandSize(3), 11);
  SolverConfig c;
  HairModel m;
  ASSERT_TRUE(buildModel(g, GroomConfig().linear_density_kg_per_m, HeadShape(), c, &m, &error))
      << error;
  // The stiffest particle is on 1 mm edges: k_s = EA / 1 mm, m = rho 1 mm.
  const double k = c.stretch.axial_stiffness_n / 1e-3,
               mass = GroomConfig().linear_density_kg_per_m * 1e-3;
  EXPECT_GT(m.explicit_substep_bound_s,
            0.5 * kExplicitStabilityFraction * 2.0 / std::sqrt(4.0 * k / mass));
}

TEST(HairImportSkips, NothingSkippedGivesNoWarning) {
  HairFileData d;
  d.strand_offsets = {0};
  addStrand(&d, line(Vec3(0, 0, 0.1), 0.1, 4));
  Groom g;
  HairImportReport report;
  report.skipped.push_back({7, "stale"});
  std::string error;
  ASSERT_TRUE(importHairAsGroom(d, HairImportOptions(), &g, &error, &report)) << error;
  EXPECT_TRUE(report.skipped.empty());
  EXPECT_EQ(report.warning(), "");
  EXPECT_EQ(report.strands_imported, 1);
}

TEST(HairImportSkips, NonFiniteAfterScalingIsSkipped) {
  HairFileData d;
  d.strand_offsets = {0};
  addStrand(&d, line(Vec3(0, 0, 1), 1e10, 3));  // finite, but past 1.8e308 once scaled by 1e300.
  HairImportOptions opts;
  opts.scale = 1e300;
  Groom g;
  std::string error;
  EXPECT_FALSE(importHairAsGroom(d, opts, &g, &error));
  EXPECT_EQ(error,
            "none of the 1 strands can be simulated: skipped 1 of 1 strands of the file (not "
            "simulated): strand 0 (non-finite point 1 after scaling)");
}

TEST(HairImportSkips, ResampleEdgeGivesPointsThatFollowEachStrandsLength) {
  HairFileData d;
  d.strand_offsets = {0};
  addStrand(&d, line(Vec3(0, 0, 0.2), 0.1, 4));  // 0.1 m: 10 edges of 1 cm -> 11 points.
  // An L of 0.2 + 0.053 = 0.253 m: round(25.3) = 25 edges -> 26 points; 0.257 m: 26 -> 27.
  addStrand(&d, {Vec3(0.1, 0, 0.2), Vec3(0.1, 0, 0.0), Vec3(0.1, 0.053, 0.0)});
  addStrand(&d, {Vec3(0.15, 0, 0.2), Vec3(0.15, 0, 0.0), Vec3(0.15, 0.057, 0.0)});
  addStrand(&d, line(Vec3(0.2, 0, 0.2), 0.016, 3));   // round(1.6) = 2 edges -> 3 points.
  addStrand(&d, line(Vec3(0.3, 0, 0.2), 0.004, 3));   // round(0.4) = 0 edges -> at least 3 points.
  addStrand(&d, line(Vec3(0.4, 0, 0.2), 1000.0, 3));  // 100001 points: more than a strand gets.
  HairImportOptions opts;
  opts.resample_edge_m = 0.01;
  Groom g;
  std::string error;
  HairImportReport report;
  ASSERT_TRUE(importHairAsGroom(d, opts, &g, &error, &report)) << error;
  ASSERT_EQ(report.skipped.size(), 1u);
  EXPECT_EQ(report.skipped[0].index, 5);
  EXPECT_EQ(report.skipped[0].reason,
            "length 1000 m needs more than 65536 points at resample_edge_m 0.01 m");
  ASSERT_EQ(g.strandCount(), 5);
  const std::vector<int> expected = {11, 26, 27, 3, 3};
  for (int s = 0; s < 5; ++s) {
    SCOPED_TRACE("strand " + std::to_string(s));
    EXPECT_EQ(g.strandSize(s), expected[s]);
    const uint32_t b = d.strand_offsets[s], e = d.strand_offsets[s + 1];
    EXPECT_TRUE(g.points[g.strand_offsets[s]].isApprox(
        Vec3(d.points[3 * b], d.points[3 * b + 1], d.points[3 * b + 2]), 1e-12));
    EXPECT_TRUE(g.points[g.strand_offsets[s + 1] - 1].isApprox(
        Vec3(d.points[3 * e - 3], d.points[3 * e - 2], d.points[3 * e - 1]), 1e-12));
    expectEqualEdges(edgeLengths(g.points, g.strand_offsets[s], g.strand_offsets[s + 1]), 1e-9);
  }
  // Straight strands: the chords are the arc length over the edge count.
  EXPECT_NEAR((g.points[1] - g.points[0]).norm(), 0.01, 1e-8);
  EXPECT_NEAR((g.points[g.strand_offsets[3] + 1] - g.points[g.strand_offsets[3]]).norm(), 0.008,
              1e-8);
}

// ------------------------------------------------------------------------------ export

TEST(HairExport, SaturationIsRecoverableAndColoured) {
  const std::vector<uint32_t> offsets = {0, 3, 6};
  Vec3List pos = {Vec3(0, 0, 1),     Vec3(0, 0, 0.9),      Vec3(0.01, 0, 0.8),
                  Vec3(0.1, 0.2, 1), Vec3(0.1, 0.2, 0.95), Vec3(0.1, 0.21, 0.9)};
  const std::vector<double> sat = {0.0, 0.25, 1.0, 0.5, 0.125, 0.75};
  const HairFileData d = groomPositionsToHair(offsets, pos, &sat);
  std::vector<uint8_t> bytes;
  std::string error;
  ASSERT_TRUE(serializeHair(d, &bytes, &error)) << error;
  HairFileData back;
  ASSERT_TRUE(parseHair(bytes.data(), bytes.size(), &back, &error)) << error;
  ASSERT_EQ(back.strand_offsets, offsets);
  ASSERT_EQ(back.transparency.size(), sat.size());
  ASSERT_EQ(back.colors.size(), 3 * sat.size());
  for (size_t i = 0; i < sat.size(); ++i) {
    EXPECT_EQ(back.transparency[i], static_cast<float>(sat[i]));
    EXPECT_FLOAT_EQ(back.colors[3 * i], static_cast<float>(1.0 - 0.7 * sat[i]));
    EXPECT_FLOAT_EQ(back.colors[3 * i + 1], static_cast<float>(1.0 - 0.4 * sat[i]));
    EXPECT_EQ(back.colors[3 * i + 2], 1.f);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(back.points[3 * i + k], static_cast<float>(pos[i][k]));
  }
  EXPECT_TRUE(back.thickness.empty());
  EXPECT_NE(back.info.find("z up"), std::string::npos);

  // Importing the export (metres, z up) gives the positions back to float precision.
  Groom g;
  ASSERT_TRUE(importHairAsGroom(back, HairImportOptions(), &g, &error)) << error;
  for (size_t i = 0; i < pos.size(); ++i) EXPECT_TRUE(g.points[i].isApprox(pos[i], 1e-6));

  const HairFileData no_sat = groomPositionsToHair(offsets, pos, nullptr);
  EXPECT_TRUE(no_sat.transparency.empty());
  EXPECT_TRUE(no_sat.colors.empty());
}

TEST(HairExport, BadInputGivesNoStrandsAndAMessage) {
  const Vec3List pos = {Vec3(0, 0, 1), Vec3(0, 0, 0.9)};
  const std::vector<double> sat = {0.5};
  EXPECT_EQ(groomPositionsToHair({0, 2}, pos, &sat).strandCount(), 0);
  EXPECT_EQ(groomPositionsToHair({0, 3}, pos, nullptr).strandCount(), 0);
  HairFileData out = sentinel();
  std::string error;
  EXPECT_FALSE(groomPositionsToHairChecked({0, 2}, pos, &sat, &out, &error));
  EXPECT_NE(error.find("saturation has 1 values"), std::string::npos) << error;
  EXPECT_TRUE(identical(out, sentinel()));
  std::vector<uint8_t> bytes;
  EXPECT_FALSE(serializeHair(groomPositionsToHair({0, 3}, pos, nullptr), &bytes, &error));
  // The format holds non-finite values, but a frame with them is a broken state: refused.
  const Vec3List bad = {Vec3(0, 0, 1), Vec3(0, std::nan(""), 0.9)};
  EXPECT_FALSE(groomPositionsToHairChecked({0, 2}, bad, nullptr, &out, &error));
  EXPECT_NE(error.find("position 1 is not finite"), std::string::npos) << error;
  EXPECT_TRUE(identical(out, sentinel()));
}

// ------------------------------------------------------------------------------ real file

TEST(HairSintelLite, ParsesWithExpectedCountsAndPrintsHeader) {
  const std::string path = sintelPath();
  ASSERT_TRUE(fileExists(path)) << "real data file missing: " << path
                                << " (shared/data/ lies beside the package)";
  std::ifstream in(path, std::ios::binary);
  std::vector<uint8_t> raw((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_GE(raw.size(), kHairHeaderBytes);
  HairFileData d;
  std::string error;
  ASSERT_TRUE(readHairFile(path, &d, &error)) << error;
  EXPECT_EQ(d.strandCount(), 228);
  EXPECT_EQ(d.pointCount(), 7296);
  std::printf(
      "sintel_lite.hair: flags 0x%x, default segments %u, default thickness %g, default "
      "transparency %g, default colour (%g, %g, %g), info \"%s\", segments array %s, thickness %s, "
      "transparency %s, colours %s\n",
      getU32(raw, 12), d.default_segments, d.default_thickness, d.default_transparency,
      d.default_color[0], d.default_color[1], d.default_color[2], d.info.c_str(),
      d.write_segments_array ? "yes" : "no", d.thickness.empty() ? "no" : "yes",
      d.transparency.empty() ? "no" : "yes", d.colors.empty() ? "no" : "yes");
  // Only what the file's provider states (the Sintel lite hair, converted from its TressFX
  // asset): points only, 31 segments per strand by default.
  EXPECT_NE(getU32(raw, 12) & kHairHasPoints, 0u);
  EXPECT_FALSE(d.write_segments_array);
  EXPECT_TRUE(d.thickness.empty());
  EXPECT_TRUE(d.transparency.empty());
  EXPECT_TRUE(d.colors.empty());
  EXPECT_EQ(d.default_segments, 31u);
  for (int s = 0; s < d.strandCount(); ++s) {
    EXPECT_EQ(d.strand_offsets[s + 1] - d.strand_offsets[s], 32u) << "strand " << s;
  }
  // Re-serializing reproduces the file's arrays byte for byte.
  std::vector<uint8_t> again;
  ASSERT_TRUE(serializeHair(d, &again, &error)) << error;
  ASSERT_EQ(again.size(), raw.size());
  EXPECT_EQ(std::vector<uint8_t>(again.begin() + kHairHeaderBytes, again.end()),
            std::vector<uint8_t>(raw.begin() + kHairHeaderBytes, raw.end()));
}

TEST(HairSintelLite, ImportsInMetresWithZUpAndResamplesToEqualEdges) {
  const std::string path = sintelPath();
  ASSERT_TRUE(fileExists(path)) << "real data file missing: " << path
                                << " (shared/data/ lies beside the package)";
  HairFileData d;
  std::string error;
  ASSERT_TRUE(readHairFile(path, &d, &error)) << error;
  HairImportOptions opts;
  opts.scale = 0.01;  // Blender units (the ~50-unit character) to metres.
  opts.up = UpAxis::kYUp;
  Groom g;
  ASSERT_TRUE(importHairAsGroom(d, opts, &g, &error)) << error;
  ASSERT_EQ(g.strandCount(), 228);
  ASSERT_EQ(g.particleCount(), 7296);
  std::string why;
  EXPECT_TRUE(g.validate(&why)) << why;
  Vec3 lo = g.points[0], hi = g.points[0];
  for (const Vec3& p : g.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3 extent = hi - lo;
  std::printf(
      "sintel_lite imported (m, REP-103): min (%.4f, %.4f, %.4f) max (%.4f, %.4f, %.4f) "
      "extent (%.4f, %.4f, %.4f)\n",
      lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z(), extent.x(), extent.y(), extent.z());
  // Head-sized hair at the top of a ~0.5 m character: extents of decimetres, top near 0.5 m.
  EXPECT_GT(extent.maxCoeff(), 0.1);
  EXPECT_LT(extent.maxCoeff(), 0.6);
  EXPECT_GT(hi.z(), 0.4);
  EXPECT_LT(hi.z(), 0.6);
  // z is the long (vertical) axis, and the hair hangs down: roots above tips on average.
  EXPECT_GT(extent.z(), extent.x());
  EXPECT_GT(extent.z(), extent.y());
  double drop = 0.0;
  for (int s = 0; s < g.strandCount(); ++s) {
    drop += g.points[g.strand_offsets[s]].z() - g.points[g.strand_offsets[s + 1] - 1].z();
  }
  EXPECT_GT(drop / g.strandCount(), 0.02);

  opts.resample_particles = 16;
  Groom r;
  ASSERT_TRUE(importHairAsGroom(d, opts, &r, &error)) << error;
  ASSERT_EQ(r.strandCount(), 228);
  ASSERT_EQ(r.particleCount(), 228 * 16);
  EXPECT_TRUE(r.validate(&why)) << why;
  for (int s = 0; s < r.strandCount(); ++s) {
    SCOPED_TRACE("strand " + std::to_string(s));
    ASSERT_EQ(r.strandSize(s), 16);
    EXPECT_EQ(r.points[r.strand_offsets[s]], g.points[g.strand_offsets[s]]);
    EXPECT_EQ(r.points[r.strand_offsets[s + 1] - 1], g.points[g.strand_offsets[s + 1] - 1]);
    expectEqualEdges(edgeLengths(r.points, r.strand_offsets[s], r.strand_offsets[s + 1]), 1e-9);
  }
}

}  // namespace
}  // namespace io
}  // namespace wet_curly_hair

// catkin_add_gtest links gtest without gtest_main.
int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
