#pragma once
// GenICam cameras through Aravis 0.8 (Debian libaravis-dev): the open library for GigE
// Vision and USB3 Vision cameras on Linux. This is the acquisition layer's first part:
// listing the cameras and a test grab (`flatscan cameras`); the station's camera source
// builds on it (docs/cameras.md).
//
// Aravis's types stay in the .cc: callers see plain C++.
//
// Aravis's in-process fake camera ("Fake" interface) stands in for hardware in tests
// and demos. Found in Aravis 0.8.26 (docs/cameras.md, "The fake camera"): it fills a
// queued buffer at every tick of its frame period (25 Hz by default) and ignores
// software triggers; frames are filled by a callback on its stream thread.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace flatscan {

// One GenICam device as discovery finds it.
struct CameraInfo {
  std::string id;        // Aravis's device id: what --source cameras:ID,ID and --test take
  std::string vendor, model, serial;
  std::string protocol;  // "GigEVision", "USB3Vision", "Fake"
  std::string address;   // IP address (GigE) or bus address (USB3)
};

// The devices found now (GigE Vision discovery on every interface and USB3 Vision; about
// 1 s). `include_fake`: also Aravis's in-process fake camera, whose id is "Fake_1".
std::vector<CameraInfo> ListCameras(bool include_fake);
nlohmann::json CameraInfoToJson(const CameraInfo& info);

// What a test grab saw: the backlight check. Grey levels are of Mono8 frames.
struct GrabStatistics {
  int frames = 0;            // complete frames grabbed
  int incomplete = 0;        // buffers with a status other than success (lost packets, ...)
  int timeouts = 0;          // waits for a frame that ran out
  int width = 0, height = 0;
  std::string pixel_format;  // GenICam name ("Mono8")
  double frames_per_second = 0;  // from the frames' timestamps
  double mean_grey = 0;          // 0-255
  double saturated_share = 0;    // share of pixels at 255 (a backlight that blooms)
  double dark_share = 0;         // share of pixels below 13, 5% of full scale
};

// Fills a Mono8 frame of the fake camera: `pixels` has width * height bytes.
using FakeFill = std::function<void(int width, int height, uint8_t* pixels, uint64_t frame_id)>;

class AravisCamera {
 public:
  // The camera whose id or serial number is `name` (discovery first, with the fake
  // camera when `include_fake`). Throws InputError naming it and how many cameras
  // were found when there is none such, or when it cannot be opened.
  static std::unique_ptr<AravisCamera> Open(const std::string& name, bool include_fake);
  // An in-process fake camera with this serial number, width x height Mono8, its
  // frames filled by `fill` (tests, demos, `--source aravis-fake:DIR`).
  static std::unique_ptr<AravisCamera> OpenFake(const std::string& serial, int width, int height, FakeFill fill);
  ~AravisCamera();
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  std::string Name() const;  // "vendor model (serial)"
  // Free-running acquisition in Mono8 (the camera must offer it) of `frames` frames,
  // waiting at most `timeout` for each; throws InputError when the camera refuses a
  // setting or gives no frame at all.
  GrabStatistics TestGrab(int frames, std::chrono::milliseconds timeout);

 private:
  class Impl;
  explicit AravisCamera(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The share statistics of one Mono8 frame added to `stats` (weighted by pixel count).
void AddGreyStatistics(const uint8_t* pixels, size_t count, GrabStatistics& stats, size_t& pixels_so_far);

}  // namespace flatscan
