#include "flatscan/acquisition/aravis_camera.h"

#include <arv.h>

#include <algorithm>
#include <mutex>

#include <fmt/format.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// Aravis's device list and interfaces are process-wide state: one caller at a time.
std::mutex& DiscoveryMutex() {
  static std::mutex mutex;
  return mutex;
}

std::string Text(const char* s) { return s ? s : ""; }

// Throws InputError "<what>: <Aravis's message>" when `error` is set.
void Check(GError* error, const std::string& what) {
  if (!error) return;
  const std::string message = error->message;
  g_error_free(error);
  ThrowInputError("{}: {}", what, message);
}

// The fake camera's fill callback (on its stream thread): the caller's FakeFill.
void FillFake(ArvBuffer* buffer, void* data, guint32, guint32, ArvPixelFormat) {
  const int width = arv_buffer_get_image_width(buffer), height = arv_buffer_get_image_height(buffer);
  // The only public way to the buffer's memory is const; the fake camera owns it here.
  auto* pixels = static_cast<uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
  (*static_cast<FakeFill*>(data))(width, height, pixels, arv_buffer_get_frame_id(buffer));
}

constexpr uint8_t kDarkBelow = 13;  // 5% of full scale

}  // namespace

std::vector<CameraInfo> ListCameras(bool include_fake) {
  std::lock_guard lock(DiscoveryMutex());
  if (include_fake) arv_enable_interface("Fake");
  else arv_disable_interface("Fake");
  arv_update_device_list();
  std::vector<CameraInfo> cameras;
  for (unsigned i = 0; i < arv_get_n_devices(); ++i)
    cameras.push_back({Text(arv_get_device_id(i)), Text(arv_get_device_vendor(i)), Text(arv_get_device_model(i)),
                       Text(arv_get_device_serial_nbr(i)), Text(arv_get_device_protocol(i)),
                       Text(arv_get_device_address(i))});
  return cameras;
}

nlohmann::json CameraInfoToJson(const CameraInfo& c) {
  return {{"id", c.id},         {"vendor", c.vendor},     {"model", c.model},
          {"serial", c.serial}, {"protocol", c.protocol}, {"address", c.address}};
}

void AddGreyStatistics(const uint8_t* pixels, size_t count, GrabStatistics& stats, size_t& pixels_so_far) {
  uint64_t sum = 0;
  size_t saturated = 0, dark = 0;
  for (size_t i = 0; i < count; ++i) {
    sum += pixels[i];
    saturated += pixels[i] == 255;
    dark += pixels[i] < kDarkBelow;
  }
  const double before = double(pixels_so_far), total = before + double(count);
  const auto blend = [&](double old_value, double frame_value) {
    return (old_value * before + frame_value) / total;
  };
  stats.mean_grey = blend(stats.mean_grey, double(sum));
  stats.saturated_share = blend(stats.saturated_share, double(saturated));
  stats.dark_share = blend(stats.dark_share, double(dark));
  pixels_so_far += count;
}

class AravisCamera::Impl {
 public:
  Impl(ArvCamera* camera, std::string name) : camera_(camera), name_(std::move(name)) {}
  ~Impl() {
    if (camera_) g_object_unref(camera_);
  }
  ArvCamera* camera_;
  std::string name_;
  std::unique_ptr<FakeFill> fill_;  // the fake camera's, alive as long as the camera
};

AravisCamera::AravisCamera(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AravisCamera::~AravisCamera() = default;

std::unique_ptr<AravisCamera> AravisCamera::Open(const std::string& name, bool include_fake) {
  const std::vector<CameraInfo> cameras = ListCameras(include_fake);
  const auto it = std::find_if(cameras.begin(), cameras.end(),
                               [&](const CameraInfo& c) { return c.id == name || c.serial == name; });
  if (it == cameras.end())
    ThrowInputError("camera '{}': not found among the {} GenICam camera(s) found (`flatscan cameras` lists them by "
                    "id and serial)",
                    name, cameras.size());
  std::lock_guard lock(DiscoveryMutex());
  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(it->id.c_str(), &error);
  Check(error, fmt::format("camera '{}': cannot open it", name));
  return std::unique_ptr<AravisCamera>(
      new AravisCamera(std::make_unique<Impl>(camera, fmt::format("{} {} ({})", it->vendor, it->model, it->serial))));
}

std::unique_ptr<AravisCamera> AravisCamera::OpenFake(const std::string& serial, int width, int height, FakeFill fill) {
  GError* error = nullptr;
  ArvDevice* device = arv_fake_device_new(serial.c_str(), &error);
  Check(error, fmt::format("fake camera '{}'", serial));
  ArvCamera* camera = arv_camera_new_with_device(device, &error);
  g_object_unref(device);  // the camera holds its own reference
  Check(error, fmt::format("fake camera '{}'", serial));
  auto impl = std::make_unique<Impl>(camera, fmt::format("Aravis Fake ({})", serial));
  ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera)));
  // Its sensor is 2048 x 2048: larger frames need a larger sensor first.
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_WIDTH, guint32(std::max(width, 2048)));
  arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_SENSOR_HEIGHT, guint32(std::max(height, 2048)));
  arv_camera_set_region(camera, 0, 0, width, height, &error);
  Check(error, fmt::format("fake camera '{}': {} x {}", serial, width, height));
  impl->fill_ = std::make_unique<FakeFill>(std::move(fill));
  arv_fake_camera_set_fill_pattern(fake, FillFake, impl->fill_.get());
  return std::unique_ptr<AravisCamera>(new AravisCamera(std::move(impl)));
}

std::string AravisCamera::Name() const { return impl_->name_; }

GrabStatistics AravisCamera::TestGrab(int frames, std::chrono::milliseconds timeout) {
  ArvCamera* camera = impl_->camera_;
  const std::string& name = impl_->name_;
  GError* error = nullptr;
  arv_camera_set_pixel_format(camera, ARV_PIXEL_FORMAT_MONO_8, &error);
  Check(error, fmt::format("camera {}: cannot set pixel format Mono8", name));
  arv_camera_clear_triggers(camera, &error);  // free running
  Check(error, fmt::format("camera {}: cannot switch triggers off", name));
  arv_camera_set_acquisition_mode(camera, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
  Check(error, fmt::format("camera {}: cannot set continuous acquisition", name));
  const guint payload = arv_camera_get_payload(camera, &error);
  Check(error, fmt::format("camera {}: cannot read the payload size", name));
  ArvStream* stream = arv_camera_create_stream(camera, nullptr, nullptr, &error);
  Check(error, fmt::format("camera {}: cannot open a stream", name));
  for (int i = 0; i < 4; ++i) arv_stream_push_buffer(stream, arv_buffer_new_allocate(payload));

  GrabStatistics stats;
  stats.pixel_format = Text(arv_camera_get_pixel_format_as_string(camera, nullptr));
  size_t pixels = 0;
  guint64 first_ns = 0, last_ns = 0;
  arv_camera_start_acquisition(camera, &error);
  if (!error) {
    while (stats.frames < frames && stats.timeouts + stats.incomplete < frames) {
      ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream, guint64(timeout.count()) * 1000);
      if (!buffer) {
        ++stats.timeouts;
        continue;
      }
      if (arv_buffer_get_status(buffer) == ARV_BUFFER_STATUS_SUCCESS) {
        stats.width = arv_buffer_get_image_width(buffer);
        stats.height = arv_buffer_get_image_height(buffer);
        // The fake camera reports size 0 for a frame its callback filled: the size is the image's.
        const auto* data = static_cast<const uint8_t*>(arv_buffer_get_data(buffer, nullptr));
        AddGreyStatistics(data, size_t(stats.width) * size_t(stats.height), stats, pixels);
        last_ns = arv_buffer_get_system_timestamp(buffer);
        if (stats.frames++ == 0) first_ns = last_ns;
      } else {
        ++stats.incomplete;
      }
      arv_stream_push_buffer(stream, buffer);
    }
    arv_camera_stop_acquisition(camera, nullptr);
  }
  g_object_unref(stream);
  Check(error, fmt::format("camera {}: cannot start acquisition", name));
  if (stats.frames == 0)
    ThrowInputError("camera {}: no complete frame in {} tries ({} timed out after {} ms, {} incomplete)", name,
                    stats.timeouts + stats.incomplete, stats.timeouts, timeout.count(), stats.incomplete);
  if (stats.frames > 1 && last_ns > first_ns) stats.frames_per_second = (stats.frames - 1) * 1e9 / double(last_ns - first_ns);
  return stats;
}

}  // namespace flatscan
