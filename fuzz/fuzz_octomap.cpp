// libFuzzer target: io::octreeFromFileContents (.bt / .ot files) and
// io::octreeFromMessagePayload (octomap_msgs/Octomap payloads) on arbitrary bytes.
//
// Input layout: bytes starting with '#' are a whole OctoMap file. Anything else is a message:
// byte 0 picks binary (bit 0), the id (bits 1-2: OcTree, ColorOcTree, "1", "OcTreeStamped") and
// the resolution (bits 3-5, from a table that includes invalid values); the rest is the payload.
//
// Invariants checked (each violation traps):
//  - a refused input sets a non-empty message and leaves the output tree pointer unchanged;
//  - an accepted tree is non-empty, has the requested resolution, its node count agrees with
//    calcNumNodes() and, for files, with the header's size line; every leaf is at depth <= 16
//    with finite log-odds and finite coordinates;
//  - the accepted tree written back as .bt and as .ot files and as a binary message payload is
//    accepted again with the same node count.
#include <octomap/OcTree.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "wet_curly_hair/io/octomap_sdf.h"

using namespace wet_curly_hair;
using namespace wet_curly_hair::io;

namespace {

void check(bool ok) {
  if (!ok) __builtin_trap();
}

/// The value of the header's "size" line (the first one, as the reader takes it), or -1.
long long headerSize(const std::string& contents) {
  std::istringstream in(contents);
  std::string line;
  std::getline(in, line);  // first line
  long long value = -1;
  while (std::getline(in, line)) {
    std::istringstream words(line);
    std::string key, v;
    if (!(words >> key)) continue;
    if (key == "data") break;
    if (key == "size" && (words >> v)) value = std::strtoll(v.c_str(), nullptr, 10);
  }
  return value;
}

void checkTree(const octomap::OcTree& tree, double res) {
  check(tree.size() > 0);
  check(tree.getResolution() == res);
  check(tree.calcNumNodes() == tree.size());
  size_t leaves = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    check(it.getDepth() <= 16);
    check(std::isfinite(it->getLogOdds()));
    const octomap::point3d c = it.getCoordinate();
    check(std::isfinite(c.x()) && std::isfinite(c.y()) && std::isfinite(c.z()));
    ++leaves;
  }
  check(leaves >= 1);
}

void checkRewrites(const octomap::OcTree& tree) {
  std::string why;
  {
    std::ostringstream bt;
    check(tree.writeBinaryConst(bt));
    std::unique_ptr<octomap::OcTree> again;
    check(octreeFromFileContents(bt.str(), &again, &why));
    check(again && again->size() == tree.size());
  }
  {
    std::ostringstream ot;
    check(tree.write(ot));
    std::unique_ptr<octomap::OcTree> again;
    check(octreeFromFileContents(ot.str(), &again, &why));
    check(again && again->size() == tree.size());
  }
  {
    std::ostringstream payload;
    tree.writeBinaryData(payload);
    const std::string s = payload.str();
    const std::vector<int8_t> bytes(s.begin(), s.end());
    std::unique_ptr<octomap::OcTree> again;
    check(octreeFromMessagePayload(true, "OcTree", tree.getResolution(), bytes, &again, &why));
    check(again && again->size() == tree.size());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  std::unique_ptr<octomap::OcTree> tree;
  octomap::OcTree* const before = new octomap::OcTree(0.5);  // a loaded tree that must survive
  tree.reset(before);
  std::string why;
  if (data[0] == '#') {
    const std::string contents(reinterpret_cast<const char*>(data), size);
    if (!octreeFromFileContents(contents, &tree, &why)) {
      check(!why.empty());
      check(tree.get() == before && tree->getResolution() == 0.5);
      return 0;
    }
    check(tree && tree.get() != before);
    const long long declared = headerSize(contents);
    check(declared >= 0 && static_cast<unsigned long long>(declared) == tree->size());
    checkTree(*tree, tree->getResolution());
  } else {
    static const char* const kIds[4] = {"OcTree", "ColorOcTree", "1", "OcTreeStamped"};
    static const double kRes[8] = {0.05, 0.1, 0.01, 1.0, 1e-6, 0.0, -0.1, NAN};
    const bool binary = (data[0] & 1) != 0;
    const std::string id = kIds[(data[0] >> 1) & 3];
    const double res = kRes[(data[0] >> 3) & 7];
    const std::vector<int8_t> payload(data + 1, data + size);
    if (!octreeFromMessagePayload(binary, id, res, payload, &tree, &why)) {
      check(!why.empty());
      check(tree.get() == before && tree->getResolution() == 0.5);
      return 0;
    }
    check(tree && tree.get() != before);
    checkTree(*tree, res);
  }
  checkRewrites(*tree);
  return 0;
}
