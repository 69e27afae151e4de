// PNG pictures of hair strands with Cairo. See render.h for the colour, shading and visibility
// rules.
#include "wet_curly_hair/viewer/render.h"

#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <sstream>

namespace wet_curly_hair {
namespace io {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxImagePx = 16384;
constexpr int kMaxSheetPx = 32767;
/// Line pieces of obstacle edges and grid lines: each straight line is cut into this many pieces
/// so that the painter's sort interleaves them correctly with hair.
constexpr int kLinePieces = 24;
/// Points on an ellipsoid silhouette.
constexpr int kSilhouettePoints = 120;
/// A line piece counts as hidden by an ellipsoid when the ray to its midpoint enters the
/// ellipsoid shrunk by this factor (tolerance for hair lying on the surface).
constexpr double kOcclusionShrink = 0.985;

bool fail(std::string* why, const std::string& message) {
  if (why) *why = message;
  return false;
}

std::string vecText(const Vec3& v) {
  std::ostringstream o;
  o << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return o.str();
}

double clamp01(double v) { return std::isfinite(v) ? std::clamp(v, 0.0, 1.0) : 0.0; }

Rgb mix(const Rgb& a, const Rgb& b, double s) {
  return {a.r + (b.r - a.r) * s, a.g + (b.g - a.g) * s, a.b + (b.b - a.b) * s};
}

Rgb scaled(const Rgb& c, double k) { return {c.r * k, c.g * k, c.b * k}; }

Rgb clamped(const Rgb& c) { return {clamp01(c.r), clamp01(c.g), clamp01(c.b)}; }

// ------------------------------------------------------------------------------ camera

/// The camera's orthonormal frame and intrinsics.
struct View {
  Vec3 eye, fwd, right, up;  // fwd: viewing direction; right x up = -fwd
  double focal_px = 1.0;     // pixels per unit of tangent
  double cx = 0.0, cy = 0.0;
  double near = 1e-4;
  Vec3 world_up = Vec3::UnitZ();    // the camera's up, normalised (the floor grid's normal)
  double tan_h = 1.0, tan_v = 1.0;  // half-angle tangents
  int width = 1, height = 1;

  double depth(const Vec3& p) const { return (p - eye).dot(fwd); }
  /// Pixel of p; p must be in front of the near plane.
  void pixel(const Vec3& p, double* x, double* y) const {
    const Vec3 c = p - eye;
    const double d = c.dot(fwd);
    *x = cx + focal_px * c.dot(right) / d;
    *y = cy - focal_px * c.dot(up) / d;
  }
};

bool makeView(const Camera& camera, View* v, std::string* why) {
  if (!camera.validate(why)) return false;
  v->eye = camera.eye_m;
  v->fwd = (camera.target_m - camera.eye_m).normalized();
  v->right = v->fwd.cross(camera.up).normalized();
  v->up = v->right.cross(v->fwd);
  v->width = camera.width_px;
  v->height = camera.height_px;
  v->tan_v = std::tan(camera.fov_deg * kPi / 360.0);
  v->tan_h = v->tan_v * camera.width_px / camera.height_px;
  v->focal_px = 0.5 * camera.height_px / v->tan_v;
  v->cx = 0.5 * camera.width_px;
  v->cy = 0.5 * camera.height_px;
  v->near = camera.near_m;
  v->world_up = camera.up.normalized();
  return true;
}

/// Clips segment [a, b] to the near plane and to a frustum 1.5 times wider than the image (so
/// that projected coordinates stay small for Cairo's fixed-point arithmetic). Returns false when
/// nothing is left; else replaces a and b by the ends of the visible part.
bool clipSegment(const View& v, Vec3* a, Vec3* b) {
  const double k = 1.5;
  // Half-spaces g(p) = n . (p - eye) - off >= 0.
  const Vec3 normals[5] = {v.fwd, k * v.tan_h * v.fwd - v.right, k * v.tan_h * v.fwd + v.right,
                           k * v.tan_v * v.fwd - v.up, k * v.tan_v * v.fwd + v.up};
  const double offsets[5] = {v.near, 0.0, 0.0, 0.0, 0.0};
  double t0 = 0.0, t1 = 1.0;
  for (int i = 0; i < 5; ++i) {
    const double ga = normals[i].dot(*a - v.eye) - offsets[i];
    const double gb = normals[i].dot(*b - v.eye) - offsets[i];
    if (ga < 0.0 && gb < 0.0) return false;
    if (ga < 0.0) {
      t0 = std::max(t0, ga / (ga - gb));
    } else if (gb < 0.0) {
      t1 = std::min(t1, ga / (ga - gb));
    }
    if (t0 > t1) return false;
  }
  const Vec3 d = *b - *a;
  const Vec3 na = *a + t0 * d;
  const Vec3 nb = *a + t1 * d;
  *a = na;
  *b = nb;
  return true;
}

// ------------------------------------------------------------------------------ solids

/// An ellipsoid drawn as a filled silhouette: x = center + A q with |q| <= 1, A = R diag(radii).
struct Solid {
  Vec3 center;
  Mat3 to_unit;    // A^-1
  Mat3 from_unit;  // A
  Rgb fill;
  double fill_alpha = 1.0;
  bool shaded = false;  // radial gradient (the head)
  Rgb edge;
  double edge_alpha = 0.0;
  double edge_width = 1.0;
  double key = 0.0;  // sort depth of the fill (centre depth)
  bool camera_inside = false;
  std::vector<Vec3> silhouette;  // closed 3-D curve, empty when the camera is inside
};

Solid makeSolid(const View& v, const Vec3& center, const Vec3& radii, const Quat& orientation) {
  Solid s;
  s.center = center;
  const Mat3 rot = orientation.normalized().toRotationMatrix();
  s.from_unit = rot * radii.asDiagonal();
  s.to_unit = radii.cwiseInverse().asDiagonal() * rot.transpose();
  s.key = v.depth(center);
  const Vec3 e = s.to_unit * (v.eye - center);
  const double d = e.norm();
  if (!(d > 1.0 + 1e-9)) {
    s.camera_inside = true;
    return s;
  }
  // In the unit-sphere space the rays from the eye touch the sphere on the circle of centre
  // e / d^2 and radius sqrt(1 - 1/d^2) perpendicular to e; the affine map A keeps tangency.
  const Vec3 n = e / d;
  Vec3 a1 = n.unitOrthogonal();
  Vec3 a2 = n.cross(a1);
  const double rho = std::sqrt(1.0 - 1.0 / (d * d));
  s.silhouette.reserve(kSilhouettePoints);
  for (int i = 0; i < kSilhouettePoints; ++i) {
    const double th = 2.0 * kPi * i / kSilhouettePoints;
    const Vec3 q = n / d + rho * (std::cos(th) * a1 + std::sin(th) * a2);
    s.silhouette.push_back(center + s.from_unit * q);
  }
  return s;
}

/// Where a point lies relative to a solid along the ray from the eye.
enum class RayRelation { kMiss, kHidden, kInFront };

RayRelation rayRelation(const View& v, const Solid& s, const Vec3& p) {
  if (s.camera_inside) return RayRelation::kMiss;
  const Vec3 o = s.to_unit * (v.eye - s.center) / kOcclusionShrink;
  const Vec3 dir = s.to_unit * (p - v.eye) / kOcclusionShrink;
  const double a = dir.squaredNorm();
  if (a <= 0.0) return RayRelation::kMiss;
  const double b = 2.0 * o.dot(dir);
  const double c = o.squaredNorm() - 1.0;
  const double disc = b * b - 4.0 * a * c;
  if (disc <= 0.0) return RayRelation::kMiss;
  const double sq = std::sqrt(disc);
  const double t0 = (-b - sq) / (2.0 * a);
  const double t1 = (-b + sq) / (2.0 * a);
  if (t1 <= 0.0) return RayRelation::kMiss;
  return t0 < 1.0 ? RayRelation::kHidden : RayRelation::kInFront;
}

// ------------------------------------------------------------------------------ draw list

/// A straight line piece, already clipped.
struct Piece {
  Vec3 a, b;
  Rgb colour;
  double alpha = 1.0;
  double width = 1.0;
  int skip_solid = -1;  // the solid whose silhouette this piece belongs to
};

/// One thing to draw, sorted by (key, tie) descending: far first; at equal key, tie +1 (hidden
/// behind a solid) before 0 (the solid's fill) before -1 (in front of it).
struct Item {
  double key;
  int tie;
  bool solid;
  size_t index;
};

struct DrawList {
  std::vector<Piece> pieces;
  std::vector<Solid> solids;
};

/// Adds segment [a, b] (clipped) as one piece.
void addPiece(const View& v, Vec3 a, Vec3 b, const Rgb& colour, double alpha, double width,
              DrawList* list, int skip_solid = -1) {
  if (!clipSegment(v, &a, &b)) return;
  Piece p;
  p.a = a;
  p.b = b;
  p.colour = colour;
  p.alpha = alpha;
  p.width = width;
  p.skip_solid = skip_solid;
  list->pieces.push_back(p);
}

/// Adds a long straight line as kLinePieces pieces.
void addLine(const View& v, const Vec3& a, const Vec3& b, const Rgb& colour, double alpha,
             double width, DrawList* list) {
  for (int i = 0; i < kLinePieces; ++i) {
    const Vec3 p = a + (b - a) * (double(i) / kLinePieces);
    const Vec3 q = a + (b - a) * (double(i + 1) / kLinePieces);
    addPiece(v, p, q, colour, alpha, width, list);
  }
}

/// A "nice" grid step (1, 2 or 5 times a power of ten) near `raw`.
double niceStep(double raw) {
  if (!(raw > 0.0) || !std::isfinite(raw)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double m = raw / p;
  return (m < 1.5 ? 1.0 : m < 3.5 ? 2.0 : m < 7.5 ? 5.0 : 10.0) * p;
}

/// A square grid of lines in the plane through `center` with unit axes e1, e2: lines every
/// `step` out to +-half.
void addGrid(const View& v, const Vec3& center, const Vec3& e1, const Vec3& e2, double half,
             double step, const Rgb& colour, double alpha, double width, DrawList* list) {
  const int n = std::max(1, std::min(50, static_cast<int>(std::floor(half / step))));
  const double h = n * step;
  for (int i = -n; i <= n; ++i) {
    addLine(v, center + e1 * (i * step) - e2 * h, center + e1 * (i * step) + e2 * h, colour, alpha,
            width, list);
    addLine(v, center + e2 * (i * step) - e1 * h, center + e2 * (i * step) + e1 * h, colour, alpha,
            width, list);
  }
}

/// Axis-aligned bounds of the hair.
void hairBounds(const RenderScene& scene, Vec3* lo, Vec3* hi) {
  *lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  *hi = -*lo;
  for (const Vec3& p : scene.positions) {
    *lo = lo->cwiseMin(p);
    *hi = hi->cwiseMax(p);
  }
}

/// Colour of one hair segment before depth darkening.
Rgb segmentColour(const View& v, const RenderStyle& style, const Vec3& a, const Vec3& b, double s) {
  const Rgb base =
      style.colour_by_saturation ? mix(style.dry_colour, style.wet_colour, s) : style.dry_colour;
  if (!style.shading) return base;
  const Vec3 mid = 0.5 * (a + b);
  Vec3 t = b - a;
  const double len = t.norm();
  if (!(len > 0.0)) return scaled(base, style.ambient + style.diffuse);
  t /= len;
  Vec3 light = style.light_dir_camera.x() * v.right + style.light_dir_camera.y() * v.up -
               style.light_dir_camera.z() * v.fwd;
  light = light.norm() > 0.0 ? light.normalized() : Vec3(-v.fwd);
  const Vec3 to_eye = (v.eye - mid).normalized();
  const Vec3 half = (light + to_eye).norm() > 1e-12 ? (light + to_eye).normalized() : to_eye;
  const double tl = t.dot(light), th = t.dot(half);
  const double diff = std::sqrt(std::max(0.0, 1.0 - tl * tl));
  const double spec = std::pow(std::sqrt(std::max(0.0, 1.0 - th * th)), style.shininess);
  const double ks = style.colour_by_saturation
                        ? style.specular_dry + (style.specular_wet - style.specular_dry) * s
                        : style.specular_dry;
  const double k = style.ambient + style.diffuse * diff;
  return {base.r * k + ks * spec, base.g * k + ks * spec, base.b * k + ks * spec};
}

/// Nearest and farthest clipped hair-segment midpoint depth of a scene (lo > hi when none).
void hairDepthRange(const View& v, const RenderScene& scene, double* lo, double* hi) {
  for (size_t s = 0; s + 1 < scene.strand_offsets.size(); ++s) {
    for (uint32_t i = scene.strand_offsets[s]; i + 1 < scene.strand_offsets[s + 1]; ++i) {
      Vec3 a = scene.positions[i], b = scene.positions[i + 1];
      if (!clipSegment(v, &a, &b)) continue;
      const double d = v.depth(0.5 * (a + b));
      *lo = std::min(*lo, d);
      *hi = std::max(*hi, d);
    }
  }
}

/// Builds every piece and solid of a scene.
void buildDrawList(const View& v, const RenderScene& scene, const RenderStyle& style,
                   double depth_lo, double depth_hi, DrawList* list) {
  Vec3 lo, hi;
  hairBounds(scene, &lo, &hi);
  const Vec3 centre = 0.5 * (lo + hi);
  const double diameter = std::max((hi - lo).norm(), 1e-9);

  // Hair.
  const bool has_sat = !scene.saturation.empty();
  const double range = depth_hi - depth_lo;
  for (size_t s = 0; s + 1 < scene.strand_offsets.size(); ++s) {
    for (uint32_t i = scene.strand_offsets[s]; i + 1 < scene.strand_offsets[s + 1]; ++i) {
      const Vec3& a = scene.positions[i];
      const Vec3& b = scene.positions[i + 1];
      const double sat =
          has_sat ? 0.5 * (clamp01(scene.saturation[i]) + clamp01(scene.saturation[i + 1])) : 0.0;
      Rgb c = segmentColour(v, style, a, b, sat);
      Vec3 ca = a, cb = b;
      if (!clipSegment(v, &ca, &cb)) continue;
      if (style.depth_darkening > 0.0 && range > 0.0) {
        const double f = std::clamp((v.depth(0.5 * (ca + cb)) - depth_lo) / range, 0.0, 1.0);
        c = scaled(c, 1.0 - std::clamp(style.depth_darkening, 0.0, 1.0) * f);
      }
      Piece p;
      p.a = ca;
      p.b = cb;
      p.colour = clamped(c);
      p.width = style.line_width_px;
      list->pieces.push_back(p);
    }
  }

  // Head.
  if (scene.head && style.draw_head) {
    Solid h = makeSolid(v, scene.head->center_m, scene.head->radii_m, scene.head->orientation);
    h.fill = style.head_colour;
    h.fill_alpha = std::clamp(style.head_alpha, 0.0, 1.0);
    h.shaded = true;
    h.edge = scaled(style.head_colour, 0.7);
    h.edge_alpha = h.fill_alpha;
    h.edge_width = 1.2;
    list->solids.push_back(h);
  }

  // Obstacles.
  const Rgb oc = style.obstacle_colour;
  const double ow = style.obstacle_line_width_px;
  for (const AnalyticObstacle& o : scene.obstacles) {
    switch (o.shape) {
      case AnalyticObstacle::Shape::kSphere: {
        Solid s = makeSolid(v, o.center_m, Vec3::Constant(o.radius_m), Quat::Identity());
        s.fill = oc;
        s.fill_alpha = std::clamp(style.obstacle_fill_alpha, 0.0, 1.0);
        const int id = static_cast<int>(list->solids.size());
        const size_t n = s.silhouette.size();
        for (size_t i = 0; i < n; ++i)
          addPiece(v, s.silhouette[i], s.silhouette[(i + 1) % n], oc, 1.0, ow, list, id);
        list->solids.push_back(s);
        break;
      }
      case AnalyticObstacle::Shape::kBox: {
        const Mat3 r = o.orientation.normalized().toRotationMatrix();
        auto corner = [&](int i) {
          const Vec3 sgn((i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0);
          return Vec3(o.center_m + r * o.half_extents_m.cwiseProduct(sgn));
        };
        for (int i = 0; i < 8; ++i)
          for (int bit = 1; bit < 8; bit <<= 1)
            if (!(i & bit)) addLine(v, corner(i), corner(i | bit), oc, 1.0, ow, list);
        break;
      }
      case AnalyticObstacle::Shape::kPlane: {
        const Vec3 n = o.normal.normalized();
        const Vec3 foot = centre - n * (centre - o.center_m).dot(n);
        Vec3 e1 = Vec3::UnitX() - n * n.x();
        if (e1.norm() < 0.3) e1 = Vec3::UnitY() - n * n.y();
        e1.normalize();
        const Vec3 e2 = n.cross(e1);
        const double half = 0.75 * diameter;
        addGrid(v, foot, e1, e2, half, niceStep(half / 4.0), oc, 0.7, 0.6 * ow, list);
        break;
      }
    }
  }

  // Floor grid: perpendicular to the camera's world up, just under everything framed.
  if (style.draw_floor_grid) {
    const Vec3 n = v.world_up;
    double floor = std::numeric_limits<double>::infinity();
    for (const Vec3& p : framingPoints(scene)) floor = std::min(floor, p.dot(n));
    floor -= 0.02 * diameter;
    const Vec3 foot = centre - n * (centre.dot(n) - floor);
    Vec3 e1 = Vec3::UnitX() - n * n.x();
    if (e1.norm() < 0.3) e1 = Vec3::UnitY() - n * n.y();
    e1.normalize();
    const Vec3 e2 = n.cross(e1);
    const double half = 0.75 * diameter;
    addGrid(v, foot, e1, e2, half, niceStep(half / 5.0), style.grid_colour, 1.0, 1.0, list);
  }
}

void setColour(cairo_t* cr, const Rgb& c, double alpha) {
  cairo_set_source_rgba(cr, clamp01(c.r), clamp01(c.g), clamp01(c.b), clamp01(alpha));
}

/// Fills (and outlines) a solid's silhouette; nothing when the camera is inside it or part of
/// the silhouette is behind the near plane.
void drawSolid(cairo_t* cr, const View& v, const RenderStyle& style, const Solid& s) {
  if (s.silhouette.empty()) return;
  std::vector<double> xs, ys;
  xs.reserve(s.silhouette.size());
  ys.reserve(s.silhouette.size());
  for (const Vec3& p : s.silhouette) {
    if (!(v.depth(p) >= v.near)) return;
    double x, y;
    v.pixel(p, &x, &y);
    if (!(std::abs(x) < 1e6 && std::abs(y) < 1e6)) return;
    xs.push_back(x);
    ys.push_back(y);
  }
  cairo_new_path(cr);
  cairo_move_to(cr, xs[0], ys[0]);
  for (size_t i = 1; i < xs.size(); ++i) cairo_line_to(cr, xs[i], ys[i]);
  cairo_close_path(cr);
  if (s.fill_alpha > 0.0) {
    if (s.shaded) {
      double cx = 0.0, cy = 0.0;
      for (size_t i = 0; i < xs.size(); ++i) {
        cx += xs[i];
        cy += ys[i];
      }
      cx /= xs.size();
      cy /= ys.size();
      double r = 1.0;
      for (size_t i = 0; i < xs.size(); ++i) r = std::max(r, std::hypot(xs[i] - cx, ys[i] - cy));
      Eigen::Vector2d l(style.light_dir_camera.x(), -style.light_dir_camera.y());
      l = l.norm() > 1e-9 ? Eigen::Vector2d(l.normalized()) : Eigen::Vector2d(0.0, 0.0);
      cairo_pattern_t* pat = cairo_pattern_create_radial(cx + 0.4 * r * l.x(), cy + 0.4 * r * l.y(),
                                                         0.05 * r, cx, cy, 1.05 * r);
      const Rgb hi = mix(s.fill, Rgb{1.0, 1.0, 1.0}, 0.45);
      const Rgb lo = scaled(s.fill, 0.78);
      cairo_pattern_add_color_stop_rgba(pat, 0.0, hi.r, hi.g, hi.b, s.fill_alpha);
      cairo_pattern_add_color_stop_rgba(pat, 1.0, lo.r, lo.g, lo.b, s.fill_alpha);
      cairo_set_source(cr, pat);
      cairo_fill_preserve(cr);
      cairo_pattern_destroy(pat);
    } else {
      setColour(cr, s.fill, s.fill_alpha);
      cairo_fill_preserve(cr);
    }
  }
  if (s.edge_alpha > 0.0 && s.edge_width > 0.0) {
    setColour(cr, s.edge, s.edge_alpha);
    cairo_set_line_width(cr, s.edge_width);
    cairo_stroke(cr);
  } else {
    cairo_new_path(cr);
  }
}

/// Caption in the upper left corner on a translucent plate.
void drawCaption(cairo_t* cr, const RenderStyle& style, const std::string& text) {
  if (text.empty() || !(style.caption_font_px > 0.0)) return;
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, style.caption_font_px);
  cairo_text_extents_t ext;
  cairo_text_extents(cr, text.c_str(), &ext);
  const double m = 0.5 * style.caption_font_px;
  const double x = m, y = m + style.caption_font_px;
  cairo_rectangle(cr, x + ext.x_bearing - 0.3 * m, y + ext.y_bearing - 0.3 * m, ext.width + 0.6 * m,
                  ext.height + 0.6 * m);
  setColour(cr, style.background, 0.75);
  cairo_fill(cr);
  setColour(cr, style.caption_colour, 1.0);
  cairo_move_to(cr, x, y);
  cairo_show_text(cr, text.c_str());
  cairo_new_path(cr);
}

/// Dry -> wet colour bar in the lower left corner.
void drawLegend(cairo_t* cr, const RenderStyle& style, int width, int height) {
  if (!style.draw_legend || !style.colour_by_saturation || width < 200 || height < 120) return;
  const double font = std::max(9.0, 0.7 * (style.caption_font_px > 0 ? style.caption_font_px : 14));
  const double m = 12.0, bar_w = std::min(120.0, 0.25 * width), bar_h = 0.6 * font;
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, font);
  cairo_text_extents_t dry, wet;
  cairo_text_extents(cr, "dry", &dry);
  cairo_text_extents(cr, "wet", &wet);
  const double y = height - m - bar_h;
  const double x0 = m + dry.x_advance + 6.0;
  cairo_pattern_t* pat = cairo_pattern_create_linear(x0, 0.0, x0 + bar_w, 0.0);
  cairo_pattern_add_color_stop_rgb(pat, 0.0, style.dry_colour.r, style.dry_colour.g,
                                   style.dry_colour.b);
  cairo_pattern_add_color_stop_rgb(pat, 1.0, style.wet_colour.r, style.wet_colour.g,
                                   style.wet_colour.b);
  cairo_rectangle(cr, x0, y, bar_w, bar_h);
  cairo_set_source(cr, pat);
  cairo_fill(cr);
  cairo_pattern_destroy(pat);
  setColour(cr, style.caption_colour, 1.0);
  const double ty = y + 0.5 * bar_h + 0.35 * font;
  cairo_move_to(cr, m, ty);
  cairo_show_text(cr, "dry");
  cairo_move_to(cr, x0 + bar_w + 6.0, ty);
  cairo_show_text(cr, "wet");
  cairo_new_path(cr);
}

/// World axes triad in the lower right corner: x red, y green, z blue.
void drawAxes(cairo_t* cr, const View& v, const RenderStyle& style, int width, int height) {
  if (!style.draw_axes || width < 200 || height < 120) return;
  const double len = 22.0, m = 16.0;
  const double ox = width - m - len, oy = height - m - len;
  const Rgb colours[3] = {{0.8, 0.15, 0.1}, {0.1, 0.6, 0.15}, {0.15, 0.3, 0.85}};
  const char* names[3] = {"x", "y", "z"};
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 11.0);
  cairo_set_line_width(cr, 2.0);
  // Far axes first so that the one pointing at the viewer is on top.
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int a, int b) { return v.fwd[a] > v.fwd[b]; });
  for (int k : order) {
    const Vec3 e = Vec3::Unit(k);
    const double dx = len * e.dot(v.right), dy = -len * e.dot(v.up);
    setColour(cr, colours[k], 1.0);
    cairo_move_to(cr, ox, oy);
    cairo_line_to(cr, ox + dx, oy + dy);
    cairo_stroke(cr);
    cairo_move_to(cr, ox + 1.3 * dx - 3.0, oy + 1.3 * dy + 4.0);
    cairo_show_text(cr, names[k]);
    cairo_new_path(cr);
  }
}

/// Draws one scene into the box (0, 0) - (v.width, v.height) of the current user space.
void drawScene(cairo_t* cr, const View& v, const RenderScene& scene, const RenderStyle& style,
               double depth_lo, double depth_hi) {
  setColour(cr, style.background, 1.0);
  cairo_rectangle(cr, 0, 0, v.width, v.height);
  cairo_fill(cr);

  DrawList list;
  buildDrawList(v, scene, style, depth_lo, depth_hi, &list);
  std::vector<Item> items;
  items.reserve(list.pieces.size() + list.solids.size());
  for (size_t i = 0; i < list.pieces.size(); ++i) {
    const Piece& p = list.pieces[i];
    const Vec3 mid = 0.5 * (p.a + p.b);
    Item it{v.depth(mid), 0, false, i};
    for (size_t j = 0; j < list.solids.size(); ++j) {
      if (static_cast<int>(j) == p.skip_solid) continue;
      const Solid& s = list.solids[j];
      switch (rayRelation(v, s, mid)) {
        case RayRelation::kHidden:
          if (it.key < s.key || (it.key == s.key && it.tie <= 0)) {
            it.key = s.key;
            it.tie = 1;
          }
          break;
        case RayRelation::kInFront:
          if (it.key > s.key || (it.key == s.key && it.tie >= 0)) {
            it.key = s.key;
            it.tie = -1;
          }
          break;
        case RayRelation::kMiss:
          break;
      }
    }
    items.push_back(it);
  }
  for (size_t j = 0; j < list.solids.size(); ++j) items.push_back({list.solids[j].key, 0, true, j});
  std::stable_sort(items.begin(), items.end(), [](const Item& a, const Item& b) {
    return a.key != b.key ? a.key > b.key : a.tie > b.tie;
  });

  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (const Item& it : items) {
    if (it.solid) {
      drawSolid(cr, v, style, list.solids[it.index]);
      continue;
    }
    const Piece& p = list.pieces[it.index];
    double ax, ay, bx, by;
    v.pixel(p.a, &ax, &ay);
    v.pixel(p.b, &bx, &by);
    setColour(cr, p.colour, p.alpha);
    cairo_set_line_width(cr, p.width);
    cairo_move_to(cr, ax, ay);
    cairo_line_to(cr, bx, by);
    cairo_stroke(cr);
  }
  drawCaption(cr, style, scene.caption);
  drawLegend(cr, style, v.width, v.height);
  drawAxes(cr, v, style, v.width, v.height);
}

using SurfacePtr = std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)>;
using ContextPtr = std::unique_ptr<cairo_t, decltype(&cairo_destroy)>;

bool writeSurface(cairo_surface_t* surface, const std::string& png_path, std::string* why) {
  cairo_surface_flush(surface);
  const cairo_status_t st = cairo_surface_write_to_png(surface, png_path.c_str());
  if (st != CAIRO_STATUS_SUCCESS)
    return fail(why, "cannot write " + png_path + ": " + cairo_status_to_string(st));
  return true;
}

bool checkStyle(const RenderStyle& style, std::string* why) {
  if (!(style.line_width_px > 0.0) || !std::isfinite(style.line_width_px))
    return fail(why, "style: line_width_px is not > 0");
  if (!style.light_dir_camera.allFinite())
    return fail(why, "style: light_dir_camera is not finite");
  if (!(style.shininess >= 0.0) || !std::isfinite(style.shininess))
    return fail(why, "style: shininess is not >= 0");
  if (!std::isfinite(style.caption_font_px))
    return fail(why, "style: caption_font_px is not finite");
  return true;
}

}  // namespace

// ------------------------------------------------------------------------------ public

bool Camera::validate(std::string* why) const {
  if (!eye_m.allFinite()) return fail(why, "camera: eye " + vecText(eye_m) + " is not finite");
  if (!target_m.allFinite())
    return fail(why, "camera: target " + vecText(target_m) + " is not finite");
  if (!up.allFinite()) return fail(why, "camera: up " + vecText(up) + " is not finite");
  const Vec3 d = target_m - eye_m;
  if (!(d.norm() > 0.0)) return fail(why, "camera: eye and target coincide");
  if (!(up.norm() > 0.0) || d.normalized().cross(up.normalized()).norm() < 1e-6)
    return fail(why, "camera: up " + vecText(up) + " is zero or parallel to the view direction");
  if (!(fov_deg > 0.0 && fov_deg <= 170.0))
    return fail(why, "camera: fov_deg " + std::to_string(fov_deg) + " is not in (0, 170]");
  if (width_px < 1 || width_px > kMaxImagePx || height_px < 1 || height_px > kMaxImagePx)
    return fail(why, "camera: image size " + std::to_string(width_px) + " x " +
                         std::to_string(height_px) + " is not within [1, " +
                         std::to_string(kMaxImagePx) + "]");
  if (!(near_m > 0.0) || !std::isfinite(near_m))
    return fail(why, "camera: near_m " + std::to_string(near_m) + " is not > 0");
  return true;
}

Camera autoCamera(const Vec3List& points, Vec3 view_dir, const Camera& base, double fill) {
  Vec3List pts;
  pts.reserve(points.size());
  for (const Vec3& p : points)
    if (p.allFinite()) pts.push_back(p);
  if (pts.empty()) return base;
  if (!view_dir.allFinite() || !(view_dir.norm() > 1e-12)) view_dir = defaultViewDirection();
  view_dir.normalize();
  Camera cam = base;
  Vec3 up = base.up.allFinite() && base.up.norm() > 0.0 ? Vec3(base.up.normalized())
                                                        : Vec3(Vec3::UnitZ());
  if (view_dir.cross(up).norm() < 1e-3) {
    // Looking along the up axis: show the most horizontal world axis as up instead.
    up = std::abs(view_dir.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    if (view_dir.cross(up).norm() < 1e-3) up = Vec3::UnitY();
  }
  cam.up = up;
  if (!(fill > 0.0 && fill <= 1.0)) fill = 0.9;
  const double fov = base.fov_deg > 0.0 && base.fov_deg <= 170.0 ? base.fov_deg : 35.0;
  const int w = std::max(1, base.width_px), h = std::max(1, base.height_px);
  const double tv = fill * std::tan(fov * kPi / 360.0);
  const double th = tv * w / h;
  const Vec3 fwd = -view_dir;
  const Vec3 right = fwd.cross(up).normalized();
  const Vec3 cup = right.cross(fwd);

  Vec3 lo = pts.front(), hi = pts.front();
  for (const Vec3& p : pts) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  Vec3 centre = 0.5 * (lo + hi);
  const double extent = (hi - lo).norm();
  const double min_dist = extent > 0.0 ? 1e-3 * extent : 1.0;
  double dist = 1.0;
  auto fitDistance = [&]() {
    double d = extent > 0.0 ? 0.0 : 1.0;
    for (const Vec3& p : pts) {
      const Vec3 c = p - centre;
      const double x = c.dot(right), y = c.dot(cup), z = c.dot(fwd);
      d = std::max({d, std::abs(x) / th - z, std::abs(y) / tv - z, -z + min_dist});
    }
    return std::max(d, min_dist);
  };
  for (int iter = 0; iter < 4; ++iter) {
    dist = fitDistance();
    // Centre the projected bounding box: move the target within the plane at its depth.
    double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, ymin = xmin, ymax = -xmin;
    for (const Vec3& p : pts) {
      const Vec3 c = p - centre;
      const double z = dist + c.dot(fwd);
      const double x = c.dot(right) / z, y = c.dot(cup) / z;
      xmin = std::min(xmin, x);
      xmax = std::max(xmax, x);
      ymin = std::min(ymin, y);
      ymax = std::max(ymax, y);
    }
    centre += dist * (0.5 * (xmin + xmax) * right + 0.5 * (ymin + ymax) * cup);
  }
  dist = fitDistance();
  cam.target_m = centre;
  cam.eye_m = centre + dist * view_dir;
  return cam;
}

bool projectToPixel(const Camera& camera, const Vec3& p, double* x_px, double* y_px,
                    double* depth) {
  View v;
  if (!makeView(camera, &v, nullptr)) return false;
  const double d = v.depth(p);
  if (!(d >= v.near) || !p.allFinite()) return false;
  v.pixel(p, x_px, y_px);
  if (depth) *depth = d;
  return true;
}

bool RenderScene::validate(std::string* why) const {
  if (strand_offsets.size() < 2) return fail(why, "scene: no strands");
  if (strand_offsets.front() != 0) return fail(why, "scene: strand_offsets[0] is not 0");
  for (size_t s = 0; s + 1 < strand_offsets.size(); ++s)
    if (strand_offsets[s + 1] < strand_offsets[s])
      return fail(why, "scene: strand_offsets decrease at strand " + std::to_string(s));
  if (strand_offsets.back() != positions.size())
    return fail(why, "scene: strand_offsets end at " + std::to_string(strand_offsets.back()) +
                         " but there are " + std::to_string(positions.size()) + " positions");
  bool any_segment = false;
  for (size_t s = 0; s + 1 < strand_offsets.size(); ++s)
    any_segment = any_segment || strand_offsets[s + 1] - strand_offsets[s] >= 2;
  if (!any_segment) return fail(why, "scene: empty (no strand has two points)");
  for (size_t i = 0; i < positions.size(); ++i)
    if (!positions[i].allFinite())
      return fail(why, "scene: positions[" + std::to_string(i) + "] " + vecText(positions[i]) +
                           " is not finite");
  if (!saturation.empty()) {
    if (saturation.size() != positions.size())
      return fail(why, "scene: saturation has " + std::to_string(saturation.size()) +
                           " values for " + std::to_string(positions.size()) + " positions");
    for (size_t i = 0; i < saturation.size(); ++i)
      if (!std::isfinite(saturation[i]))
        return fail(why, "scene: saturation[" + std::to_string(i) + "] is not finite");
  }
  for (size_t k = 0; k < obstacles.size(); ++k) {
    const AnalyticObstacle& o = obstacles[k];
    const std::string name = "scene: obstacles[" + std::to_string(k) + "]";
    if (!o.center_m.allFinite()) return fail(why, name + ": centre is not finite");
    switch (o.shape) {
      case AnalyticObstacle::Shape::kSphere:
        if (!(o.radius_m > 0.0) || !std::isfinite(o.radius_m))
          return fail(why, name + ": sphere radius is not > 0");
        break;
      case AnalyticObstacle::Shape::kBox:
        if (!o.half_extents_m.allFinite() || !(o.half_extents_m.minCoeff() > 0.0))
          return fail(why, name + ": box half extents are not > 0");
        if (!o.orientation.coeffs().allFinite() || !(o.orientation.norm() > 0.0))
          return fail(why, name + ": box orientation is not a rotation");
        break;
      case AnalyticObstacle::Shape::kPlane:
        if (!o.normal.allFinite() || !(o.normal.norm() > 0.0))
          return fail(why, name + ": plane normal is zero or not finite");
        break;
    }
  }
  if (head) {
    if (!head->center_m.allFinite()) return fail(why, "scene: head centre is not finite");
    if (!head->radii_m.allFinite() || !(head->radii_m.minCoeff() > 0.0))
      return fail(why, "scene: head radii are not > 0");
    if (!head->orientation.coeffs().allFinite() || !(head->orientation.norm() > 0.0))
      return fail(why, "scene: head orientation is not a rotation");
  }
  return true;
}

Vec3List framingPoints(const RenderScene& scene) {
  Vec3List out;
  out.reserve(scene.positions.size() + 6 + 8 * scene.obstacles.size());
  for (const Vec3& p : scene.positions)
    if (p.allFinite()) out.push_back(p);
  auto ellipsoidExtremes = [&](const Vec3& c, const Vec3& r, const Quat& q) {
    const Mat3 a = q.normalized().toRotationMatrix() * r.asDiagonal();
    for (int k = 0; k < 3; ++k) {
      out.push_back(c + a.col(k));
      out.push_back(c - a.col(k));
    }
  };
  if (scene.head && scene.head->center_m.allFinite() && scene.head->radii_m.allFinite())
    ellipsoidExtremes(scene.head->center_m, scene.head->radii_m, scene.head->orientation);
  for (const AnalyticObstacle& o : scene.obstacles) {
    if (!o.center_m.allFinite()) continue;
    if (o.shape == AnalyticObstacle::Shape::kSphere && std::isfinite(o.radius_m)) {
      ellipsoidExtremes(o.center_m, Vec3::Constant(o.radius_m), Quat::Identity());
    } else if (o.shape == AnalyticObstacle::Shape::kBox && o.half_extents_m.allFinite()) {
      const Mat3 r = o.orientation.normalized().toRotationMatrix();
      for (int i = 0; i < 8; ++i) {
        const Vec3 sgn((i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0);
        out.push_back(o.center_m + r * o.half_extents_m.cwiseProduct(sgn));
      }
    }
  }
  // Drop anything non-finite produced from finite but extreme inputs.
  out.erase(std::remove_if(out.begin(), out.end(), [](const Vec3& p) { return !p.allFinite(); }),
            out.end());
  return out;
}

bool renderPng(const RenderScene& scene, const Camera& camera, const RenderStyle& style,
               const std::string& png_path, std::string* why) {
  if (png_path.empty()) return fail(why, "renderPng: empty output path");
  if (!scene.validate(why) || !checkStyle(style, why)) return false;
  View v;
  if (!makeView(camera, &v, why)) return false;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  hairDepthRange(v, scene, &lo, &hi);
  SurfacePtr surface(cairo_image_surface_create(CAIRO_FORMAT_ARGB32, v.width, v.height),
                     &cairo_surface_destroy);
  if (cairo_surface_status(surface.get()) != CAIRO_STATUS_SUCCESS)
    return fail(why, std::string("cannot create a Cairo surface: ") +
                         cairo_status_to_string(cairo_surface_status(surface.get())));
  {
    ContextPtr cr(cairo_create(surface.get()), &cairo_destroy);
    drawScene(cr.get(), v, scene, style, lo, hi);
    if (cairo_status(cr.get()) != CAIRO_STATUS_SUCCESS)
      return fail(why,
                  std::string("drawing failed: ") + cairo_status_to_string(cairo_status(cr.get())));
  }
  return writeSurface(surface.get(), png_path, why);
}

bool renderContactSheet(const std::vector<RenderScene>& frames, const Camera& camera,
                        const RenderStyle& style, int columns, const std::string& png_path,
                        std::string* why) {
  if (png_path.empty()) return fail(why, "renderContactSheet: empty output path");
  if (frames.empty()) return fail(why, "renderContactSheet: no frames");
  if (columns < 1)
    return fail(why, "renderContactSheet: columns " + std::to_string(columns) + " is not >= 1");
  for (size_t k = 0; k < frames.size(); ++k) {
    std::string w;
    if (!frames[k].validate(&w)) return fail(why, "frame " + std::to_string(k) + ": " + w);
  }
  if (!checkStyle(style, why)) return false;
  View v;
  if (!makeView(camera, &v, why)) return false;
  const int n = static_cast<int>(std::min<size_t>(frames.size(), 1u << 20));
  const int cols = std::min(columns, n);
  const int rows = (n + cols - 1) / cols;
  const long long sw = static_cast<long long>(cols) * v.width;
  const long long sh = static_cast<long long>(rows) * v.height;
  if (sw > kMaxSheetPx || sh > kMaxSheetPx)
    return fail(why, "renderContactSheet: sheet of " + std::to_string(sw) + " x " +
                         std::to_string(sh) + " pixels exceeds " + std::to_string(kMaxSheetPx));
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const RenderScene& f : frames) hairDepthRange(v, f, &lo, &hi);
  SurfacePtr surface(
      cairo_image_surface_create(CAIRO_FORMAT_ARGB32, static_cast<int>(sw), static_cast<int>(sh)),
      &cairo_surface_destroy);
  if (cairo_surface_status(surface.get()) != CAIRO_STATUS_SUCCESS)
    return fail(why, std::string("cannot create a Cairo surface: ") +
                         cairo_status_to_string(cairo_surface_status(surface.get())));
  {
    ContextPtr cr(cairo_create(surface.get()), &cairo_destroy);
    setColour(cr.get(), style.background, 1.0);
    cairo_paint(cr.get());
    for (int k = 0; k < n; ++k) {
      const int col = k % cols, row = k / cols;
      cairo_save(cr.get());
      cairo_translate(cr.get(), col * v.width, row * v.height);
      cairo_rectangle(cr.get(), 0, 0, v.width, v.height);
      cairo_clip(cr.get());
      drawScene(cr.get(), v, frames[k], style, lo, hi);
      // Tile border.
      cairo_rectangle(cr.get(), 0.5, 0.5, v.width - 1.0, v.height - 1.0);
      setColour(cr.get(), scaled(style.background, 0.8), 1.0);
      cairo_set_line_width(cr.get(), 1.0);
      cairo_stroke(cr.get());
      cairo_restore(cr.get());
    }
    if (cairo_status(cr.get()) != CAIRO_STATUS_SUCCESS)
      return fail(why,
                  std::string("drawing failed: ") + cairo_status_to_string(cairo_status(cr.get())));
  }
  return writeSurface(surface.get(), png_path, why);
}

}  // namespace io
}  // namespace wet_curly_hair
