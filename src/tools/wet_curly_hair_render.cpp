// wet_curly_hair_render: PNG pictures of `.hair` frames (one picture, or a contact sheet of
// several frames sharing one camera). See viewer/render.h for how strands are drawn.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/viewer/render.h"

namespace {

using namespace wet_curly_hair;

const char* kUsage =
    "usage: wet_curly_hair_render [--out OUT.png] [--sheet COLUMNS] [--width PX] [--height PX]\n"
    "                             [--view x,y,z] [--up AXIS] [--scale S] [--fov DEG]\n"
    "                             [--obstacle SPEC]... [--head] [--head-center x,y,z]\n"
    "                             [--head-radii a,b,c] [--caption TEXT] [--fps F]\n"
    "                             [--line-width PX] [--grid] [--no-saturation]\n"
    "                             FRAME.hair [FRAME2.hair ...]\n"
    "\n"
    "One file gives one picture; several files, or --sheet, give a contact sheet (one tile per\n"
    "file, COLUMNS tiles per row; default 3 when several files). All frames share one camera,\n"
    "fitted to all of them (and to the head and obstacles) together.\n"
    "\n"
    "  --out OUT.png      output (default: FRAME.png, or FRAME_sheet.png for a sheet, next to\n"
    "                     the first input)\n"
    "  --sheet COLUMNS    contact sheet with COLUMNS columns (>= 1)\n"
    "  --width, --height  picture (or tile) size in pixels (default 800 x 800; 400 x 400 tiles)\n"
    "  --view x,y,z       direction from the hair toward the camera, world frame (REP-103: x\n"
    "                     forward, y left, z up); default 1,0.55,0.3: front-left, slightly above\n"
    "  --up AXIS          the files' up axis (x, y, z, -x, -y, -z; default z); points are turned\n"
    "                     to z up as the .hair import does (y up: (x, y, z) -> (z, x, y))\n"
    "  --scale S          multiply file coordinates by S (default 1)\n"
    "  --fov DEG          vertical field of view (default 35)\n"
    "  --obstacle SPEC    sphere:x=..,y=..,z=..,r=..  box:x=..,y=..,z=..,hx=..,hy=..,hz=..\n"
    "                     plane:x=..,y=..,z=..,nx=..,ny=..,nz=..  (as wet_curly_hair_run;\n"
    "                     world frame after --up and --scale; repeatable)\n"
    "  --head             draw the head ellipsoid (default: centre 0,0,0, radii\n"
    "                     0.095,0.078,0.11 m, the built-in scene's head at rest; frames do not\n"
    "                     record the head pose, so a moving head is drawn where it started)\n"
    "  --head-center x,y,z, --head-radii a,b,c   place / size the head ellipsoid (world frame\n"
    "                     after --up and --scale; imply --head)\n"
    "  --caption TEXT     caption (a sheet prefixes it to each tile's own caption)\n"
    "  --fps F            frame rate for captions from file names (default 60):\n"
    "                     frame_00090.hair -> \"frame 90   t = 1.50 s\"\n"
    "  --line-width PX    hair line width (default 2, sheets 1.4)\n"
    "  --grid             draw a floor grid under the scene\n"
    "  --no-saturation    draw every strand in the dry colour\n"
    "Saturation comes from the file's transparency array when present (frames written by\n"
    "wet_curly_hair_run carry it there); colour runs from brown (dry) to blue-black (wet).\n"
    "Exit codes: 0 written, 1 rendering or writing failed, 2 bad arguments or input.\n";

int usageError(const std::string& message) {
  std::fprintf(stderr, "wet_curly_hair_render: %s\n(run with --help for usage)\n", message.c_str());
  return 2;
}

bool parseNumber(const std::string& text, double* v) {
  if (text.empty()) return false;
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (*end != '\0' || !std::isfinite(x)) return false;
  *v = x;
  return true;
}

bool parseInt(const std::string& text, int lo, int hi, int* v) {
  if (text.empty()) return false;
  char* end = nullptr;
  const long x = std::strtol(text.c_str(), &end, 10);
  if (*end != '\0' || x < lo || x > hi) return false;
  *v = static_cast<int>(x);
  return true;
}

bool parseVec3(const std::string& text, Vec3* v) {
  std::vector<double> parts;
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    double x;
    if (!parseNumber(
            text.substr(start, comma == std::string::npos ? std::string::npos : comma - start), &x))
      return false;
    parts.push_back(x);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (parts.size() != 3) return false;
  *v = Vec3(parts[0], parts[1], parts[2]);
  return true;
}

std::string baseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string withoutExtension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return path;
  return path.substr(0, dot);
}

/// "frame 90   t = 1.50 s" for ".../frame_00090.hair" at 60 frames/s, else the file's stem.
std::string captionFromName(const std::string& path, double fps) {
  const std::string stem = withoutExtension(baseName(path));
  size_t i = stem.size();
  while (i > 0 && std::isdigit(static_cast<unsigned char>(stem[i - 1]))) --i;
  if (i < stem.size() && i >= 6 && stem.compare(i - 6, 6, "frame_") == 0 && stem.size() - i < 10) {
    const long frame = std::strtol(stem.c_str() + i, nullptr, 10);
    char buf[96];
    std::snprintf(buf, sizeof(buf), "frame %ld   t = %.2f s", frame, frame / fps);
    return buf;
  }
  return stem;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out_path, caption, why;
  int sheet_columns = 0;
  int width = 0, height = 0;
  Vec3 view = io::defaultViewDirection();
  io::UpAxis up = io::UpAxis::kZUp;
  double scale = 1.0, fov = 35.0, fps = 60.0, line_width = 0.0;
  bool head = false, grid = false, use_saturation = true;
  io::EllipsoidOutline head_shape;
  {
    const EllipsoidShape builtin;  // the built-in scene's head
    head_shape.center_m = builtin.center_m;
    head_shape.radii_m = builtin.radii_m;
  }
  std::vector<AnalyticObstacle> obstacles;
  std::vector<std::string> inputs;

  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string* v) {
      if (i + 1 >= argc) return false;
      *v = argv[++i];
      return true;
    };
    std::string v;
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (a == "--out") {
      if (!value(&out_path) || out_path.empty()) return usageError("--out needs a file name");
    } else if (a == "--sheet") {
      if (!value(&v) || !parseInt(v, 1, 64, &sheet_columns))
        return usageError("--sheet needs a column count in [1, 64]");
    } else if (a == "--width") {
      if (!value(&v) || !parseInt(v, 16, 16384, &width))
        return usageError("--width needs a pixel count in [16, 16384]");
    } else if (a == "--height") {
      if (!value(&v) || !parseInt(v, 16, 16384, &height))
        return usageError("--height needs a pixel count in [16, 16384]");
    } else if (a == "--view") {
      if (!value(&v) || !parseVec3(v, &view) || !(view.norm() > 0.0))
        return usageError("--view needs a non-zero direction x,y,z, e.g. --view 1,0.5,0.3");
    } else if (a == "--up") {
      if (!value(&v)) return usageError("--up needs an axis (x, y, z, -x, -y, -z)");
      if (!io::parseUpAxis(v, &up, &why)) return usageError("--up: " + why);
    } else if (a == "--scale") {
      if (!value(&v) || !parseNumber(v, &scale) || !(scale > 0.0))
        return usageError("--scale needs a number > 0");
    } else if (a == "--fov") {
      if (!value(&v) || !parseNumber(v, &fov) || !(fov > 1.0 && fov < 170.0))
        return usageError("--fov needs degrees in (1, 170)");
    } else if (a == "--fps") {
      if (!value(&v) || !parseNumber(v, &fps) || !(fps > 0.0))
        return usageError("--fps needs a rate > 0");
    } else if (a == "--line-width") {
      if (!value(&v) || !parseNumber(v, &line_width) || !(line_width > 0.0 && line_width <= 100.0))
        return usageError("--line-width needs pixels in (0, 100]");
    } else if (a == "--obstacle") {
      AnalyticObstacle o;
      if (!value(&v))
        return usageError("--obstacle needs a spec, e.g. sphere:x=0.2,y=0,z=0,r=0.05");
      if (!AnalyticObstacle::parse(v, &o, &why))
        return usageError("--obstacle '" + v + "': " + why);
      obstacles.push_back(o);
    } else if (a == "--head") {
      head = true;
    } else if (a == "--head-center") {
      if (!value(&v) || !parseVec3(v, &head_shape.center_m))
        return usageError("--head-center needs x,y,z");
      head = true;
    } else if (a == "--head-radii") {
      if (!value(&v) || !parseVec3(v, &head_shape.radii_m) || !(head_shape.radii_m.minCoeff() > 0))
        return usageError("--head-radii needs three radii > 0: a,b,c");
      head = true;
    } else if (a == "--caption") {
      if (!value(&caption)) return usageError("--caption needs a text");
    } else if (a == "--grid") {
      grid = true;
    } else if (a == "--no-saturation") {
      use_saturation = false;
    } else if (a.size() > 1 && a[0] == '-') {
      return usageError("unknown option '" + a + "'");
    } else {
      inputs.push_back(a);
    }
  }
  if (inputs.empty()) return usageError("no input .hair file");
  const bool sheet = sheet_columns > 0 || inputs.size() > 1;
  if (sheet && sheet_columns == 0)
    sheet_columns = std::min<int>(3, static_cast<int>(inputs.size()));
  if (out_path.empty())
    out_path = withoutExtension(inputs.front()) + (sheet ? "_sheet.png" : ".png");

  // Read every frame.
  const Mat3 rot = io::upAxisRotation(up);
  std::vector<io::RenderScene> frames;
  frames.reserve(inputs.size());
  for (const std::string& path : inputs) {
    io::HairFileData data;
    if (!io::readHairFile(path, &data, &why)) return usageError(why);
    io::RenderScene s;
    s.strand_offsets = data.strand_offsets;
    const int n = data.pointCount();
    s.positions.resize(n);
    for (int i = 0; i < n; ++i)
      s.positions[i] =
          scale * (rot * Vec3(data.points[3 * i], data.points[3 * i + 1], data.points[3 * i + 2]));
    if (use_saturation && data.transparency.size() == static_cast<size_t>(n))
      s.saturation.assign(data.transparency.begin(), data.transparency.end());
    s.obstacles = obstacles;
    if (head) s.head = head_shape;
    const std::string own = captionFromName(path, fps);
    s.caption = caption.empty() ? own : (sheet ? caption + "   " + own : caption);
    if (!s.validate(&why)) return usageError(path + ": " + why);
    frames.push_back(std::move(s));
  }

  // One camera for all frames.
  io::Camera base;
  base.width_px = width > 0 ? width : (sheet ? 400 : 800);
  base.height_px = height > 0 ? height : (sheet ? 400 : 800);
  base.fov_deg = fov;
  Vec3List all;
  for (const io::RenderScene& f : frames) {
    const Vec3List pts = io::framingPoints(f);
    all.insert(all.end(), pts.begin(), pts.end());
  }
  io::Camera camera = io::autoCamera(all, view, base);
  camera.near_m = 1e-4 * std::max(1e-9, (camera.eye_m - camera.target_m).norm());

  io::RenderStyle style;
  style.colour_by_saturation = use_saturation;
  style.draw_floor_grid = grid;
  style.line_width_px = line_width > 0.0 ? line_width : (sheet ? 1.4 : 2.0);
  if (sheet) style.caption_font_px = 14.0;

  const bool ok = sheet
                      ? io::renderContactSheet(frames, camera, style, sheet_columns, out_path, &why)
                      : io::renderPng(frames.front(), camera, style, out_path, &why);
  if (!ok) {
    std::fprintf(stderr, "wet_curly_hair_render: %s\n", why.c_str());
    return 1;
  }
  std::printf("%s\n", out_path.c_str());
  return 0;
}
