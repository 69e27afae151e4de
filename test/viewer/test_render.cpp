// Tests of the Cairo renderer: image size, depth order (painter's algorithm, solids, near-plane
// clipping), colour by saturation, refusal of bad input, contact sheet tiling, camera fitting.
#include <cairo.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "wet_curly_hair/viewer/render.h"

namespace wet_curly_hair {
namespace io {
namespace {

// ------------------------------------------------------------------------------ helpers

std::string tempPng(const std::string& name) {
  return std::string(WCH_BINARY_DIR) + "/test_render_" + std::to_string(getpid()) + "_" + name +
         ".png";
}

bool fileExists(const std::string& path) {
  struct stat st;
  return stat(path.c_str(), &st) == 0;
}

/// A PNG read back with Cairo.
struct Image {
  int width = 0, height = 0;
  std::vector<uint32_t> argb;  // row-major, 0xAARRGGBB

  double r(int x, int y) const { return ((argb[y * width + x] >> 16) & 0xff) / 255.0; }
  double g(int x, int y) const { return ((argb[y * width + x] >> 8) & 0xff) / 255.0; }
  double b(int x, int y) const { return (argb[y * width + x] & 0xff) / 255.0; }
  Rgb at(int x, int y) const { return {r(x, y), g(x, y), b(x, y)}; }
};

bool readPng(const std::string& path, Image* out) {
  cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
  if (cairo_surface_status(s) != CAIRO_STATUS_SUCCESS) {
    cairo_surface_destroy(s);
    return false;
  }
  cairo_surface_flush(s);
  out->width = cairo_image_surface_get_width(s);
  out->height = cairo_image_surface_get_height(s);
  const int stride = cairo_image_surface_get_stride(s);
  const unsigned char* data = cairo_image_surface_get_data(s);
  out->argb.resize(static_cast<size_t>(out->width) * out->height);
  for (int y = 0; y < out->height; ++y)
    for (int x = 0; x < out->width; ++x)
      out->argb[y * out->width + x] =
          *reinterpret_cast<const uint32_t*>(data + static_cast<size_t>(y) * stride + 4 * x);
  cairo_surface_destroy(s);
  return true;
}

double colourDistance(const Rgb& a, const Rgb& b) {
  return std::sqrt((a.r - b.r) * (a.r - b.r) + (a.g - b.g) * (a.g - b.g) +
                   (a.b - b.b) * (a.b - b.b));
}

double luminance(const Rgb& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

/// A camera on the +x axis looking at the origin, z up, 200 x 200 pixels.
Camera frontCamera(int w = 200, int h = 200) {
  Camera c;
  c.eye_m = Vec3(1.0, 0.0, 0.0);
  c.target_m = Vec3::Zero();
  c.up = Vec3::UnitZ();
  c.fov_deg = 40.0;
  c.width_px = w;
  c.height_px = h;
  return c;
}

/// A plain style: no shading, no depth darkening, no overlays, thick lines, so that pixel
/// colours at strand centres are exactly the base colours.
RenderStyle plainStyle() {
  RenderStyle s;
  s.shading = false;
  s.depth_darkening = 0.0;
  s.caption_font_px = 0.0;
  s.draw_legend = false;
  s.draw_axes = false;
  s.line_width_px = 7.0;
  s.obstacle_line_width_px = 3.0;
  return s;
}

/// Appends a straight strand from a to b with n points and uniform saturation.
void addStrand(RenderScene* scene, const Vec3& a, const Vec3& b, int n, double saturation) {
  for (int i = 0; i < n; ++i) {
    scene->positions.push_back(a + (b - a) * (double(i) / (n - 1)));
    scene->saturation.push_back(saturation);
  }
  scene->strand_offsets.push_back(static_cast<uint32_t>(scene->positions.size()));
}

Rgb pixelOf(const Image& img, const Camera& cam, const Vec3& p) {
  double x = 0, y = 0;
  EXPECT_TRUE(projectToPixel(cam, p, &x, &y));
  return img.at(static_cast<int>(x), static_cast<int>(y));
}

// ------------------------------------------------------------------------------ tests

TEST(Render, WritesPngOfTheCameraSize) {
  RenderScene scene;
  addStrand(&scene, Vec3(0, -0.1, 0.1), Vec3(0, 0.1, -0.1), 10, 0.3);
  scene.caption = "size test";
  const Camera cam = frontCamera(320, 240);
  const std::string path = tempPng("size");
  std::string why;
  ASSERT_TRUE(renderPng(scene, cam, RenderStyle(), path, &why)) << why;
  Image img;
  ASSERT_TRUE(readPng(path, &img));
  EXPECT_EQ(img.width, 320);
  EXPECT_EQ(img.height, 240);
  // Something other than background was drawn.
  const Rgb bg = RenderStyle().background;
  int drawn = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) drawn += colourDistance(img.at(x, y), bg) > 0.1;
  EXPECT_GT(drawn, 100);
  std::remove(path.c_str());
}

TEST(Render, StrandInFrontOfSphereCoversItsOutlineAndOneBehindDoesNot) {
  const Camera cam = frontCamera();
  const RenderStyle style = plainStyle();
  AnalyticObstacle sphere;
  sphere.shape = AnalyticObstacle::Shape::kSphere;
  sphere.center_m = Vec3::Zero();
  sphere.radius_m = 0.1;

  // The sphere alone: find its outline on the middle row (leftmost non-background pixel).
  RenderScene only;
  addStrand(&only, Vec3(0, 0.3, 0.3), Vec3(0, 0.31, 0.3), 2, 0.0);  // tiny strand, far corner
  only.obstacles.push_back(sphere);
  const std::string path0 = tempPng("sphere_alone");
  std::string why;
  ASSERT_TRUE(renderPng(only, cam, style, path0, &why)) << why;
  Image img0;
  ASSERT_TRUE(readPng(path0, &img0));
  const int row = 100;
  int outline_x = -1;
  for (int x = 0; x < 100 && outline_x < 0; ++x)
    if (colourDistance(img0.at(x, row), style.background) > 0.3) outline_x = x + 1;
  ASSERT_GT(outline_x, 0) << "sphere outline not found";
  const Rgb outline = img0.at(outline_x, row);
  EXPECT_LT(colourDistance(outline, style.obstacle_colour), 0.25);

  // The world point on the line of sight of that pixel at depth x = +0.3 (in front of the
  // sphere) and x = -0.3 (behind it).
  double px, py;
  ASSERT_TRUE(projectToPixel(cam, Vec3(0, 0, 0), &px, &py));
  const double tan_per_px = std::tan(20.0 * M_PI / 180.0) / 100.0;
  const double lateral = (outline_x + 0.5 - px) * tan_per_px;  // image right is +y here
  auto vertical = [&](double x) {
    const double d = 1.0 - x;  // depth of the plane at world x
    return std::make_pair(Vec3(x, lateral * d, -0.2), Vec3(x, lateral * d, 0.2));
  };
  for (const double depth_x : {0.3, -0.3}) {
    RenderScene s = only;
    const auto ends = vertical(depth_x);
    addStrand(&s, ends.first, ends.second, 12, 0.0);
    const std::string path = tempPng(depth_x > 0 ? "strand_front" : "strand_behind");
    ASSERT_TRUE(renderPng(s, cam, style, path, &why)) << why;
    Image img;
    ASSERT_TRUE(readPng(path, &img));
    const Rgb c = img.at(outline_x, row);
    if (depth_x > 0) {
      EXPECT_LT(colourDistance(c, style.dry_colour), 0.08) << "strand in front must cover";
    } else {
      EXPECT_LT(colourDistance(c, outline), 0.08) << "outline must be drawn over a strand behind";
    }
    // Away from the outline (above the sphere) the strand shows in both cases.
    double sx, sy;
    ASSERT_TRUE(projectToPixel(cam, (ends.first + ends.second) / 2 + Vec3(0, 0, 0.17), &sx, &sy));
    EXPECT_LT(colourDistance(img.at(static_cast<int>(sx), static_cast<int>(sy)), style.dry_colour),
              0.08);
    std::remove(path.c_str());
  }
  std::remove(path0.c_str());
}

TEST(Render, HeadHidesHairBehindItAndNotHairInFront) {
  const Camera cam = frontCamera();
  RenderStyle style = plainStyle();
  style.head_alpha = 1.0;
  RenderScene scene;
  scene.head = EllipsoidOutline();
  scene.head->radii_m = Vec3(0.1, 0.1, 0.12);
  // Behind: a horizontal strand at z = +0.03 behind the head; in front: one at z = -0.03.
  addStrand(&scene, Vec3(-0.2, -0.15, 0.03), Vec3(-0.2, 0.15, 0.03), 20, 0.0);
  addStrand(&scene, Vec3(0.2, -0.15, -0.03), Vec3(0.2, 0.15, -0.03), 20, 1.0);
  const std::string path = tempPng("head");
  std::string why;
  ASSERT_TRUE(renderPng(scene, cam, style, path, &why)) << why;
  Image img;
  ASSERT_TRUE(readPng(path, &img));
  const Rgb behind = pixelOf(img, cam, Vec3(-0.2, 0.0, 0.03));
  const Rgb front = pixelOf(img, cam, Vec3(0.2, 0.0, -0.03));
  EXPECT_GT(colourDistance(behind, style.dry_colour), 0.2) << "hair behind the head is hidden";
  EXPECT_LT(colourDistance(front, style.wet_colour), 0.08) << "hair in front is drawn over it";
  // Outside the silhouette the strand behind the head is visible.
  const Rgb side = pixelOf(img, cam, Vec3(-0.2, 0.14, 0.03));
  EXPECT_LT(colourDistance(side, style.dry_colour), 0.08);
  std::remove(path.c_str());
}

TEST(Render, WetStrandIsDarkerAndBluerThanDry) {
  const Camera cam = frontCamera();
  for (const bool plain : {true, false}) {
    RenderStyle style = plain ? plainStyle() : RenderStyle();
    style.line_width_px = 7.0;
    RenderScene scene;
    addStrand(&scene, Vec3(0, -0.15, 0.05), Vec3(0, 0.15, 0.07), 10, 0.0);    // dry
    addStrand(&scene, Vec3(0, -0.15, -0.05), Vec3(0, 0.15, -0.03), 10, 1.0);  // wet
    const std::string path = tempPng(plain ? "wet_dry_plain" : "wet_dry_default");
    std::string why;
    ASSERT_TRUE(renderPng(scene, cam, style, path, &why)) << why;
    Image img;
    ASSERT_TRUE(readPng(path, &img));
    const Rgb dry = pixelOf(img, cam, Vec3(0, 0.0, 0.06));
    const Rgb wet = pixelOf(img, cam, Vec3(0, 0.0, -0.04));
    EXPECT_LT(luminance(wet), luminance(dry) - 0.1) << "plain=" << plain;
    EXPECT_GT(wet.b - wet.r, dry.b - dry.r + 0.2) << "plain=" << plain;
    if (plain) {
      EXPECT_LT(colourDistance(dry, style.dry_colour), 0.03);
      EXPECT_LT(colourDistance(wet, style.wet_colour), 0.03);
    }
    std::remove(path.c_str());
  }
  // Half saturation is the linear blend.
  RenderStyle style = plainStyle();
  RenderScene scene;
  addStrand(&scene, Vec3(0, -0.15, 0.0), Vec3(0, 0.15, 0.0), 10, 0.5);
  const std::string path = tempPng("half");
  std::string why;
  ASSERT_TRUE(renderPng(scene, cam, style, path, &why)) << why;
  Image img;
  ASSERT_TRUE(readPng(path, &img));
  const Rgb mid = pixelOf(img, cam, Vec3(0, 0.0, 0.0));
  const Rgb expect{0.5 * (style.dry_colour.r + style.wet_colour.r),
                   0.5 * (style.dry_colour.g + style.wet_colour.g),
                   0.5 * (style.dry_colour.b + style.wet_colour.b)};
  EXPECT_LT(colourDistance(mid, expect), 0.03);
  std::remove(path.c_str());
}

TEST(Render, NearStrandIsDrawnOverFarStrandWhateverTheInputOrder) {
  const Camera cam = frontCamera();
  const RenderStyle style = plainStyle();
  for (const bool near_first : {true, false}) {
    RenderScene scene;
    // Near: horizontal, dry, x = 0.2. Far: vertical, wet, x = -0.2. They cross at the centre.
    const auto addNear = [&] { addStrand(&scene, Vec3(0.2, -0.1, 0), Vec3(0.2, 0.1, 0), 9, 0.0); };
    const auto addFar = [&] { addStrand(&scene, Vec3(-0.2, 0, -0.2), Vec3(-0.2, 0, 0.2), 9, 1.0); };
    if (near_first) {
      addNear();
      addFar();
    } else {
      addFar();
      addNear();
    }
    const std::string path = tempPng(near_first ? "depth_a" : "depth_b");
    std::string why;
    ASSERT_TRUE(renderPng(scene, cam, style, path, &why)) << why;
    Image img;
    ASSERT_TRUE(readPng(path, &img));
    EXPECT_LT(colourDistance(img.at(100, 100), style.dry_colour), 0.05)
        << "near_first=" << near_first;
    // Along the far strand away from the crossing it is visible.
    EXPECT_LT(colourDistance(img.at(100, 60), style.wet_colour), 0.05);
    std::remove(path.c_str());
  }
}

TEST(Render, PointsBehindTheCameraAreClippedNotMirrored) {
  const Camera cam = frontCamera();
  const RenderStyle style = plainStyle();
  RenderScene scene;
  // A at the image centre-ish above the axis, B behind the camera (depth -1). A naive
  // projection of B lands above A; the clipped segment leaves A downward.
  scene.positions = {Vec3(0, 0, 0.05), Vec3(2, 0, -0.3)};
  scene.strand_offsets = {0, 2};
  const std::string path = tempPng("clip");
  std::string why;
  ASSERT_TRUE(renderPng(scene, cam, style, path, &why)) << why;
  Image img;
  ASSERT_TRUE(readPng(path, &img));
  double ax, ay;
  ASSERT_TRUE(projectToPixel(cam, scene.positions[0], &ax, &ay));
  EXPECT_FALSE(projectToPixel(cam, scene.positions[1], &ax, &ay)) << "behind the camera";
  ASSERT_TRUE(projectToPixel(cam, scene.positions[0], &ax, &ay));
  const int x = static_cast<int>(ax);
  EXPECT_LT(colourDistance(img.at(x, static_cast<int>(ay) + 20), style.dry_colour), 0.05);
  EXPECT_LT(colourDistance(img.at(x, static_cast<int>(ay) - 20), style.background), 0.02);
  EXPECT_LT(colourDistance(img.at(x, 5), style.background), 0.02);
  std::remove(path.c_str());
}

TEST(Render, RefusesBadInput) {
  const Camera cam = frontCamera();
  const RenderStyle style;
  std::string why;
  const std::string path = tempPng("bad");

  RenderScene empty;
  EXPECT_FALSE(renderPng(empty, cam, style, path, &why));
  EXPECT_NE(why.find("no strands"), std::string::npos) << why;

  RenderScene single_points;  // strands with one point each: nothing to draw
  single_points.positions = {Vec3(0, 0, 0), Vec3(0, 0.1, 0)};
  single_points.strand_offsets = {0, 1, 2};
  why.clear();
  EXPECT_FALSE(renderPng(single_points, cam, style, path, &why));
  EXPECT_NE(why.find("empty"), std::string::npos) << why;

  RenderScene nan;
  addStrand(&nan, Vec3(0, -0.1, 0), Vec3(0, 0.1, 0), 5, 0.0);
  nan.positions[3].y() = std::numeric_limits<double>::quiet_NaN();
  why.clear();
  EXPECT_FALSE(renderPng(nan, cam, style, path, &why));
  EXPECT_NE(why.find("positions[3]"), std::string::npos) << why;

  RenderScene inf;
  addStrand(&inf, Vec3(0, -0.1, 0), Vec3(0, 0.1, 0), 5, 0.0);
  inf.positions[0].x() = std::numeric_limits<double>::infinity();
  why.clear();
  EXPECT_FALSE(renderPng(inf, cam, style, path, &why));
  EXPECT_NE(why.find("not finite"), std::string::npos) << why;

  RenderScene bad_sat;
  addStrand(&bad_sat, Vec3(0, -0.1, 0), Vec3(0, 0.1, 0), 5, 0.0);
  bad_sat.saturation[2] = std::numeric_limits<double>::quiet_NaN();
  why.clear();
  EXPECT_FALSE(renderPng(bad_sat, cam, style, path, &why));
  EXPECT_NE(why.find("saturation[2]"), std::string::npos) << why;
  bad_sat.saturation.pop_back();
  EXPECT_FALSE(renderPng(bad_sat, cam, style, path, &why));

  RenderScene bad_offsets;
  addStrand(&bad_offsets, Vec3(0, -0.1, 0), Vec3(0, 0.1, 0), 5, 0.0);
  bad_offsets.strand_offsets.back() = 7;
  EXPECT_FALSE(renderPng(bad_offsets, cam, style, path, &why));

  EXPECT_FALSE(fileExists(path)) << "nothing written for refused input";

  RenderScene ok;
  addStrand(&ok, Vec3(0, -0.1, 0), Vec3(0, 0.1, 0), 5, 0.0);
  Camera bad_cam = cam;
  bad_cam.target_m = bad_cam.eye_m;
  EXPECT_FALSE(renderPng(ok, bad_cam, style, path, &why));
  bad_cam = cam;
  bad_cam.eye_m.z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(renderPng(ok, bad_cam, style, path, &why));
  bad_cam = cam;
  bad_cam.up = Vec3::UnitX();  // parallel to the view direction
  EXPECT_FALSE(renderPng(ok, bad_cam, style, path, &why));

  why.clear();
  EXPECT_FALSE(renderPng(ok, cam, style, "/nonexistent_dir_wch/x.png", &why));
  EXPECT_NE(why.find("cannot write"), std::string::npos) << why;
}

TEST(Render, ContactSheetHasTheTiledSize) {
  std::vector<RenderScene> frames;
  for (int k = 0; k < 5; ++k) {
    RenderScene s;
    addStrand(&s, Vec3(0, -0.1, 0.02 * k), Vec3(0, 0.1, -0.02 * k), 8, 0.2 * k);
    char cap[32];
    std::snprintf(cap, sizeof(cap), "t = %.2f s", 0.5 * k);
    s.caption = cap;
    frames.push_back(s);
  }
  const Camera cam = frontCamera(160, 120);
  const std::string path = tempPng("sheet");
  std::string why;
  ASSERT_TRUE(renderContactSheet(frames, cam, RenderStyle(), 2, path, &why)) << why;
  Image img;
  ASSERT_TRUE(readPng(path, &img));
  EXPECT_EQ(img.width, 2 * 160);
  EXPECT_EQ(img.height, 3 * 120);
  // More columns than frames: one row.
  ASSERT_TRUE(renderContactSheet(frames, cam, RenderStyle(), 8, path, &why)) << why;
  ASSERT_TRUE(readPng(path, &img));
  EXPECT_EQ(img.width, 5 * 160);
  EXPECT_EQ(img.height, 120);
  std::remove(path.c_str());

  // A bad frame is named; no frames and zero columns are refused.
  frames[3].positions[1].x() = std::nan("");
  EXPECT_FALSE(renderContactSheet(frames, cam, RenderStyle(), 2, path, &why));
  EXPECT_NE(why.find("frame 3"), std::string::npos) << why;
  EXPECT_FALSE(renderContactSheet({}, cam, RenderStyle(), 2, path, &why));
  frames.pop_back();
  EXPECT_FALSE(renderContactSheet(frames, cam, RenderStyle(), 0, path, &why));
}

TEST(Render, AutoCameraFramesAllPoints) {
  Vec3List pts;
  for (int i = 0; i < 50; ++i) {
    const double t = i / 49.0;
    pts.push_back(Vec3(0.3 + 0.1 * std::cos(9 * t), 2.0 + 0.4 * t, -1.0 + 0.1 * std::sin(7 * t)));
  }
  Camera base;
  base.width_px = 400;
  base.height_px = 300;
  for (const Vec3& dir : {defaultViewDirection(), Vec3(0, 0, 1), Vec3(-1, 0.2, -0.5)}) {
    const Camera cam = autoCamera(pts, dir, base);
    std::string why;
    ASSERT_TRUE(cam.validate(&why)) << why;
    EXPECT_LT(((cam.eye_m - cam.target_m).normalized() - dir.normalized()).norm(), 1e-9);
    double xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
    for (const Vec3& p : pts) {
      double x, y;
      ASSERT_TRUE(projectToPixel(cam, p, &x, &y));
      xmin = std::min(xmin, x);
      xmax = std::max(xmax, x);
      ymin = std::min(ymin, y);
      ymax = std::max(ymax, y);
    }
    EXPECT_GE(xmin, 0.0);
    EXPECT_LE(xmax, 400.0);
    EXPECT_GE(ymin, 0.0);
    EXPECT_LE(ymax, 300.0);
    // Fills most of one dimension and is centred.
    EXPECT_GT(std::max((xmax - xmin) / 400.0, (ymax - ymin) / 300.0), 0.8);
    EXPECT_NEAR(0.5 * (xmin + xmax), 200.0, 2.0);
    EXPECT_NEAR(0.5 * (ymin + ymax), 150.0, 2.0);
  }
  // No points: the base camera.
  const Camera same = autoCamera({}, defaultViewDirection(), base);
  EXPECT_EQ(same.eye_m, base.eye_m);
}

TEST(Render, FramingPointsIncludeHeadAndObstacles) {
  RenderScene scene;
  addStrand(&scene, Vec3(0, 0, 0), Vec3(0, 0, 0.1), 3, 0.0);
  scene.head = EllipsoidOutline();
  AnalyticObstacle box;
  box.shape = AnalyticObstacle::Shape::kBox;
  box.center_m = Vec3(1, 0, 0);
  scene.obstacles.push_back(box);
  AnalyticObstacle plane;
  plane.shape = AnalyticObstacle::Shape::kPlane;
  scene.obstacles.push_back(plane);
  const Vec3List pts = framingPoints(scene);
  EXPECT_EQ(pts.size(), 3u + 6u + 8u);
}

TEST(Render, BoxAndPlaneObstaclesAndGridRender) {
  RenderScene scene;
  addStrand(&scene, Vec3(0, -0.1, 0.1), Vec3(0, 0.1, 0.0), 10, 0.5);
  AnalyticObstacle box;
  box.shape = AnalyticObstacle::Shape::kBox;
  box.center_m = Vec3(0, 0, -0.2);
  box.half_extents_m = Vec3(0.1, 0.2, 0.05);
  box.orientation = Quat(Eigen::AngleAxisd(0.3, Vec3::UnitZ()));
  AnalyticObstacle plane;
  plane.shape = AnalyticObstacle::Shape::kPlane;
  plane.center_m = Vec3(0, 0, -0.3);
  scene.obstacles = {box, plane};
  scene.head = EllipsoidOutline();
  RenderStyle style;
  style.draw_floor_grid = true;
  const Camera cam =
      autoCamera(framingPoints(scene), defaultViewDirection(), frontCamera(300, 300));
  const std::string path = tempPng("box_plane");
  std::string why;
  ASSERT_TRUE(renderPng(scene, cam, style, path, &why)) << why;
  Image img;
  ASSERT_TRUE(readPng(path, &img));
  int blue = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      blue += colourDistance(img.at(x, y), style.obstacle_colour) < 0.15;
  EXPECT_GT(blue, 200) << "box edges drawn";
  std::remove(path.c_str());
}

}  // namespace
}  // namespace io
}  // namespace wet_curly_hair
