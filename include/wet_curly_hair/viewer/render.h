// Still pictures of hair strands as PNG, drawn with Cairo: a perspective camera, line segments
// depth-sorted back to front (painter's algorithm), colour by saturation, simple strand shading,
// the head as a filled silhouette, obstacles as outlines, and contact sheets of several frames.
//
// World frame: REP-103 (x forward, y left, z up), metres (any unit works as long as the scene,
// obstacles and head use the same one; only Camera::near_m is an absolute length).
//
// Colour (RenderStyle::colour_by_saturation): a particle of saturation s (clamped to [0, 1])
// gets base = (1 - s) * dry_colour + s * wet_colour, a linear blend in sRGB from a warm hair
// brown (dry) to a dark blue-black (wet). A segment uses the mean of its two end values. Then:
//   - strand shading (RenderStyle::shading): Kajiya-Kay style, with T the unit segment tangent,
//     L the light direction and H the half vector between L and the view direction:
//       colour = base * (ambient + diffuse * sqrt(1 - (T.L)^2))
//              + specular(s) * (sqrt(1 - (T.H)^2))^shininess * white,
//     specular(s) = (1 - s) * specular_dry + s * specular_wet (wet hair is glossier);
//   - depth darkening: colour *= 1 - depth_darkening * f, f in [0, 1] the segment's place
//     between the nearest (0) and farthest (1) hair segment of the picture.
// With both off, a pixel at the centre of a thick strand has exactly the blended base colour.
//
// Visibility (painter's algorithm with solids): every drawn line piece (hair segment, obstacle
// edge, silhouette piece, grid line piece) is sorted by the camera depth of its midpoint, far
// first. Ellipsoids (the head, sphere obstacles) are drawn as filled silhouettes, each sorted at
// the depth of its centre; a line piece whose midpoint is hidden by an ellipsoid (the ray from
// the eye to the midpoint enters the ellipsoid first) is moved just behind that ellipsoid's
// fill, and one that lies over an ellipsoid's silhouette but in front of its surface is moved
// just in front of it. This is exact for hair against a single solid up to the length of a
// segment (a segment is decided by its midpoint); between solids the order is by centre depth.
// The head fill is opaque by default (RenderStyle::head_alpha); sphere fills are faint tints
// under a stroked silhouette. Boxes are their 12 edges; a plane is a square grid patch around
// the foot of the scene centre, sized to the scene.
//
// Clipping: line pieces are clipped against the near plane (depth Camera::near_m) in 3-D before
// projection, so points behind the camera are never drawn (not mirrored through the eye).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {
namespace io {

/// A pinhole camera. The image is width_px x height_px; fov_deg is the vertical field of view.
struct Camera {
  Vec3 eye_m = Vec3(0.9, 0.6, 0.35);  ///< camera position, world.
  Vec3 target_m = Vec3::Zero();       ///< point at the image centre.
  Vec3 up = Vec3::UnitZ();            ///< world direction shown upward (need not be unit).
  double fov_deg = 35.0;              ///< vertical field of view, degrees, in (0, 170].
  int width_px = 800;
  int height_px = 800;
  double near_m = 1e-4;  ///< near clipping plane distance (> 0), world units.

  /// Checks finiteness, eye != target, up not parallel to the view direction, the field of view,
  /// image sizes in [1, 16384] and near_m > 0. Names the field.
  bool validate(std::string* why) const;
};

/// Default direction from the scene toward the camera: in front (+x), to the left (+y) and
/// slightly above (+z), i.e. the viewer stands front-left of the head.
inline Vec3 defaultViewDirection() { return Vec3(1.0, 0.55, 0.3).normalized(); }

/// A camera looking along -view_dir (view_dir points from the scene toward the eye; any length
/// > 0) that frames all `points`: the target is centred on their projection and the distance is
/// the smallest that keeps every point inside the image with a margin (`fill` is the fraction of
/// the tighter image dimension the points may span, in (0, 1]). Uses `base`'s fov, image size,
/// up and near plane. With no finite points it returns `base` unchanged. If view_dir is zero,
/// non-finite or parallel to `base.up`, defaultViewDirection() (or a tilted up) is used.
Camera autoCamera(const Vec3List& points, Vec3 view_dir = defaultViewDirection(),
                  const Camera& base = Camera(), double fill = 0.9);

/// Projects world point p: pixel coordinates (x right, y down, pixel centres at i + 0.5) and the
/// camera depth (distance along the viewing axis). Returns false (outputs untouched) when p is
/// not in front of the near plane or the camera is invalid.
bool projectToPixel(const Camera& camera, const Vec3& p, double* x_px, double* y_px,
                    double* depth = nullptr);

/// An sRGB colour, components in [0, 1].
struct Rgb {
  double r = 0.0, g = 0.0, b = 0.0;
};

/// How a picture looks. See the file comment for the colour and shading formulas.
struct RenderStyle {
  double line_width_px = 2.0;        ///< hair line width, pixels.
  bool colour_by_saturation = true;  ///< false: every strand in dry_colour.
  Rgb dry_colour{0.55, 0.33, 0.16};  ///< warm hair brown (saturation 0).
  Rgb wet_colour{0.06, 0.08, 0.19};  ///< dark blue-black (saturation 1).
  Rgb background{0.97, 0.96, 0.93};
  bool shading = true;         ///< Kajiya-Kay style strand shading.
  double ambient = 0.55;       ///< shading: ambient factor.
  double diffuse = 0.55;       ///< shading: diffuse factor.
  double specular_dry = 0.10;  ///< shading: specular weight at saturation 0.
  double specular_wet = 0.30;  ///< shading: specular weight at saturation 1 (glossy).
  double shininess = 40.0;     ///< shading: specular exponent.
  /// Light direction in camera coordinates (x right, y up, z toward the viewer); normalised.
  Vec3 light_dir_camera = Vec3(-0.4, 0.7, 0.6);
  double depth_darkening = 0.3;  ///< in [0, 1]: darkening of the farthest hair.
  bool draw_head = true;         ///< draw RenderScene::head when set.
  Rgb head_colour{0.86, 0.83, 0.79};
  double head_alpha = 1.0;  ///< opacity of the head fill (< 1: hair behind shows).
  Rgb obstacle_colour{0.18, 0.42, 0.72};
  double obstacle_line_width_px = 1.8;
  double obstacle_fill_alpha = 0.10;  ///< sphere fill opacity (0: outline only).
  bool draw_floor_grid = false;       ///< horizontal grid (normal = camera up) under the scene.
  Rgb grid_colour{0.70, 0.70, 0.68};
  Rgb caption_colour{0.15, 0.15, 0.15};
  double caption_font_px = 18.0;  ///< caption height; 0 hides captions.
  bool draw_legend = true;        ///< small dry -> wet colour bar in the lower left corner.
  bool draw_axes = true;          ///< small x (red) y (green) z (blue) triad, lower right.
};

/// An ellipsoid outline to draw as a filled silhouette (the head), world frame.
struct EllipsoidOutline {
  Vec3 center_m = Vec3::Zero();
  Vec3 radii_m = Vec3(0.095, 0.078, 0.11);  ///< semi-axes along the ellipsoid's own axes.
  Quat orientation = Quat::Identity();      ///< the ellipsoid's axes in the world.
};

/// What to draw. Strand s owns positions [strand_offsets[s], strand_offsets[s + 1]).
struct RenderScene {
  std::vector<uint32_t> strand_offsets{0};
  Vec3List positions;
  std::vector<double> saturation;  ///< per point (finite), or empty: all dry.
  std::vector<AnalyticObstacle> obstacles;
  std::optional<EllipsoidOutline> head;
  std::string caption;  ///< drawn in the upper left corner; may be empty.

  /// Checks that there is something to draw and that it is consistent: at least one strand with
  /// at least one segment, offsets starting at 0, non-decreasing and ending at the point count,
  /// finite positions, saturation empty or one finite value per point, obstacles with finite
  /// fields and positive sizes, a head with finite fields and positive radii. Names the field.
  bool validate(std::string* why) const;
};

/// Points that a camera should keep in view to show `scene`: the hair positions, the extreme
/// points of the head and of sphere obstacles and the corners of boxes (planes are unbounded and
/// add nothing). Non-finite points are skipped.
Vec3List framingPoints(const RenderScene& scene);

/// Renders one picture of camera.width_px x camera.height_px to `png_path`. Returns false with
/// `*why` set (if non-null) on an invalid scene or camera, or when the PNG cannot be written.
bool renderPng(const RenderScene& scene, const Camera& camera, const RenderStyle& style,
               const std::string& png_path, std::string* why);

/// Renders several frames as one PNG: tiles of camera.width_px x camera.height_px in `columns`
/// columns (>= 1; fewer when there are fewer frames) and as many rows as needed, left to right,
/// top to bottom, each with its own caption. Every tile uses the same camera and the same depth
/// range for darkening, so tiles compare directly. The sheet may not exceed 32767 pixels in
/// either direction. Returns false with `*why` set on an empty list, an invalid frame (named by
/// its index) or camera, or a write error.
bool renderContactSheet(const std::vector<RenderScene>& frames, const Camera& camera,
                        const RenderStyle& style, int columns, const std::string& png_path,
                        std::string* why);

}  // namespace io
}  // namespace wet_curly_hair
