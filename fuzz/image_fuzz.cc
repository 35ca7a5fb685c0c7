// Fuzz target: image to verdict. The input is a PNG (mutated); it is read as the left
// image of a small simulated rig whose right image is the same file, and inspected. The
// verdict itself is not checked here (the studies do that): only that every input ends
// in a measurement or an InputError ("not measured"), within bounded memory.
#include <opencv2/core.hpp>

#include "fuzz/fuzz_target.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/io/image_io.h"
#include "flatscan/simulation/station.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const flatscan::Station station = [] {
    flatscan::SceneConfig scene = flatscan::ScenePreset("paper");
    scene.left_camera.width = scene.right_camera.width = 320;  // small images: fast inputs
    scene.left_camera.height = scene.right_camera.height = 240;
    return flatscan::BuildStation(scene);
  }();
  return flatscan::fuzz::ReadAsFile(data, size, "image.png", [](const auto& p) {
    const cv::Size size(station.rig.left.width, station.rig.left.height);
    const cv::Mat1b image = flatscan::ReadGreyImage(p.string(), size);
    flatscan::InspectionParams params;
    params.thickness_mm = 0.2;
    flatscan::InspectPart(station.rig, station.plane, image, image, params);
  });
}
