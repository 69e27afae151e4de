#include "wet_curly_hair/io/scene_setup.h"

#include "wet_curly_hair/io/hair_file.h"

namespace wet_curly_hair {
namespace io {

bool makeGroom(const SceneConfig& scene, Groom* groom, std::string* why) {
  if (!scene.validate(why)) return false;
  if (scene.groom_file.file.empty()) {
    *groom = generateGroom(scene.groom, scene.head.ellipsoid);
    return groom->validate(why);
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
  options.head_center_m = scene.head.ellipsoid.center_m;
  Groom imported;
  if (!importHairAsGroom(data, options, &imported, &inner)) {
    if (why) *why = "groom_file.file: " + scene.groom_file.file + ": " + inner;
    return false;
  }
  if (!imported.validate(why)) return false;
  *groom = std::move(imported);
  return true;
}

bool buildSceneModel(const SceneConfig& scene, HairModel* model, std::string* why) {
  Groom groom;
  if (!makeGroom(scene, &groom, why)) return false;
  return buildModel(groom, scene.groom.particle_mass_kg, scene.head, scene.solver, model, why);
}

}  // namespace io
}  // namespace wet_curly_hair
