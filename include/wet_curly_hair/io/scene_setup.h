// From a scene to a model: generate or import the groom, then build the HairModel.
#pragma once

#include <string>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/io/scene.h"

namespace wet_curly_hair {
namespace io {

/// The scene's groom: read from groom_file.file when set, else generated from `groom`.
bool makeGroom(const SceneConfig& scene, Groom* groom, std::string* why);

/// makeGroom + buildModel. On failure *model is unchanged.
bool buildSceneModel(const SceneConfig& scene, HairModel* model, std::string* why);

}  // namespace io
}  // namespace wet_curly_hair
