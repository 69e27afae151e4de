#include "wet_curly_hair/io/octomap_sdf.h"

#include <octomap/AbstractOcTree.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/edt.h"

namespace wet_curly_hair {
namespace io {
namespace {

/// Depth of an octomap OcTree: the root is at depth 0, the finest leaves at depth 16.
constexpr int kTreeDepth = 16;
/// First lines of the two file formats (octomap's AbstractOccupancyOcTree::binaryFileHeader and
/// AbstractOcTree::fileHeader; a line must start with them).
const char* const kBinaryFileHeader = "# Octomap OcTree binary file";
const char* const kFullFileHeader = "# Octomap OcTree file";
/// Longest ASCII header accepted, bytes.
constexpr size_t kMaxHeaderBytes = 65536;

bool fail(std::string* error, const std::string& what) {
  if (error) *error = what;
  return false;
}

std::string excerpt(const std::string& s) {
  // Printable excerpt of untrusted text for messages: at most 40 characters, others escaped.
  std::ostringstream o;
  o << '\'';
  for (size_t i = 0; i < s.size() && i < 40; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      o << static_cast<char>(c);
    } else {
      static const char* hex = "0123456789abcdef";
      o << "\\x" << hex[c >> 4] << hex[c & 15];
    }
  }
  if (s.size() > 40) o << "...";
  o << '\'';
  return o.str();
}

bool checkResolution(const std::string& what, double res, std::string* error) {
  if (!std::isfinite(res) || res < kMinOctreeResolution || res > kMaxOctreeResolution) {
    std::ostringstream s;
    s << what << ": resolution " << res << " m is invalid, it must be a finite number in ["
      << kMinOctreeResolution << ", " << kMaxOctreeResolution << "] m";
    return fail(error, s.str());
  }
  return true;
}

/// Maps a tree id to the one we read; false for unsupported ids.
bool supportedId(const std::string& id, std::string* canonical) {
  if (id == "OcTree" || id == "1") {  // "1": octomap's deprecated id for OcTree.
    *canonical = "OcTree";
    return true;
  }
  if (id == "ColorOcTree") {
    *canonical = id;
    return true;
  }
  return false;
}

/// Validates the .bt bit stream of a node at `depth` whose two child-code bytes start at *pos
/// (octomap's OccupancyOcTreeBase::readBinaryNode layout: 2 bits per child, 01 occupied leaf,
/// 10 free leaf, 11 inner node, 00 none; the inner children follow depth first, in child order).
bool walkBinary(const uint8_t* d, size_t n, size_t* pos, int depth, uint64_t* count,
                std::string* error) {
  if (n - *pos < 2) {
    std::ostringstream s;
    s << "the node stream is truncated: it ends at byte " << n
      << " inside the child codes of a node at depth " << depth;
    return fail(error, s.str());
  }
  const uint8_t codes[2] = {d[*pos], d[*pos + 1]};
  if (depth > 0 && codes[0] == 0 && codes[1] == 0) {
    std::ostringstream s;
    s << "a node at depth " << depth << " is marked as having children but has none (byte " << *pos
      << ")";
    return fail(error, s.str());
  }
  *pos += 2;
  bool inner[8];
  for (int i = 0; i < 8; ++i) {
    const int shift = (i % 4) * 2;
    const int code = (codes[i / 4] >> shift) & 3;  // bit 0: first bit, bit 1: second bit.
    inner[i] = code == 3;
    if (code != 0) ++*count;
    if (inner[i] && depth + 1 >= kTreeDepth) {
      std::ostringstream s;
      s << "a node at depth " << depth + 1 << " has children, but an octree has only " << kTreeDepth
        << " levels below its root (byte " << *pos - 2 << ")";
      return fail(error, s.str());
    }
  }
  for (int i = 0; i < 8; ++i) {
    if (inner[i] && !walkBinary(d, n, pos, depth + 1, count, error)) return false;
  }
  return true;
}

/// Validates the .ot node stream of a node at `depth` starting at *pos (octomap's
/// OcTreeBaseImpl::readNodesRecurs layout: node data, one byte of child flags, the children depth
/// first). node_bytes: 4 (OcTree: float log-odds) or 7 (ColorOcTree: log-odds and r, g, b).
/// If converted is given, the OcTree stream (log-odds and flags only) is appended to it.
bool walkFull(const uint8_t* d, size_t n, size_t* pos, int depth, size_t node_bytes,
              uint64_t* count, std::string* converted, std::string* error) {
  if (n - *pos < node_bytes + 1) {
    std::ostringstream s;
    s << "the node stream is truncated: it ends at byte " << n << " inside node " << *count
      << " (depth " << depth << ")";
    return fail(error, s.str());
  }
  float log_odds = 0.0f;
  std::memcpy(&log_odds, d + *pos, sizeof(float));
  if (!std::isfinite(log_odds)) {
    std::ostringstream s;
    s << "node " << *count << " (byte " << *pos << ", depth " << depth << ") has log-odds "
      << log_odds << ", which is not finite";
    return fail(error, s.str());
  }
  const uint8_t children = d[*pos + node_bytes];
  if (converted) {
    converted->append(reinterpret_cast<const char*>(d + *pos), sizeof(float));
    converted->push_back(static_cast<char>(children));
  }
  *pos += node_bytes + 1;
  ++*count;
  if (children != 0 && depth >= kTreeDepth) {
    std::ostringstream s;
    s << "node " << *count - 1 << " at depth " << depth << " has children, but an octree has only "
      << kTreeDepth << " levels below its root";
    return fail(error, s.str());
  }
  for (int i = 0; i < 8; ++i) {
    if ((children >> i) & 1) {
      if (!walkFull(d, n, pos, depth + 1, node_bytes, count, converted, error)) return false;
    }
  }
  return true;
}

/// Validates a node stream completely, then reads it into a fresh OcTree with octomap's own
/// data reader. expected_nodes null: no node count to check. `what` prefixes messages.
bool treeFromStream(const std::string& what, bool binary, const std::string& id, double res,
                    const uint8_t* data, size_t n, const uint64_t* expected_nodes,
                    std::unique_ptr<octomap::OcTree>* tree, std::string* error) {
  std::string canonical;
  if (!supportedId(id, &canonical)) {
    return fail(error, what + ": tree id " + excerpt(id) +
                           " is not supported (only OcTree and ColorOcTree are)");
  }
  if (!checkResolution(what, res, error)) return false;
  if (n == 0) return fail(error, what + ": the tree is empty (no node data)");

  uint64_t count = 0;
  size_t pos = 0;
  std::string err;
  std::string converted;
  const bool convert = !binary && canonical == "ColorOcTree";
  bool ok;
  if (binary) {
    count = 1;  // The root; walkBinary counts the children.
    ok = walkBinary(data, n, &pos, 0, &count, &err);
  } else {
    if (convert) converted.reserve(n);
    ok = walkFull(data, n, &pos, 0, convert ? 7 : 4, &count, convert ? &converted : nullptr, &err);
  }
  if (!ok) return fail(error, what + ": " + err);
  if (pos != n) {
    std::ostringstream s;
    s << what << ": " << n - pos << " unexpected bytes follow the end of the tree at byte " << pos;
    return fail(error, s.str());
  }
  if (expected_nodes != nullptr && *expected_nodes != count) {
    std::ostringstream s;
    s << what << ": the header says size " << *expected_nodes << " but the data holds " << count
      << " nodes";
    return fail(error, s.str());
  }

  std::unique_ptr<octomap::OcTree> result;
  if (binary) {
    result = std::make_unique<octomap::OcTree>(res);
    std::istringstream in(std::string(reinterpret_cast<const char*>(data), n));
    result->readBinaryData(in);
  } else {
    std::unique_ptr<octomap::AbstractOcTree> abstract(
        octomap::AbstractOcTree::createTree("OcTree", res));
    auto* as_octree = dynamic_cast<octomap::OcTree*>(abstract.get());
    if (!as_octree) return fail(error, what + ": octomap could not create an OcTree");
    abstract.release();
    result.reset(as_octree);
    std::istringstream in(convert ? converted
                                  : std::string(reinterpret_cast<const char*>(data), n));
    result->readData(in);
  }
  if (result->size() != count) {
    std::ostringstream s;
    s << what << ": octomap read " << result->size() << " nodes where the stream holds " << count;
    return fail(error, s.str());
  }
  *tree = std::move(result);
  return true;
}

/// Parses an unsigned decimal integer that makes up all of `token`.
bool parseUnsigned(const std::string& token, uint64_t* value) {
  if (token.empty() || token.size() > 19) return false;
  uint64_t v = 0;
  for (char c : token) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  *value = v;
  return true;
}

/// Parses a floating-point number that makes up all of `token` (nan and inf included, so that
/// they can be refused by name).
bool parseDouble(const std::string& token, double* value) {
  if (token.empty() || token.size() > 64) return false;
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (end != token.c_str() + token.size()) return false;
  *value = v;
  return true;
}

}  // namespace

bool octreeFromFileContents(const std::string& contents, std::unique_ptr<octomap::OcTree>* tree,
                            std::string* error) {
  const std::string what = "OctoMap file";
  try {
    if (!tree) return fail(error, what + ": tree is null");
    if (contents.empty()) return fail(error, what + ": the file is empty");

    // First line.
    const size_t first_end = contents.find('\n');
    if (first_end == std::string::npos || first_end > kMaxHeaderBytes) {
      return fail(error, what + ": no OctoMap header (the first line does not end in the first " +
                             std::to_string(kMaxHeaderBytes) + " bytes); starts with " +
                             excerpt(contents.substr(0, 40)));
    }
    const std::string first = contents.substr(0, first_end);
    bool binary;
    if (first.compare(0, std::strlen(kBinaryFileHeader), kBinaryFileHeader) == 0) {
      binary = true;
    } else if (first.compare(0, std::strlen(kFullFileHeader), kFullFileHeader) == 0) {
      binary = false;
    } else {
      return fail(error, what + ": the first line " + excerpt(first) + " is neither '" +
                             kBinaryFileHeader + "' (.bt) nor '" + kFullFileHeader + "' (.ot)");
    }

    // Header lines up to "data".
    std::string id;
    uint64_t size = 0;
    double res = 0.0;
    bool has_id = false, has_size = false, has_res = false, has_data = false;
    size_t pos = first_end + 1;
    int line_no = 1;
    while (!has_data) {
      const size_t end = contents.find('\n', pos);
      if (end == std::string::npos) {
        return fail(error, what + ": the header ends before its 'data' line" +
                               (has_id && has_size && has_res ? std::string()
                                                              : " (id, size and res are needed)"));
      }
      if (end > kMaxHeaderBytes) {
        return fail(error, what + ": the header is longer than " + std::to_string(kMaxHeaderBytes) +
                               " bytes");
      }
      ++line_no;
      std::istringstream line(contents.substr(pos, end - pos));
      pos = end + 1;
      std::string key, value, extra;
      if (!(line >> key)) continue;  // Blank line.
      if (key[0] == '#') continue;   // Comment.
      if (key == "data") {
        has_data = true;
        break;
      }
      const bool has_value = static_cast<bool>(line >> value);
      const bool has_extra = static_cast<bool>(line >> extra);
      const std::string where = " (header line " + std::to_string(line_no) + ")";
      if (key == "id" || key == "size" || key == "res") {
        if (!has_value || has_extra) {
          return fail(error,
                      what + ": header line '" + key + "' must hold exactly one value" + where);
        }
      }
      if (key == "id") {
        id = value;
        has_id = true;
      } else if (key == "size") {
        if (!parseUnsigned(value, &size)) {
          return fail(error,
                      what + ": size " + excerpt(value) + " is not a non-negative integer" + where);
        }
        has_size = true;
      } else if (key == "res") {
        if (!parseDouble(value, &res)) {
          return fail(error, what + ": res " + excerpt(value) + " is not a number" + where);
        }
        has_res = true;
      }
      // Other keywords are skipped, as octomap does.
    }
    if (!has_id) return fail(error, what + ": the header has no 'id' line");
    if (!has_size) return fail(error, what + ": the header has no 'size' line");
    if (!has_res) return fail(error, what + ": the header has no 'res' line");
    if (!checkResolution(what + " header", res, error)) return false;
    std::string canonical;
    if (!supportedId(id, &canonical)) {
      return fail(error, what + ": tree id " + excerpt(id) +
                             " is not supported (only OcTree and ColorOcTree are)");
    }
    if (size == 0) return fail(error, what + ": the tree is empty (size 0 in the header)");
    return treeFromStream(what + (binary ? " (.bt)" : " (.ot)"), binary, canonical, res,
                          reinterpret_cast<const uint8_t*>(contents.data()) + pos,
                          contents.size() - pos, &size, tree, error);
  } catch (const std::bad_alloc&) {
    return fail(error, what + ": out of memory");
  } catch (const std::exception& e) {
    return fail(error, what + ": " + e.what());
  } catch (...) {
    return fail(error, what + ": unknown exception");
  }
}

bool loadOctreeFile(const std::string& path, std::unique_ptr<octomap::OcTree>* tree,
                    std::string* error) {
  try {
    if (!tree) return fail(error, "loadOctreeFile: tree is null");
    if (path.empty()) return fail(error, "loadOctreeFile: the path is empty");
    const std::string what = "OctoMap file '" + path + "'";
    std::error_code ec;
    const std::filesystem::file_status st = std::filesystem::status(path, ec);
    if (ec || !std::filesystem::exists(st)) return fail(error, what + " does not exist");
    if (std::filesystem::is_directory(st)) return fail(error, what + " is a directory");
    std::ifstream in(path, std::ios::binary);
    if (!in) return fail(error, what + " cannot be opened for reading");
    in.seekg(0, std::ios::end);
    const std::streamoff length = in.tellg();
    in.seekg(0, std::ios::beg);
    if (length < 0 || !in) return fail(error, what + " cannot be read");
    if (length == 0) return fail(error, what + " is empty");
    if (length > kMaxOctreeFileBytes) {
      return fail(error,
                  what + " is larger than " + std::to_string(kMaxOctreeFileBytes) + " bytes");
    }
    std::string contents(static_cast<size_t>(length), '\0');
    in.read(&contents[0], length);
    if (in.gcount() != length) return fail(error, what + " could not be read completely");
    std::string err;
    if (!octreeFromFileContents(contents, tree, &err)) {
      // Replace the generic prefix by the path.
      const std::string generic = "OctoMap file";
      if (err.compare(0, generic.size(), generic) == 0) err = what + err.substr(generic.size());
      return fail(error, err);
    }
    return true;
  } catch (const std::bad_alloc&) {
    return fail(error, "loadOctreeFile: out of memory reading '" + path + "'");
  } catch (const std::exception& e) {
    return fail(error, "loadOctreeFile: '" + path + "': " + e.what());
  } catch (...) {
    return fail(error, "loadOctreeFile: '" + path + "': unknown exception");
  }
}

bool octreeFromMessagePayload(bool binary, const std::string& id, double resolution,
                              const std::vector<int8_t>& data,
                              std::unique_ptr<octomap::OcTree>* tree, std::string* error) {
  const std::string what = binary ? "OctoMap message (binary)" : "OctoMap message (full)";
  try {
    if (!tree) return fail(error, what + ": tree is null");
    return treeFromStream(what, binary, id, resolution,
                          reinterpret_cast<const uint8_t*>(data.data()), data.size(), nullptr, tree,
                          error);
  } catch (const std::bad_alloc&) {
    return fail(error, what + ": out of memory");
  } catch (const std::exception& e) {
    return fail(error, what + ": " + e.what());
  } catch (...) {
    return fail(error, what + ": unknown exception");
  }
}

bool SdfBuildConfig::validate(const std::string& prefix, std::string* why) const {
  using namespace config_check;
  if (!positive(prefix + "resolution_m", resolution_m, why)) return false;
  if (!nonNegative(prefix + "margin_m", margin_m, why)) return false;
  if (max_cells < 1 || max_cells > kMaxEdtCells) {
    if (why) {
      std::ostringstream s;
      s << prefix << "max_cells: " << max_cells << " is outside the valid range [1, "
        << kMaxEdtCells << "]";
      *why = s.str();
    }
    return false;
  }
  return true;
}

namespace {

/// The field's voxel grid in the map frame and the per-voxel state while rasterising:
/// 0 unknown, 1 occupied, 2 free.
struct Raster {
  Eigen::Vector3d first_index;  ///< integer index (as double) of voxel 0: it spans
                                ///< [first_index * h, (first_index + 1) * h], m.
  Eigen::Vector3i dims;
  double h = 0.0;
  double tree_res = 0.0;
  bool mark_free = false;
  std::vector<uint8_t> state;
  int64_t leaves_used = 0;
  int64_t occupied_cells = 0;  ///< voxels in state 1.
};

/// Slack in voxel units: a leaf that only touches a voxel face does not overlap the voxel.
constexpr double kFaceSlack = 1e-6;
/// Slack in voxel units when snapping the box to voxel boundaries.
constexpr double kSnapSlack = 1e-9;

void rasteriseNode(const octomap::OcTree& tree, const octomap::OcTreeNode* node, int depth,
                   const uint32_t key0[3], Raster* r) {
  const uint32_t size_keys = uint32_t{1} << (kTreeDepth - depth);
  const double half_span = static_cast<double>(uint32_t{1} << (kTreeDepth - 1));
  double ua[3], ub[3];
  for (int a = 0; a < 3; ++a) {
    const double lo_m = (static_cast<double>(key0[a]) - half_span) * r->tree_res;
    const double hi_m = lo_m + static_cast<double>(size_keys) * r->tree_res;
    ua[a] = lo_m / r->h - r->first_index[a];
    ub[a] = hi_m / r->h - r->first_index[a];
    if (ub[a] <= kFaceSlack || ua[a] >= r->dims[a] - kFaceSlack) return;  // No overlap.
  }
  if (tree.nodeHasChildren(node)) {
    const uint32_t half = size_keys / 2;
    for (unsigned i = 0; i < 8; ++i) {
      if (!tree.nodeChildExists(node, i)) continue;
      const uint32_t child_key0[3] = {key0[0] + ((i & 1) ? half : 0),
                                      key0[1] + ((i & 2) ? half : 0),
                                      key0[2] + ((i & 4) ? half : 0)};
      rasteriseNode(tree, tree.getNodeChild(node, i), depth + 1, child_key0, r);
    }
    return;
  }
  ++r->leaves_used;
  const bool occupied = tree.isNodeOccupied(node);
  if (!occupied && !r->mark_free) return;
  int i0[3], i1[3];
  for (int a = 0; a < 3; ++a) {
    const double hi_cell = r->dims[a] - 1;
    double f0, f1;
    if (occupied) {  // Voxels overlapping the leaf with non-zero volume.
      f0 = std::floor(ua[a] + kFaceSlack);
      f1 = std::ceil(ub[a] - kFaceSlack) - 1.0;
    } else {  // Voxels whose centre lies in the leaf.
      f0 = std::ceil(ua[a] - 0.5 - kFaceSlack);
      f1 = std::ceil(ub[a] - 0.5 - kFaceSlack) - 1.0;
    }
    f0 = std::max(f0, 0.0);
    f1 = std::min(f1, hi_cell);
    if (f1 < f0) return;
    i0[a] = static_cast<int>(f0);
    i1[a] = static_cast<int>(f1);
  }
  const int64_t nx = r->dims.x(), slab = nx * r->dims.y();
  for (int z = i0[2]; z <= i1[2]; ++z) {
    for (int y = i0[1]; y <= i1[1]; ++y) {
      uint8_t* row = r->state.data() + z * slab + y * nx;
      if (occupied) {
        int64_t newly = 0;
        for (int x = i0[0]; x <= i1[0]; ++x) {
          newly += row[x] != 1;
          row[x] = 1;
        }
        r->occupied_cells += newly;
      } else {
        for (int x = i0[0]; x <= i1[0]; ++x) row[x] = row[x] == 0 ? 2 : row[x];
      }
    }
  }
}

std::string boxText(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::ostringstream s;
  s << "[" << lo.x() << ", " << lo.y() << ", " << lo.z() << "] - [" << hi.x() << ", " << hi.y()
    << ", " << hi.z() << "] m";
  return s.str();
}

}  // namespace

bool buildSdfFromOctree(const octomap::OcTree& tree, const Pose& tree_in_world,
                        const Eigen::AlignedBox3d& reach_box_world, const SdfBuildConfig& cfg,
                        DenseSdf* sdf, Pose* sdf_in_world, SdfBuildStats* stats,
                        std::string* error) {
  const std::string fn = "buildSdfFromOctree";
  using Clock = std::chrono::steady_clock;
  const Clock::time_point t0 = Clock::now();
  try {
    if (!sdf || !sdf_in_world) return fail(error, fn + ": sdf and sdf_in_world must not be null");
    std::string why;
    if (!cfg.validate("", &why)) return fail(error, fn + ": config " + why);
    if (!tree_in_world.isFinite()) {
      return fail(error, fn + ": tree_in_world has non-finite components");
    }
    const double qn = tree_in_world.rotation.norm();
    if (!(qn > 1e-9)) return fail(error, fn + ": tree_in_world has a zero quaternion");
    Pose map_in_world = tree_in_world;
    map_in_world.rotation.normalize();
    if (reach_box_world.isEmpty()) return fail(error, fn + ": reach_box_world is empty");
    if (!reach_box_world.min().allFinite() || !reach_box_world.max().allFinite()) {
      return fail(error, fn + ": reach_box_world has non-finite corners");
    }
    if (!tree.getRoot() || tree.size() == 0) return fail(error, fn + ": the tree has no nodes");
    if (tree.getTreeDepth() != static_cast<unsigned>(kTreeDepth)) {
      return fail(error, fn + ": the tree depth is " + std::to_string(tree.getTreeDepth()) +
                             ", only " + std::to_string(kTreeDepth) + " is supported");
    }
    std::string res_error;
    if (!checkResolution(fn + ": tree", tree.getResolution(), &res_error)) {
      return fail(error, res_error);
    }

    // The box in the map frame: bounding box of the transformed corners, grown by the margin.
    Eigen::AlignedBox3d box_map;
    for (int c = 0; c < 8; ++c) {
      const Vec3 corner = reach_box_world.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
      box_map.extend(map_in_world.applyInverse(corner));
    }
    const Vec3 lo_m = box_map.min().array() - cfg.margin_m;
    const Vec3 hi_m = box_map.max().array() + cfg.margin_m;
    const double h = cfg.resolution_m;

    Raster r;
    r.h = h;
    r.tree_res = tree.getResolution();
    r.mark_free = cfg.unknown_is_occupied;
    double cells_d = 1.0;
    for (int a = 0; a < 3; ++a) {
      // Snap outwards, ignoring rounding noise (a box edge at 6.0000000001 voxels is at 6).
      const double first = std::floor(lo_m[a] / h + kSnapSlack);
      const double last = std::ceil(hi_m[a] / h - kSnapSlack);
      const double n = std::max(1.0, last - first);
      if (!std::isfinite(first) || !std::isfinite(n) || n > 2147483647.0) {
        return fail(error, fn + ": the grid over " + boxText(lo_m, hi_m) + " at " +
                               std::to_string(h) + " m is too large");
      }
      r.first_index[a] = first;
      r.dims[a] = static_cast<int>(n);
      cells_d *= n;
    }
    if (cells_d > static_cast<double>(cfg.max_cells)) {
      std::ostringstream s;
      s << fn << ": the grid over " << boxText(lo_m, hi_m) << " (map frame, margin included) at "
        << h << " m has " << r.dims.x() << " x " << r.dims.y() << " x " << r.dims.z() << " = "
        << static_cast<int64_t>(cells_d) << " voxels, more than max_cells = " << cfg.max_cells;
      return fail(error, s.str());
    }
    const int64_t cells = static_cast<int64_t>(cells_d);
    r.state.assign(static_cast<size_t>(cells), 0);

    const uint32_t root_key0[3] = {0, 0, 0};
    rasteriseNode(tree, tree.getRoot(), 0, root_key0, &r);
    if (r.leaves_used == 0) {
      double x0, y0, z0, x1, y1, z1;
      tree.getMetricMin(x0, y0, z0);
      tree.getMetricMax(x1, y1, z1);
      return fail(error, fn + ": the reach box, " + boxText(lo_m, hi_m) +
                             " in the map frame with the margin, does not intersect the map, "
                             "whose leaves span " +
                             boxText(Vec3(x0, y0, z0), Vec3(x1, y1, z1)));
    }
    int64_t n_occupied = r.occupied_cells;
    if (cfg.unknown_is_occupied) {
      // 0 (unknown) and 1 (occupied) become 1, 2 (free) becomes 0.
      n_occupied = 0;
      uint8_t* state = r.state.data();
      const bool parallel = cells >= (int64_t{1} << 16);
#pragma omp parallel for schedule(static) reduction(+ : n_occupied) if (parallel)
      for (int64_t i = 0; i < cells; ++i) {
        const uint8_t occ = state[i] != 2;
        state[i] = occ;
        n_occupied += occ;
      }
    }  // Otherwise the state holds only 0 (free or unknown) and 1 (occupied) already.
    const Clock::time_point t1 = Clock::now();

    DenseSdf field;
    const Vec3 origin = (r.first_index.array() + 0.5) * h;
    std::string edt_error;
    if (!buildSignedDistanceField(r.state, r.dims, h, origin, &field, &edt_error)) {
      return fail(error, fn + ": " + edt_error);
    }
    const Clock::time_point t2 = Clock::now();

    if (stats) {
      SdfBuildStats st;
      st.dims = r.dims;
      st.cells = cells;
      st.occupied_cells = n_occupied;
      st.leaves_used = r.leaves_used;
      st.rasterise_s = std::chrono::duration<double>(t1 - t0).count();
      st.edt_s = std::chrono::duration<double>(t2 - t1).count();
      st.total_s = std::chrono::duration<double>(t2 - t0).count();
      st.memory_bytes = field.memoryBytes();
      *stats = st;
    }
    *sdf = std::move(field);
    *sdf_in_world = map_in_world;
    return true;
  } catch (const std::bad_alloc&) {
    return fail(error, fn + ": out of memory");
  } catch (const std::exception& e) {
    return fail(error, fn + ": " + e.what());
  } catch (...) {
    return fail(error, fn + ": unknown exception");
  }
}

}  // namespace io
}  // namespace wet_curly_hair
