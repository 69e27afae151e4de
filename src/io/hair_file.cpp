// Cem Yuksel's `.hair` format: parser (safe for arbitrary bytes), writer, Groom import and export.
#include "wet_curly_hair/io/hair_file.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>

namespace wet_curly_hair {
namespace io {
namespace {

void setError(std::string* error, const std::string& message) {
  if (error != nullptr) *error = message;
}

// Little-endian loads and stores, independent of the host byte order. Callers check bounds.
uint32_t loadU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}

uint16_t loadU16(const uint8_t* p) {
  return static_cast<uint16_t>(static_cast<uint16_t>(p[0]) | (static_cast<uint16_t>(p[1]) << 8));
}

float loadF32(const uint8_t* p) {
  const uint32_t bits = loadU32(p);
  float f;
  std::memcpy(&f, &bits, sizeof(f));
  return f;
}

void storeU32(uint32_t v, std::vector<uint8_t>* b) {
  for (int i = 0; i < 4; ++i) b->push_back(static_cast<uint8_t>((v >> (8 * i)) & 0xffu));
}

void storeU16(uint16_t v, std::vector<uint8_t>* b) {
  b->push_back(static_cast<uint8_t>(v & 0xffu));
  b->push_back(static_cast<uint8_t>((v >> 8) & 0xffu));
}

void storeF32(float f, std::vector<uint8_t>* b) {
  uint32_t bits;
  std::memcpy(&bits, &f, sizeof(bits));
  storeU32(bits, b);
}

// Reads `count` floats of an array that starts at `*offset`, after checking that the bytes exist.
// Advances `*offset` on success.
bool readFloatArray(const uint8_t* data, size_t size, const char* name, uint64_t count,
                    uint64_t* offset, std::vector<float>* out, std::string* error) {
  const uint64_t need = count * 4;  // count <= 3 * 2^28: no overflow.
  if (*offset > size || need > size - *offset) {
    std::ostringstream m;
    m << name << " array: needs " << need << " bytes at offset " << *offset << ", file has only "
      << size << " bytes";
    setError(error, m.str());
    return false;
  }
  out->resize(static_cast<size_t>(count));
  const uint8_t* p = data + *offset;
  for (uint64_t i = 0; i < count; ++i) (*out)[i] = loadF32(p + 4 * i);
  *offset += need;
  return true;
}

}  // namespace

int HairFileData::strandCount() const {
  return strand_offsets.empty() ? 0 : static_cast<int>(strand_offsets.size() - 1);
}

int HairFileData::pointCount() const { return static_cast<int>(points.size() / 3); }

uint32_t HairFileData::flags() const {
  uint32_t f = kHairHasPoints;
  if (write_segments_array) f |= kHairHasSegments;
  if (!thickness.empty()) f |= kHairHasThickness;
  if (!transparency.empty()) f |= kHairHasTransparency;
  if (!colors.empty()) f |= kHairHasColor;
  return f;
}

bool validateHairData(const HairFileData& data, std::string* error) {
  std::ostringstream m;
  const auto& off = data.strand_offsets;
  if (off.size() < 2) {
    m << "strand_offsets has " << off.size() << " entries: need at least 2 (zero strands)";
    setError(error, m.str());
    return false;
  }
  if (off.size() - 1 > kHairMaxPoints) {
    m << "strand count " << off.size() - 1 << " exceeds the limit " << kHairMaxPoints;
    setError(error, m.str());
    return false;
  }
  if (data.points.size() % 3 != 0) {
    m << "points has " << data.points.size() << " floats, not a multiple of 3";
    setError(error, m.str());
    return false;
  }
  const uint64_t n = data.points.size() / 3;
  if (n > kHairMaxPoints) {
    m << "point count " << n << " exceeds the limit " << kHairMaxPoints;
    setError(error, m.str());
    return false;
  }
  if (off[0] != 0) {
    m << "strand_offsets[0] is " << off[0] << ", must be 0";
    setError(error, m.str());
    return false;
  }
  for (size_t s = 0; s + 1 < off.size(); ++s) {
    if (off[s + 1] <= off[s]) {
      m << "strand " << s << " has "
        << (off[s + 1] < off[s] ? std::string("a negative number of") : std::string("0"))
        << " points (strand_offsets[" << s << "] = " << off[s] << ", strand_offsets[" << s + 1
        << "] = " << off[s + 1] << "): every strand needs at least 1 point";
      setError(error, m.str());
      return false;
    }
    const uint64_t segments = off[s + 1] - off[s] - 1;
    if (data.write_segments_array && segments > 0xffffu) {
      m << "strand " << s << " has " << segments
        << " segments: the segments array holds at most 65535";
      setError(error, m.str());
      return false;
    }
    if (!data.write_segments_array && segments != data.default_segments) {
      m << "strand " << s << " has " << segments << " segments but write_segments_array is false"
        << " and default_segments is " << data.default_segments;
      setError(error, m.str());
      return false;
    }
  }
  if (off.back() != n) {
    m << "strand_offsets ends at " << off.back() << " but there are " << n << " points";
    setError(error, m.str());
    return false;
  }
  if (!data.thickness.empty() && data.thickness.size() != n) {
    m << "thickness has " << data.thickness.size() << " values, expected 0 or " << n;
    setError(error, m.str());
    return false;
  }
  if (!data.transparency.empty() && data.transparency.size() != n) {
    m << "transparency has " << data.transparency.size() << " values, expected 0 or " << n;
    setError(error, m.str());
    return false;
  }
  if (!data.colors.empty() && data.colors.size() != 3 * n) {
    m << "colors has " << data.colors.size() << " values, expected 0 or " << 3 * n;
    setError(error, m.str());
    return false;
  }
  return true;
}

bool parseHair(const uint8_t* data, size_t size, HairFileData* out, std::string* error) {
  std::ostringstream m;
  if (out == nullptr) {
    setError(error, "parseHair: output is null");
    return false;
  }
  if (data == nullptr && size > 0) {
    setError(error, "parseHair: data is null");
    return false;
  }
  if (size < kHairHeaderBytes) {
    m << "header: file has only " << size << " bytes, shorter than the " << kHairHeaderBytes
      << "-byte header";
    setError(error, m.str());
    return false;
  }
  if (std::memcmp(data, "HAIR", 4) != 0) {
    m << "header: bad magic at offset 0 (bytes";
    for (int i = 0; i < 4; ++i) m << ' ' << static_cast<int>(data[i]);
    m << "), expected \"HAIR\"";
    setError(error, m.str());
    return false;
  }
  const uint64_t strands = loadU32(data + 4);
  const uint64_t points = loadU32(data + 8);
  const uint32_t flags = loadU32(data + 12);

  HairFileData r;
  r.default_segments = loadU32(data + 16);
  r.default_thickness = loadF32(data + 20);
  r.default_transparency = loadF32(data + 24);
  for (int k = 0; k < 3; ++k) r.default_color[k] = loadF32(data + 28 + 4 * k);
  {
    const char* info = reinterpret_cast<const char*>(data + 40);
    size_t len = 0;
    while (len < kHairInfoBytes && info[len] != '\0') ++len;
    r.info.assign(info, len);
  }
  r.write_segments_array = (flags & kHairHasSegments) != 0;

  if (strands == 0) {
    setError(error, "header: strand count (offset 4) is 0: the file has no strands");
    return false;
  }
  if (strands > kHairMaxPoints) {
    m << "header: strand count (offset 4) " << strands << " exceeds the limit " << kHairMaxPoints;
    setError(error, m.str());
    return false;
  }
  if (points > kHairMaxPoints) {
    m << "header: point count (offset 8) " << points << " exceeds the limit " << kHairMaxPoints;
    setError(error, m.str());
    return false;
  }
  if ((flags & kHairHasPoints) == 0) {
    m << "header: flags (offset 12) = 0x" << std::hex << flags << std::dec
      << " has no points array (bit 1): positions are required";
    setError(error, m.str());
    return false;
  }

  uint64_t offset = kHairHeaderBytes;
  r.strand_offsets.assign(1, 0u);
  if (r.write_segments_array) {
    const uint64_t need = 2 * strands;
    if (need > size - offset) {
      m << "segments array: needs " << need << " bytes at offset " << offset << ", file has only "
        << size << " bytes";
      setError(error, m.str());
      return false;
    }
    r.strand_offsets.reserve(static_cast<size_t>(strands + 1));
    uint64_t total = 0;
    for (uint64_t s = 0; s < strands; ++s) {
      // 0 segments is a strand of one point: kept, importHairAsGroom skips and names it.
      const uint64_t seg = loadU16(data + offset + 2 * s);
      total += seg + 1;
      if (total > points) {
        m << "segments array: strand " << s << " (" << seg
          << " segments) brings the point total to " << total
          << ", more than the header point count " << points;
        setError(error, m.str());
        return false;
      }
      r.strand_offsets.push_back(static_cast<uint32_t>(total));
    }
    if (total != points) {
      m << "segments array: the " << strands << " strands (last is strand " << strands - 1
        << ") hold " << total << " points but the header point count is " << points;
      setError(error, m.str());
      return false;
    }
    offset += need;
  } else {
    // A default segment count of 0 makes every strand a single point: kept, like one-point
    // strands of a segments array (importHairAsGroom skips them).
    const uint64_t per = uint64_t{r.default_segments} + 1;  // <= 2^32
    const uint64_t total = strands * per;                   // < 2^64
    if (total != points) {
      m << "header: " << strands << " strands x (default segment count " << r.default_segments
        << " + 1) = " << total << " points, but the header point count is " << points
        << " (no segments array)";
      setError(error, m.str());
      return false;
    }
    // The offsets take 4 bytes a strand, up to 4 bytes a point when strands have one point: check
    // that the 12 bytes a point of the points array exist before allocating them.
    if (12 * points > size - offset) {
      m << "points array: needs " << 12 * points << " bytes at offset " << offset
        << ", file has only " << size << " bytes";
      setError(error, m.str());
      return false;
    }
    r.strand_offsets.reserve(static_cast<size_t>(strands + 1));
    for (uint64_t s = 1; s <= strands; ++s) {
      r.strand_offsets.push_back(static_cast<uint32_t>(s * per));
    }
  }

  // Non-finite coordinates are kept: importHairAsGroom skips and names their strands.
  if (!readFloatArray(data, size, "points", 3 * points, &offset, &r.points, error)) return false;
  if ((flags & kHairHasThickness) != 0 &&
      !readFloatArray(data, size, "thickness", points, &offset, &r.thickness, error)) {
    return false;
  }
  if ((flags & kHairHasTransparency) != 0 &&
      !readFloatArray(data, size, "transparency", points, &offset, &r.transparency, error)) {
    return false;
  }
  if ((flags & kHairHasColor) != 0 &&
      !readFloatArray(data, size, "color", 3 * points, &offset, &r.colors, error)) {
    return false;
  }
  *out = std::move(r);
  return true;
}

bool readHairFile(const std::string& path, HairFileData* out, std::string* error) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) {
    setError(error, path + ": cannot open for reading");
    return false;
  }
  const std::streamoff end = in.tellg();
  // Largest well-formed file: header + segments + 32 bytes of arrays per point.
  const uint64_t max_size = kHairHeaderBytes + 2 * kHairMaxPoints + 32 * kHairMaxPoints;
  if (end < 0 || static_cast<uint64_t>(end) > max_size) {
    setError(error, path +
                        ": cannot determine the file size, or it is larger than any valid "
                        ".hair file");
    return false;
  }
  std::vector<uint8_t> bytes(static_cast<size_t>(end));
  in.seekg(0);
  if (!bytes.empty() && !in.read(reinterpret_cast<char*>(bytes.data()), end)) {
    setError(error, path + ": read error");
    return false;
  }
  std::string why;
  if (!parseHair(bytes.data(), bytes.size(), out, &why)) {
    setError(error, path + ": " + why);
    return false;
  }
  return true;
}

bool serializeHair(const HairFileData& data, std::vector<uint8_t>* bytes, std::string* error) {
  if (bytes == nullptr) {
    setError(error, "serializeHair: output is null");
    return false;
  }
  if (!validateHairData(data, error)) return false;
  const uint64_t strands = data.strand_offsets.size() - 1;
  const uint64_t n = data.points.size() / 3;
  std::vector<uint8_t> b;
  b.reserve(static_cast<size_t>(
      kHairHeaderBytes + 2 * strands + 4 * (3 * n) +
      4 * (data.thickness.size() + data.transparency.size() + data.colors.size())));
  b.insert(b.end(), {'H', 'A', 'I', 'R'});
  storeU32(static_cast<uint32_t>(strands), &b);
  storeU32(static_cast<uint32_t>(n), &b);
  storeU32(data.flags(), &b);
  storeU32(data.default_segments, &b);
  storeF32(data.default_thickness, &b);
  storeF32(data.default_transparency, &b);
  for (int k = 0; k < 3; ++k) storeF32(data.default_color[k], &b);
  {
    uint8_t info[kHairInfoBytes] = {};
    const size_t len = std::min(data.info.size(), kHairInfoBytes - 1);
    std::memcpy(info, data.info.data(), len);
    b.insert(b.end(), info, info + kHairInfoBytes);
  }
  if (data.write_segments_array) {
    for (uint64_t s = 0; s < strands; ++s) {
      storeU16(static_cast<uint16_t>(data.strand_offsets[s + 1] - data.strand_offsets[s] - 1), &b);
    }
  }
  for (float f : data.points) storeF32(f, &b);
  for (float f : data.thickness) storeF32(f, &b);
  for (float f : data.transparency) storeF32(f, &b);
  for (float f : data.colors) storeF32(f, &b);
  *bytes = std::move(b);
  return true;
}

bool writeHairFile(const std::string& path, const HairFileData& data, std::string* error) {
  std::vector<uint8_t> bytes;
  std::string why;
  if (!serializeHair(data, &bytes, &why)) {
    setError(error, path + ": " + why);
    return false;
  }
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) {
    setError(error, path + ": cannot open for writing");
    return false;
  }
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) {
    setError(error, path + ": write error");
    return false;
  }
  return true;
}

// ------------------------------------------------------------------------------ axes

bool parseUpAxis(const std::string& s, UpAxis* out, std::string* error) {
  std::string t = s;
  bool negative = false;
  if (!t.empty() && (t[0] == '-' || t[0] == '+')) {
    negative = t[0] == '-';
    t = t.substr(1);
  }
  UpAxis axis;
  if (t == "x") {
    axis = negative ? UpAxis::kNegXUp : UpAxis::kXUp;
  } else if (t == "y") {
    axis = negative ? UpAxis::kNegYUp : UpAxis::kYUp;
  } else if (t == "z") {
    axis = negative ? UpAxis::kNegZUp : UpAxis::kZUp;
  } else {
    setError(error, "up axis \"" + s + "\" is not one of x, y, z, -x, -y, -z");
    return false;
  }
  if (out == nullptr) {
    setError(error, "parseUpAxis: output is null");
    return false;
  }
  *out = axis;
  return true;
}

std::string upAxisName(UpAxis up) {
  switch (up) {
    case UpAxis::kXUp:
      return "x";
    case UpAxis::kYUp:
      return "y";
    case UpAxis::kZUp:
      return "z";
    case UpAxis::kNegXUp:
      return "-x";
    case UpAxis::kNegYUp:
      return "-y";
    case UpAxis::kNegZUp:
      return "-z";
  }
  return "?";
}

Mat3 upAxisRotation(UpAxis up) {
  Mat3 positive = Mat3::Identity();
  // Rows give the REP-103 coordinates as file coordinates.
  switch (up) {
    case UpAxis::kXUp:
    case UpAxis::kNegXUp:
      positive << 0, 1, 0,  // x_r = y_f
          0, 0, 1,          // y_r = z_f
          1, 0, 0;          // z_r = x_f
      break;
    case UpAxis::kYUp:
    case UpAxis::kNegYUp:
      positive << 0, 0, 1,  // x_r = z_f
          1, 0, 0,          // y_r = x_f
          0, 1, 0;          // z_r = y_f
      break;
    case UpAxis::kZUp:
    case UpAxis::kNegZUp:
      break;
  }
  if (up == UpAxis::kNegXUp || up == UpAxis::kNegYUp || up == UpAxis::kNegZUp) {
    const Mat3 half_turn_x = Vec3(1.0, -1.0, -1.0).asDiagonal();
    return half_turn_x * positive;
  }
  return positive;
}

// ------------------------------------------------------------------------------ resampling

namespace {

// Walks `steps` chords of length c along the polyline from its first point. Each step goes to
// the first point further along the polyline at distance c from the current point. Returns the
// arc-length position of the last point reached minus the total length L, or, when the walk ran
// off the tip, c times the number of chords left (> 0). Fills `pts` with the points reached
// (steps + 1 of them when it did not run off).
double walkChords(const Vec3List& poly, const std::vector<double>& arc, double c, int steps,
                  Vec3List* pts) {
  const size_t nseg = poly.size() - 1;
  const double total = arc.back();
  if (pts != nullptr) {
    pts->clear();
    pts->push_back(poly.front());
  }
  Vec3 q = poly.front();
  size_t seg = 0;
  double t_lo = 0.0;  // parameter of q on segment `seg`.
  for (int k = 0; k < steps; ++k) {
    bool found = false;
    while (seg < nseg) {
      const Vec3 a = poly[seg];
      const Vec3 d = poly[seg + 1] - a;
      const double A = d.squaredNorm();
      if (A > 0.0) {
        const Vec3 e = a - q;
        const double B = 2.0 * d.dot(e);
        const double C = e.squaredNorm() - c * c;
        const double disc = B * B - 4.0 * A * C;
        if (disc >= 0.0) {
          // Larger root: where the distance to q grows through c.
          const double sq = std::sqrt(disc);
          const double t = (B <= 0.0) ? (-B + sq) / (2.0 * A) : (-2.0 * C) / (B + sq);
          if (t >= t_lo && t <= 1.0) {
            q = a + t * d;
            t_lo = t;
            found = true;
            break;
          }
        }
      }
      ++seg;
      t_lo = 0.0;
    }
    if (!found) {
      // Ran off the tip with steps - k chords still to go.
      return c * (steps - k);
    }
    if (pts != nullptr) pts->push_back(q);
  }
  const double pos = arc[seg] + t_lo * (arc[seg + 1] - arc[seg]);
  return pos - total;
}

}  // namespace

bool resampleEqualChord(const Vec3List& in, int count, Vec3List* out, std::string* error) {
  if (out == nullptr) {
    setError(error, "resampleEqualChord: output is null");
    return false;
  }
  if (count < 2) {
    setError(error, "resample count " + std::to_string(count) + " is below 2");
    return false;
  }
  if (in.size() < 2) {
    setError(error, "polyline has " + std::to_string(in.size()) + " points, needs at least 2");
    return false;
  }
  std::vector<double> arc(in.size(), 0.0);
  for (size_t i = 0; i + 1 < in.size(); ++i) {
    if (!in[i].allFinite() || !in[i + 1].allFinite()) {
      setError(error, "polyline point " + std::to_string(i) + " is not finite");
      return false;
    }
    arc[i + 1] = arc[i] + (in[i + 1] - in[i]).norm();
  }
  const double total = arc.back();
  if (!(total > 0.0) || !std::isfinite(total)) {
    setError(error, "polyline total length is 0 (or not finite): cannot resample");
    return false;
  }
  const int steps = count - 1;
  // Chords are never longer than the arc they span, so c = L / steps reaches or passes the tip;
  // a tiny c stays near the root.
  double hi = total / steps;
  double lo = 0.0;
  if (walkChords(in, arc, hi, steps, nullptr) < 0.0) {
    // Numerically just short of the tip (straight polyline): grow hi until it passes.
    for (int it = 0; it < 1000 && walkChords(in, arc, hi, steps, nullptr) < 0.0; ++it) {
      hi *= 1.0 + 1e-12;
    }
  }
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    if (walkChords(in, arc, mid, steps, nullptr) < 0.0) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  Vec3List pts;
  // Prefer the walk that stays on the polyline (lo), unless lo is 0 (count large vs. precision).
  double c = lo > 0.0 ? lo : hi;
  walkChords(in, arc, c, steps, &pts);
  if (static_cast<int>(pts.size()) < count) {
    walkChords(in, arc, hi, steps, &pts);
  }
  pts.resize(static_cast<size_t>(count), in.back());
  pts.back() = in.back();
  for (size_t i = 0; i + 1 < pts.size(); ++i) {
    if (!((pts[i + 1] - pts[i]).norm() > 0.0)) {
      setError(error, "resampled edge " + std::to_string(i) + " has length 0");
      return false;
    }
  }
  *out = std::move(pts);
  return true;
}

// ------------------------------------------------------------------------------ import / export

namespace {

std::string metres(double v) {
  std::ostringstream m;
  m << v << " m";
  return m.str();
}

// Brings strand `s` of `file` into the head frame and checks that it can be simulated. Returns
// false with `*reason` (why the strand is skipped) or true with the strand's points in `*out`
// (repeats dropped, resampled when asked) and the number of dropped repeats in `*repeats`.
bool importStrand(const HairFileData& file, int s, const HairImportOptions& opts, const Mat3& R,
                  Vec3List* out, int* repeats, std::string* reason) {
  const uint32_t b = file.strand_offsets[s];
  const uint32_t e = file.strand_offsets[s + 1];
  const int n = static_cast<int>(e - b);
  if (n < kHairMinStrandPoints) {
    *reason = std::to_string(n) + (n == 1 ? " point" : " points");
    return false;
  }
  Vec3List& strand = *out;
  strand.clear();
  double length = 0.0;
  *repeats = 0;
  for (uint32_t i = b; i < e; ++i) {
    const Vec3 pf(file.points[3 * i], file.points[3 * i + 1], file.points[3 * i + 2]);
    const Vec3 p = opts.scale * (R * pf) + opts.offset_m;
    if (!pf.allFinite() || !p.allFinite()) {
      *reason = "non-finite point " + std::to_string(i - b) +
                (pf.allFinite() ? std::string(" after scaling") : std::string(" in the file"));
      return false;
    }
    // A point within kHairRepeatPointM of the previous kept one repeats it: dropping it keeps the
    // strand's shape and gives no zero-length edge.
    if (!strand.empty() && !((p - strand.back()).norm() >= kHairRepeatPointM)) {
      ++*repeats;
      continue;
    }
    if (!strand.empty()) length += (p - strand.back()).norm();
    strand.push_back(p);
  }
  if (!(length >= kHairMinStrandLengthM)) {
    *reason = "length " + metres(length) + ", below " + metres(kHairMinStrandLengthM);
    return false;
  }
  if (static_cast<int>(strand.size()) < kHairMinStrandPoints) {
    *reason = std::to_string(strand.size()) + " distinct points once " + std::to_string(*repeats) +
              " repeated ones are dropped";
    return false;
  }
  if (opts.min_edge_m > 0.0 && !(length >= 2.0 * opts.min_edge_m)) {
    *reason = "length " + metres(length) + ", shorter than two edges of min_edge_m " +
              metres(opts.min_edge_m);
    return false;
  }
  int count = opts.resample_particles;
  if (opts.min_edge_m > 0.0 && count == 0 && opts.resample_edge_m == 0.0 &&
      length / (strand.size() - 1) < opts.min_edge_m)
    count =
        std::max(kHairMinStrandPoints, static_cast<int>(std::floor(length / opts.min_edge_m)) + 1);
  if (opts.resample_edge_m > 0.0) {
    const double edges = std::round(length / opts.resample_edge_m);
    if (!(edges + 1.0 <= kHairMaxResampledPoints)) {
      *reason = "length " + metres(length) + " needs more than " +
                std::to_string(kHairMaxResampledPoints) + " points at resample_edge_m " +
                metres(opts.resample_edge_m);
      return false;
    }
    count = static_cast<int>(std::max<double>(kHairMinStrandPoints, edges + 1.0));
  }
  if (count > 0) {
    Vec3List resampled;
    std::string why;
    if (!resampleEqualChord(strand, count, &resampled, &why)) {
      *reason = "resampling to " + std::to_string(count) + " points: " + why;
      return false;
    }
    for (size_t i = 0; i + 1 < resampled.size(); ++i) {
      if (!((resampled[i + 1] - resampled[i]).norm() >= kHairRepeatPointM)) {
        *reason = "resampled to " + std::to_string(count) + " points, edge " + std::to_string(i) +
                  " is shorter than " + metres(kHairRepeatPointM);
        return false;
      }
    }
    strand.swap(resampled);
  }
  return true;
}

bool checkImportOptions(const HairImportOptions& opts, std::string* error) {
  std::ostringstream m;
  if (!(opts.scale > 0.0) || !std::isfinite(opts.scale)) {
    m << "import option scale is " << opts.scale << ": must be finite and > 0 (metres per unit)";
  } else if (!opts.offset_m.allFinite()) {
    m << "import option offset_m is not finite";
  } else if (!opts.head_center_m.allFinite()) {
    m << "import option head_center_m is not finite";
  } else if (opts.resample_particles < 0 || opts.resample_particles == 1) {
    m << "import option resample_particles is " << opts.resample_particles
      << ": must be 0 (keep the file's points) or >= 2";
  } else if (!(opts.resample_edge_m >= 0.0) || !std::isfinite(opts.resample_edge_m)) {
    m << "import option resample_edge_m is " << opts.resample_edge_m
      << ": must be 0 (off) or a finite length > 0, m";
  } else if (!(opts.min_edge_m >= 0.0) || !std::isfinite(opts.min_edge_m)) {
    m << "import option min_edge_m is " << opts.min_edge_m
      << ": must be 0 (off) or a finite length > 0, m";
  } else if (!opts.scalp.center_m.allFinite() || !opts.scalp.radii_m.allFinite() ||
             !(opts.scalp.radii_m.minCoeff() > 0.0)) {
    m << "import option scalp needs a finite centre and finite radii > 0, m";
  } else if (opts.resample_edge_m > 0.0 && opts.resample_particles > 0) {
    m << "import options resample_particles (" << opts.resample_particles
      << ") and resample_edge_m (" << opts.resample_edge_m
      << " m) are both set: choose one (the other 0)";
  } else {
    return true;
  }
  setError(error, m.str());
  return false;
}

}  // namespace

std::string HairImportReport::warning() const {
  if (skipped.empty()) return "";
  std::ostringstream m;
  m << "skipped " << skipped.size() << " of " << strands_in_file
    << " strands of the file (not simulated): ";
  const size_t named = std::min<size_t>(skipped.size(), kHairMaxNamedSkips);
  for (size_t k = 0; k < named; ++k) {
    m << (k > 0 ? ", " : "") << "strand " << skipped[k].index << " (" << skipped[k].reason << ")";
  }
  if (skipped.size() > named) m << ", and " << skipped.size() - named << " more";
  return m.str();
}

std::string HairImportReport::scalpSummary() const {
  const ScalpPlacement& p = scalp_placement;
  if (p.strands_moved == 0) return "";
  std::ostringstream m;
  m << "roots_on_scalp moved " << p.strands_moved << " of " << strands_imported
    << " strands onto the head's ellipsoid, the farthest by " << metres(p.largest_move_m) << "; "
    << p.particles_inside << " particles start inside it (the first step pushes them out)";
  return m.str();
}

std::string HairImportReport::rootsInsideWarning() const {
  if (roots_inside.count == 0) return "";
  std::ostringstream m;
  m << roots_inside.count << " of " << strands_imported
    << " roots lie inside the head's ellipsoid, the deepest by " << metres(roots_inside.deepest_m)
    << ": each holds its strand's first edge against the head; roots_on_scalp: true moves every "
       "strand onto the scalp";
  return m.str();
}

bool importHairAsGroom(const HairFileData& file, const HairImportOptions& opts, Groom* groom,
                       std::string* error, HairImportReport* report) {
  if (groom == nullptr) {
    setError(error, "importHairAsGroom: output is null");
    return false;
  }
  if (!checkImportOptions(opts, error)) return false;
  std::string why;
  if (!validateHairData(file, &why)) {
    setError(error, "hair data: " + why);
    return false;
  }
  const Mat3 R = upAxisRotation(opts.up);
  Groom g;
  g.strand_offsets.assign(1, 0u);
  HairImportReport r;
  r.strands_in_file = file.strandCount();
  Vec3List strand;
  for (int s = 0; s < r.strands_in_file; ++s) {
    int repeats = 0;
    std::string reason;
    if (!importStrand(file, s, opts, R, &strand, &repeats, &reason)) {
      r.skipped.push_back({s, reason});
      continue;
    }
    r.repeated_points_dropped += repeats;
    Vec3 normal = strand.front() - opts.head_center_m;
    if (!(normal.norm() > 0.0)) normal = strand[1] - strand[0];
    normal.stableNormalize();  // no overflow of the squared norm for far-away points
    g.root_normals.push_back(normal);
    g.points.insert(g.points.end(), strand.begin(), strand.end());
    g.strand_offsets.push_back(static_cast<uint32_t>(g.points.size()));
  }
  r.strands_imported = g.strandCount();
  if (r.strands_imported == 0) {
    setError(error, "none of the " + std::to_string(r.strands_in_file) +
                        " strands can be simulated: " + r.warning());
    return false;
  }
  if (opts.roots_on_scalp) r.scalp_placement = placeRootsOnScalp(opts.scalp, &g);
  r.roots_inside = rootsInside(opts.scalp, g, kHairRootInsideM);
  if (!g.validate(&why)) {  // Safety net: the checks above should already guarantee this.
    setError(error, "imported groom is invalid: " + why);
    return false;
  }
  *groom = std::move(g);
  if (report != nullptr) *report = std::move(r);
  return true;
}

bool groomPositionsToHairChecked(const std::vector<uint32_t>& strand_offsets,
                                 const Vec3List& positions_m, const std::vector<double>* saturation,
                                 HairFileData* out, std::string* error) {
  if (out == nullptr) {
    setError(error, "groomPositionsToHair: output is null");
    return false;
  }
  std::ostringstream m;
  if (strand_offsets.size() < 2 || strand_offsets.front() != 0 ||
      strand_offsets.back() != positions_m.size()) {
    m << "strand_offsets (" << strand_offsets.size() << " entries, last "
      << (strand_offsets.empty() ? 0 : strand_offsets.back())
      << ") do not start at 0 and end at the particle count " << positions_m.size();
    setError(error, m.str());
    return false;
  }
  for (size_t s = 0; s + 1 < strand_offsets.size(); ++s) {
    if (strand_offsets[s + 1] < strand_offsets[s]) {
      m << "strand_offsets decrease at strand " << s;
      setError(error, m.str());
      return false;
    }
  }
  for (size_t i = 0; i < positions_m.size(); ++i) {
    // The format holds non-finite values, but an exported frame with them is a broken state.
    if (!positions_m[i].allFinite()) {
      m << "position " << i << " is not finite";
      setError(error, m.str());
      return false;
    }
  }
  if (saturation != nullptr && saturation->size() != positions_m.size()) {
    m << "saturation has " << saturation->size() << " values, expected one per particle ("
      << positions_m.size() << ")";
    setError(error, m.str());
    return false;
  }
  HairFileData d;
  d.strand_offsets = strand_offsets;
  d.points.reserve(3 * positions_m.size());
  for (const Vec3& p : positions_m) {
    for (int k = 0; k < 3; ++k) d.points.push_back(static_cast<float>(p[k]));
  }
  d.write_segments_array = true;
  const uint32_t first = strand_offsets[1] - strand_offsets[0];
  bool uniform = first >= 1;
  for (size_t s = 0; s + 1 < strand_offsets.size(); ++s) {
    uniform = uniform && strand_offsets[s + 1] - strand_offsets[s] == first;
  }
  d.default_segments = uniform ? first - 1 : 0;
  d.info = "wet_curly_hair: metres, z up (REP-103)";
  if (saturation != nullptr) {
    d.info += "; transparency = saturation";
    d.transparency.reserve(saturation->size());
    d.colors.reserve(3 * saturation->size());
    for (double s : *saturation) {
      d.transparency.push_back(static_cast<float>(s));
      const double c = std::isfinite(s) ? std::clamp(s, 0.0, 1.0) : 0.0;
      d.colors.push_back(static_cast<float>(1.0 - 0.7 * c));
      d.colors.push_back(static_cast<float>(1.0 - 0.4 * c));
      d.colors.push_back(1.f);
    }
  }
  *out = std::move(d);
  return true;
}

HairFileData groomPositionsToHair(const std::vector<uint32_t>& strand_offsets,
                                  const Vec3List& positions_m,
                                  const std::vector<double>* saturation) {
  HairFileData d;
  if (!groomPositionsToHairChecked(strand_offsets, positions_m, saturation, &d, nullptr)) {
    return HairFileData();
  }
  return d;
}

}  // namespace io
}  // namespace wet_curly_hair
