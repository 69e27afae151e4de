// wet_curly_hair_make_octomap: writes an OctoMap (.bt) of analytic shapes, for tests and demos.
//   wet_curly_hair_make_octomap OUT.bt RESOLUTION_M SPEC [SPEC...]
// SPEC is an obstacle spec as the runner takes it (sphere:x=..,y=..,z=..,r=.., box:..., plane
// specs are refused: a plane is unbounded). Voxels whose centre is inside a shape are occupied;
// free space around the shapes (one shape size of margin) is marked free.
#include <octomap/octomap.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "wet_curly_hair/core/obstacles.h"

int main(int argc, char** argv) {
  using namespace wet_curly_hair;
  if (argc < 4) {
    std::fprintf(stderr, "usage: wet_curly_hair_make_octomap OUT.bt RESOLUTION_M SPEC [SPEC...]\n");
    return 2;
  }
  char* end = nullptr;
  const double res = std::strtod(argv[2], &end);
  if (*end != '\0' || !(res > 1e-4) || !(res < 1.0)) {
    std::fprintf(stderr, "wet_curly_hair_make_octomap: resolution '%s' must be in (1e-4, 1) m\n",
                 argv[2]);
    return 2;
  }
  std::vector<AnalyticObstacle> shapes;
  Eigen::AlignedBox3d box;
  for (int i = 3; i < argc; ++i) {
    AnalyticObstacle o;
    std::string why;
    if (!AnalyticObstacle::parse(argv[i], &o, &why)) {
      std::fprintf(stderr, "wet_curly_hair_make_octomap: %s\n", why.c_str());
      return 2;
    }
    if (o.shape == AnalyticObstacle::Shape::kPlane) {
      std::fprintf(stderr, "wet_curly_hair_make_octomap: a plane is unbounded; use a thin box\n");
      return 2;
    }
    const Vec3 half = o.shape == AnalyticObstacle::Shape::kSphere ? Vec3::Constant(o.radius_m)
                                                                  : Vec3(o.half_extents_m);
    box.extend(o.center_m - 2.0 * half);
    box.extend(o.center_m + 2.0 * half);
    shapes.push_back(o);
  }
  octomap::OcTree tree(res);
  const Eigen::Vector3i n = ((box.max() - box.min()) / res).array().ceil().cast<int>();
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i) {
        const Vec3 c = box.min() + res * Vec3(i + 0.5, j + 0.5, k + 0.5);
        bool inside = false;
        for (const AnalyticObstacle& o : shapes) {
          Vec3 normal;
          inside = inside || o.distance(c, &normal) < 0.0;
        }
        tree.updateNode(octomap::point3d(c.x(), c.y(), c.z()), inside, true);
      }
  tree.updateInnerOccupancy();
  tree.prune();
  if (!tree.writeBinary(argv[1])) {
    std::fprintf(stderr, "wet_curly_hair_make_octomap: cannot write %s\n", argv[1]);
    return 2;
  }
  std::printf("%s: %zu leaves at %g m\n", argv[1], tree.getNumLeafNodes(), res);
  return 0;
}
