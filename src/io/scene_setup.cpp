#include "wet_curly_hair/io/scene_setup.h"

#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/io/hair_file.h"

namespace wet_curly_hair {
namespace io {

bool makeGroom(const SceneConfig& scene, Groom* groom, std::string* why, HairImportReport* report) {
  if (!scene.validate(why)) return false;
  if (scene.groom_file.file.empty()) {
    *groom = generateGroom(scene.groom, scene.head.ellipsoid);
    if (!groom->validate(why)) return false;
    if (report != nullptr) {
      *report = HairImportReport();
      report->strands_in_file = report->strands_imported = groom->strandCount();
    }
    return true;
  }
  HairFileData data;
  std::string inner;
  if (!readHairFile(scene.groom_file.file, &data, &inner)) {
    if (why) *why = "groom_file.file: " + inner;
    return false;
  }
  HairImportOptions options;
  options.scale = scene.groom_file.scale;
  if (!parseUpAxis(scene.groom_file.up_axis, &options.up, &inner)) {
    if (why) *why = "groom_file.up_axis: " + inner;
    return false;
  }
  options.offset_m = scene.groom_file.offset_m;
  options.resample_particles = scene.groom_file.resample_particles;
  options.resample_edge_m = scene.groom_file.resample_edge_m;
  options.min_edge_m = scene.groom_file.min_edge_m;
  options.head_center_m = scene.head.ellipsoid.center_m;
  options.roots_on_scalp = scene.groom_file.roots_on_scalp;
  options.scalp = scene.head.ellipsoid;
  Groom imported;
  HairImportReport imported_report;
  if (!importHairAsGroom(data, options, &imported, &inner, &imported_report)) {
    if (why) *why = "groom_file.file: " + scene.groom_file.file + ": " + inner;
    return false;
  }
  if (!imported.validate(why)) return false;
  *groom = std::move(imported);
  if (report != nullptr) *report = std::move(imported_report);
  return true;
}

bool buildSceneModel(const SceneConfig& scene, HairModel* model, std::string* why,
                     HairImportReport* report) {
  Groom groom;
  HairImportReport r;
  if (!makeGroom(scene, &groom, why, &r)) return false;
  // Guides are chosen by the same rule (groom.guides) whether it was generated or read from a
  // .hair file.
  if (!buildFollowerModel(groom, scene.groom.linear_density_kg_per_m, scene.groom.follow_ratio,
                          scene.head, scene.solver, model, why, guideChoice(scene.groom.guides)))
    return false;
  if (report != nullptr) *report = std::move(r);
  return true;
}

}  // namespace io
}  // namespace wet_curly_hair
