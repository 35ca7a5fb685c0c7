#include "flatscan/acquisition/aravis_camera.h"

#include <arpa/inet.h>
#include <arv.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

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

// A fake camera's fill, and what each buffer given to it by a trigger carries: the
// trigger's tag and when the camera got the trigger.
struct FakeContext {
  struct Triggered {
    uint64_t tag = 0;
    int64_t at_ns = 0;  // host clock, UTC
  };
  FakeFill fill;
  std::mutex mutex;
  std::map<ArvBuffer*, Triggered> triggered;
  // Free running as on a line: the n-th frame gets tag n, and the line's n-th pulse
  // as its time, first_pulse_ns + (n - 1) * period_ns.
  bool count_frames = false;
  uint64_t frames = 0;
  int64_t first_pulse_ns = 0, period_ns = 0;
};

// The fake camera's fill callback (on its stream thread): the caller's FakeFill. In
// Mono16 the 8-bit fill is spread to 16 bits, v * 257 (255 -> 65535).
void FillFake(ArvBuffer* buffer, void* data, guint32, guint32, ArvPixelFormat format) {
  auto& fake = *static_cast<FakeContext*>(data);
  const int width = arv_buffer_get_image_width(buffer), height = arv_buffer_get_image_height(buffer);
  FakeContext::Triggered t;
  {
    std::lock_guard lock(fake.mutex);
    if (fake.count_frames) {
      t.tag = ++fake.frames;
      t.at_ns = fake.first_pulse_ns + int64_t(t.tag - 1) * fake.period_ns;
    } else if (const auto it = fake.triggered.find(buffer); it != fake.triggered.end()) {
      t = it->second;
      fake.triggered.erase(it);
    }
  }
  // The only public way to the buffer's memory is const; the fake camera owns it here.
  auto* pixels = static_cast<uint8_t*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
  if (format == ARV_PIXEL_FORMAT_MONO_16) {
    std::vector<uint8_t> grey(size_t(width) * size_t(height));
    fake.fill(width, height, grey.data(), t.tag);
    auto* words = reinterpret_cast<uint16_t*>(pixels);
    for (size_t i = 0; i < grey.size(); ++i) words[i] = uint16_t(grey[i] * 257);
  } else {
    fake.fill(width, height, pixels, t.tag);
  }
  // Its time is when it was triggered (its exposure), not when its thread came to fill
  // it: a loaded machine delays the thread, which would put the two fakes' frames of
  // one trigger apart (103 ms, measured under ctest -j2 beside a build).
  // Its own clock, too, as two PTP-synchronised cameras would stamp one trigger's frames.
  if (t.at_ns > 0) {
    arv_buffer_set_system_timestamp(buffer, guint64(t.at_ns));
    arv_buffer_set_timestamp(buffer, guint64(t.at_ns));
  }
}

constexpr uint8_t kDarkBelow = 13;  // 5% of full scale
// The fake camera's frame period in triggered acquisition: a trigger waits at most this
// long for its frame.
constexpr guint32 kFakeFramePeriodUs = 4000;

std::string BufferProblem(ArvBufferStatus status) {
  switch (status) {
    case ARV_BUFFER_STATUS_SUCCESS: return "";
    case ARV_BUFFER_STATUS_CLEARED: return "buffer cleared";
    case ARV_BUFFER_STATUS_TIMEOUT: return "timeout while the frame arrived";
    case ARV_BUFFER_STATUS_MISSING_PACKETS: return "missing packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID: return "wrong packet id";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH: return "size mismatch (the frame did not fit the buffer)";
    case ARV_BUFFER_STATUS_FILLING: return "still filling";
    case ARV_BUFFER_STATUS_ABORTED: return "aborted";
    default: return fmt::format("status {}", int(status));
  }
}

// A stream and its buffers, shared with the frames still held: a frame's buffer comes
// back here when released. A fake camera's buffers wait in `spare` until a trigger
// (`per_trigger`); a real camera's go straight back to the stream.
struct StreamState {
  ArvStream* stream = nullptr;
  bool per_trigger = false;
  // The camera's fill context, shared: a frame still held after its camera was closed
  // (a camera lost and reopened) comes back here, and the stream's thread may fill with
  // it until the stream is gone (members go after the destructor's body).
  std::shared_ptr<FakeContext> fake_context;
  std::mutex mutex;
  std::vector<ArvBuffer*> spare;
  std::set<ArvBuffer*> undersized;  // made by FakeTriggerFault::incomplete, freed on return

  ~StreamState() {
    for (ArvBuffer* b : spare) g_object_unref(b);
    if (stream) g_object_unref(stream);  // frees the buffers it holds
  }
  void Return(ArvBuffer* buffer) {
    if (!per_trigger) {
      arv_stream_push_buffer(stream, buffer);
      return;
    }
    std::lock_guard lock(mutex);
    if (undersized.erase(buffer)) {  // never filled: its trigger is forgotten here
      {
        std::lock_guard fake_lock(fake_context->mutex);
        fake_context->triggered.erase(buffer);
      }
      g_object_unref(buffer);
    } else {
      spare.push_back(buffer);
    }
  }
};

}  // namespace

int64_t HostClockNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

PixelFormat ParsePixelFormat(const std::string& name, const std::string& option) {
  for (const PixelFormat f : {PixelFormat::kMono8, PixelFormat::kMono10, PixelFormat::kMono12, PixelFormat::kMono16})
    if (PixelFormatName(f) == name) return f;
  ThrowInputError("{} '{}': expected Mono8, Mono10, Mono12 or Mono16 (unpacked)", option, name);
}

std::string PixelFormatName(PixelFormat format) { return fmt::format("Mono{}", PixelFormatBits(format)); }

int PixelFormatBits(PixelFormat format) {
  switch (format) {
    case PixelFormat::kMono8: return 8;
    case PixelFormat::kMono10: return 10;
    case PixelFormat::kMono12: return 12;
    case PixelFormat::kMono16: return 16;
  }
  return 8;
}

cv::Mat1b ReduceToMono8(const uint16_t* pixels, int width, int height, size_t stride_words, int bits) {
  FLATSCAN_CHECK(bits >= 8 && bits <= 16);
  const int shift = bits - 8;
  cv::Mat1b out(height, width);
  for (int y = 0; y < height; ++y) {
    const uint16_t* row = pixels + size_t(y) * stride_words;
    uint8_t* to = out.ptr(y);
    for (int x = 0; x < width; ++x) to[x] = uint8_t(std::min(255, row[x] >> shift));
  }
  return out;
}

CameraInterfaces ParseCameraInterfaces(const std::string& list, const std::string& option) {
  CameraInterfaces interfaces{false, false, false};
  std::string rest = list;
  while (true) {
    const size_t comma = rest.find(',');
    const std::string name = rest.substr(0, comma);
    if (name == "gige") interfaces.gige = true;
    else if (name == "usb3") interfaces.usb3 = true;
    else if (name == "fake") interfaces.fake = true;
    else ThrowInputError("{} '{}': expected a comma-separated list of gige, usb3, fake", option, list);
    if (comma == std::string::npos) break;
    rest = rest.substr(comma + 1);
  }
  return interfaces;
}

namespace {

void EnableInterfacesLocked(const CameraInterfaces& interfaces) {
  for (const auto& [id, on] : {std::pair{"GigEVision", interfaces.gige}, std::pair{"USB3Vision", interfaces.usb3},
                               std::pair{"Fake", interfaces.fake}})
    on ? arv_enable_interface(id) : arv_disable_interface(id);
}

bool IsIpv4Address(const std::string& name) {
  in_addr address{};
  return inet_pton(AF_INET, name.c_str(), &address) == 1;
}

}  // namespace

std::vector<CameraInfo> ListCameras(const CameraInterfaces& interfaces) {
  std::lock_guard lock(DiscoveryMutex());
  EnableInterfacesLocked(interfaces);
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
  Impl(ArvCamera* camera, std::string name) : camera_(camera), name_(std::move(name)) {
    // Aravis emits control-lost from its own thread when the camera stops answering (a
    // GigE camera's heartbeat, a USB3 camera unplugged).
    control_lost_handler_ =
        g_signal_connect(arv_camera_get_device(camera_), "control-lost", G_CALLBACK(&Impl::OnControlLost), this);
  }
  ~Impl() {
    g_signal_handler_disconnect(arv_camera_get_device(camera_), control_lost_handler_);
    StopAcquisition();
    stream_.reset();
    if (camera_) g_object_unref(camera_);
  }
  static void OnControlLost(ArvDevice*, gpointer self) { static_cast<Impl*>(self)->control_lost_ = true; }
  void StopAcquisition() {
    if (!stream_) return;
    arv_camera_stop_acquisition(camera_, nullptr);
  }
  ArvCamera* camera_;
  std::string name_;
  std::shared_ptr<FakeContext> fake_;  // the fake camera's fill; its streams share it
  gulong control_lost_handler_ = 0;
  std::atomic<bool> control_lost_{false};
  guint32 fake_period_us_ = kFakeFramePeriodUs;
  std::shared_ptr<StreamState> stream_;
};

AravisCamera::AravisCamera(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AravisCamera::~AravisCamera() = default;

std::unique_ptr<AravisCamera> AravisCamera::Open(const std::string& name, const CameraInterfaces& interfaces) {
  if (interfaces.gige && IsIpv4Address(name)) return OpenGigEByAddress(name);
  const std::vector<CameraInfo> cameras = ListCameras(interfaces);
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

// Aravis talks to that address alone (a camera on the subnet of one of the host's
// interfaces is not even searched for): no discovery broadcast.
std::unique_ptr<AravisCamera> AravisCamera::OpenGigEByAddress(const std::string& address) {
  std::lock_guard lock(DiscoveryMutex());
  EnableInterfacesLocked({true, false, false});
  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(address.c_str(), &error);
  Check(error, fmt::format("camera '{}': cannot open the GigE Vision camera at this address", address));
  const std::string name = fmt::format("{} {} ({}, {})", Text(arv_camera_get_vendor_name(camera, nullptr)),
                                       Text(arv_camera_get_model_name(camera, nullptr)),
                                       Text(arv_camera_get_device_serial_number(camera, nullptr)), address);
  return std::unique_ptr<AravisCamera>(new AravisCamera(std::make_unique<Impl>(camera, name)));
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
  impl->fake_ = std::make_shared<FakeContext>();
  impl->fake_->fill = std::move(fill);
  arv_fake_camera_set_fill_pattern(fake, FillFake, impl->fake_.get());
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

bool AravisCamera::IsFake() const { return impl_->fake_ != nullptr; }

void AravisCamera::Start(const AcquisitionSettings& settings) {
  ArvCamera* camera = impl_->camera_;
  const std::string& name = impl_->name_;
  FLATSCAN_CHECK(!impl_->stream_);
  FLATSCAN_CHECK(settings.buffers >= 1);
  GError* error = nullptr;
  const std::string format = PixelFormatName(settings.pixel_format);
  arv_camera_set_pixel_format_from_string(camera, format.c_str(), &error);
  Check(error, fmt::format("camera {}: cannot set pixel format {}", name, format));
  arv_camera_set_acquisition_mode(camera, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
  Check(error, fmt::format("camera {}: cannot set continuous acquisition", name));
  SetExposureAndGain(settings.exposure_us, settings.gain_db);
  auto state = std::make_shared<StreamState>();
  state->fake_context = impl_->fake_;
  if (IsFake()) {
    // It ignores triggers. Software: a short frame period, and one buffer per trigger.
    // Line0: free running at the line's rate, every buffer queued (two fakes tick
    // together: their ticks are multiples of the period on the host clock).
    const bool line = settings.trigger == TriggerSource::kLine0;
    FLATSCAN_CHECK(!line || (settings.fake_line_hz >= 1 && settings.fake_line_hz <= 100));
    state->per_trigger = !line;
    impl_->fake_->count_frames = line;
    ArvFakeCamera* fake = arv_fake_device_get_fake_camera(ARV_FAKE_DEVICE(arv_camera_get_device(camera)));
    impl_->fake_period_us_ = line ? guint32(1e6 / settings.fake_line_hz) : kFakeFramePeriodUs;
    arv_fake_camera_write_register(fake, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, impl_->fake_period_us_);
  } else {
    arv_camera_set_trigger(camera, settings.trigger == TriggerSource::kLine0 ? "Line0" : "Software", &error);
    Check(error, fmt::format("camera {}: cannot set the trigger", name));
  }
  const guint payload = arv_camera_get_payload(camera, &error);
  Check(error, fmt::format("camera {}: cannot read the payload size", name));
  state->stream = arv_camera_create_stream(camera, nullptr, nullptr, &error);
  Check(error, fmt::format("camera {}: cannot open a stream", name));
  for (int i = 0; i < settings.buffers; ++i) {
    ArvBuffer* buffer = arv_buffer_new_allocate(payload);
    if (IsFake()) state->spare.push_back(buffer);  // until a trigger, or QueueFakeLine()
    else arv_stream_push_buffer(state->stream, buffer);
  }
  arv_camera_start_acquisition(camera, &error);
  Check(error, fmt::format("camera {}: cannot start acquisition", name));
  impl_->stream_ = std::move(state);
}

// Aravis 0.8 writes a value outside the feature's bounds as it is (the fake camera took
// a gain of 40 on its 0-10 GainRaw): the bounds are checked here.
void AravisCamera::SetExposureAndGain(std::optional<double> exposure_us, std::optional<double> gain_db) {
  using Bounds = void (*)(ArvCamera*, double*, double*, GError**);
  using Setter = void (*)(ArvCamera*, double, GError**);
  const auto set = [&](double value, Bounds bounds, Setter setter, const char* what, const char* unit) {
    const std::string context = fmt::format("camera {}: cannot set the {} to {} {}", impl_->name_, what, value, unit);
    GError* error = nullptr;
    double lo = 0, hi = 0;
    bounds(impl_->camera_, &lo, &hi, &error);
    Check(error, context);
    if (value < lo || value > hi) ThrowInputError("{}: the camera takes {} to {} {}", context, lo, hi, unit);
    setter(impl_->camera_, value, &error);
    Check(error, context);
  };
  if (exposure_us)
    set(*exposure_us, arv_camera_get_exposure_time_bounds, arv_camera_set_exposure_time, "exposure time", "us");
  if (gain_db) set(*gain_db, arv_camera_get_gain_bounds, arv_camera_set_gain, "gain", "dB");
}

double AravisCamera::ExposureUs() const {
  GError* error = nullptr;
  const double value = arv_camera_get_exposure_time(impl_->camera_, &error);
  Check(error, fmt::format("camera {}: cannot read the exposure time", impl_->name_));
  return value;
}

double AravisCamera::GainDb() const {
  GError* error = nullptr;
  const double value = arv_camera_get_gain(impl_->camera_, &error);
  Check(error, fmt::format("camera {}: cannot read the gain", impl_->name_));
  return value;
}

void AravisCamera::Stop() {
  impl_->StopAcquisition();
  impl_->stream_.reset();  // the frames still held keep the stream until released
}

bool AravisCamera::ControlLost() const { return impl_->control_lost_; }

void AravisCamera::Trigger(uint64_t tag, const FakeTriggerFault& fault) {
  FLATSCAN_CHECK(impl_->stream_);
  if (fault.lose && IsFake())  // as Aravis does for a camera that stops answering
    g_signal_emit_by_name(arv_camera_get_device(impl_->camera_), "control-lost");
  if (ControlLost()) ThrowInputError("camera {}: lost (it stopped answering on its control channel)", impl_->name_);
  StreamState& state = *impl_->stream_;
  if (!state.per_trigger) {
    if (IsFake()) return;  // a fake on its "line": it triggers itself
    GError* error = nullptr;
    arv_camera_software_trigger(impl_->camera_, &error);
    Check(error, fmt::format("camera {}: software trigger refused", impl_->name_));
    return;
  }
  if (fault.drop) return;
  if (fault.delay.count() > 0) std::this_thread::sleep_for(fault.delay);
  ArvBuffer* buffer = nullptr;
  {
    std::lock_guard lock(state.mutex);
    if (fault.incomplete) {
      buffer = arv_buffer_new_allocate(16);
      state.undersized.insert(buffer);
    } else if (!state.spare.empty()) {
      buffer = state.spare.back();
      state.spare.pop_back();
    }
  }
  if (!buffer) return;  // every buffer is held: the frame is lost, as on a camera that overruns
  {
    std::lock_guard lock(state.fake_context->mutex);
    state.fake_context->triggered[buffer] = {tag, HostClockNs()};  // after the delay: the camera's trigger
  }
  arv_stream_push_buffer(state.stream, buffer);
}

std::optional<CameraFrame> AravisCamera::NextFrame(std::chrono::microseconds wait) {
  const std::shared_ptr<StreamState> state = impl_->stream_;
  if (!state) return std::nullopt;  // stopped
  ArvBuffer* buffer = wait.count() > 0 ? arv_stream_timeout_pop_buffer(state->stream, guint64(wait.count()))
                                       : arv_stream_try_pop_buffer(state->stream);
  if (!buffer) return std::nullopt;
  CameraFrame frame;
  frame.memory = std::shared_ptr<const void>(buffer, [state](const void* b) {
    state->Return(static_cast<ArvBuffer*>(const_cast<void*>(b)));
  });
  frame.timestamp_ns = int64_t(arv_buffer_get_system_timestamp(buffer));
  // A buffer the camera could not fill (a fake's too-small buffer) has no timestamp:
  // it arrived now.
  if (frame.timestamp_ns == 0) frame.timestamp_ns = HostClockNs();
  frame.camera_timestamp_ns = int64_t(arv_buffer_get_timestamp(buffer));
  frame.frame_id = arv_buffer_get_frame_id(buffer);
  frame.problem = BufferProblem(arv_buffer_get_status(buffer));
  if (!frame.problem.empty()) return frame;
  const int width = arv_buffer_get_image_width(buffer), height = arv_buffer_get_image_height(buffer);
  const ArvPixelFormat format = arv_buffer_get_image_pixel_format(buffer);
  size_t size = 0;
  const void* data = arv_buffer_get_data(buffer, &size);
  const int bits = format == ARV_PIXEL_FORMAT_MONO_8    ? 8
                   : format == ARV_PIXEL_FORMAT_MONO_10 ? 10
                   : format == ARV_PIXEL_FORMAT_MONO_12 ? 12
                   : format == ARV_PIXEL_FORMAT_MONO_16 ? 16
                                                        : 0;
  const size_t bytes = size_t(width) * size_t(height) * (bits > 8 ? 2 : 1);
  // The fake camera reports size 0 for a frame its callback filled (docs/cameras.md).
  if (bits == 0 || width <= 0 || height <= 0 || (size != 0 && size < bytes)) {
    frame.problem = fmt::format("unexpected frame: {} x {}, pixel format 0x{:08x}, {} bytes (expected Mono8, Mono10, "
                                "Mono12 or Mono16)",
                                width, height, uint32_t(format), size);
    return frame;
  }
  if (bits > 8) {  // the reduction of PixelFormat's comment, into an image of its own
    frame.image = ReduceToMono8(static_cast<const uint16_t*>(data), width, height, size_t(width), bits);
    return frame;
  }
  // cv::Mat over the buffer: the boundary detector reads the camera's memory.
  frame.image = cv::Mat1b(height, width, static_cast<uint8_t*>(const_cast<void*>(data)));
  return frame;
}

void AravisCamera::QueueFakeLine() {
  FLATSCAN_CHECK(impl_->stream_ && IsFake() && !impl_->stream_->per_trigger);
  StreamState& state = *impl_->stream_;
  {
    // The line's first pulse: the fake's next tick (its ticks are multiples of its period).
    const int64_t period_ns = int64_t(impl_->fake_period_us_) * 1000;
    std::lock_guard lock(impl_->fake_->mutex);
    impl_->fake_->period_ns = period_ns;
    impl_->fake_->first_pulse_ns = (HostClockNs() / period_ns + 1) * period_ns;
  }
  std::lock_guard lock(state.mutex);
  for (ArvBuffer* buffer : state.spare) arv_stream_push_buffer(state.stream, buffer);
  state.spare.clear();
}

void AravisCamera::AwayFromFakeTick(std::chrono::microseconds margin) const {
  if (!IsFake()) return;
  const guint64 period = impl_->fake_period_us_;
  const guint64 phase = guint64(g_get_real_time()) % period;  // the fake's ticks: multiples of the period
  const guint64 m = guint64(margin.count());
  if (phase >= m && phase + m <= period) return;
  const guint64 until = phase < m ? m - phase : period - phase + m;
  std::this_thread::sleep_for(std::chrono::microseconds(until));
}

}  // namespace flatscan
