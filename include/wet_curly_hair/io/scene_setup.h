// From a scene to a model: generate or import the groom, then build the HairModel.
#pragma once

#include <string>

#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/io/hair_file.h"
#include "wet_curly_hair/io/scene.h"

namespace wet_curly_hair {
namespace io {

/// The scene's groom: read from groom_file.file when set, else generated from `groom`. When
/// `report` is non-null it receives what the import skipped (HairImportReport::warning() is the
/// one warning to show; a generated groom skips nothing). On failure *groom and *report are
/// unchanged.
bool makeGroom(const SceneConfig& scene, Groom* groom, std::string* why,
               HairImportReport* report = nullptr);

/// makeGroom + buildModel. On failure *model and *report are unchanged.
bool buildSceneModel(const SceneConfig& scene, HairModel* model, std::string* why,
                     HairImportReport* report = nullptr);

}  // namespace io
}  // namespace wet_curly_hair
