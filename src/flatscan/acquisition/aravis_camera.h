#pragma once
// GenICam cameras through Aravis 0.8 (Debian libaravis-dev): the open library for GigE
// Vision and USB3 Vision cameras on Linux. Listing the cameras and a test grab
// (`flatscan cameras`), and triggered acquisition for the station's camera source
// (acquisition/camera_pair_source.h; docs/cameras.md).
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
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace flatscan {

// One GenICam device as discovery finds it.
struct CameraInfo {
  std::string id;        // Aravis's device id: what --source cameras:ID,ID and --test take
  std::string vendor, model, serial;
  std::string protocol;  // "GigEVision", "USB3Vision", "Fake"
  std::string address;   // IP address (GigE) or bus address (USB3)
};

// The Aravis interfaces discovery searches. GigE Vision discovery broadcasts on every
// network interface of the machine and waits about 1 s for answers; the tests search the
// fake interface only (Aravis's in-process fake camera, id "Fake_1"), so that they send
// nothing on a network.
struct CameraInterfaces {
  bool gige = true, usb3 = true, fake = false;
  static CameraInterfaces FakeOnly() { return {false, false, true}; }
};
// "gige,usb3,fake" or any subset; throws InputError "<option> '<list>': expected ...".
CameraInterfaces ParseCameraInterfaces(const std::string& list, const std::string& option);

// The devices found now on `interfaces`.
std::vector<CameraInfo> ListCameras(const CameraInterfaces& interfaces);
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

// Fills a Mono8 frame of the fake camera: `pixels` has width * height bytes; `tag` is the
// value given to the Trigger() that queued the buffer (0 in a test grab).
using FakeFill = std::function<void(int width, int height, uint8_t* pixels, uint64_t tag)>;

// One frame as the camera delivered it. `image` points into the camera's buffer (no
// copy); the buffer goes back to the camera once the last copy of `memory` is gone.
// The host clock (UTC) in ns: the clock of CameraFrame::timestamp_ns and of a source's
// trigger times (not g_get_real_time's microseconds: a frame stamped in its trigger's own
// microsecond would look older than the trigger).
int64_t HostClockNs();

struct CameraFrame {
  cv::Mat1b image;                     // empty when the frame is not complete
  std::shared_ptr<const void> memory;  // holds the buffer
  // Host clock (UTC, ns) when the frame arrived (Aravis's system timestamp): the two
  // cameras' device clocks are not synchronised, the host's is one clock for both.
  int64_t timestamp_ns = 0;
  // The camera's own clock (ns) at exposure (GenICam timestamp; 0 when it gives none):
  // comparable between the two cameras only when PTP (IEEE 1588) synchronises them.
  int64_t camera_timestamp_ns = 0;
  uint64_t frame_id = 0;
  std::string problem;  // empty for a complete frame, else why not ("missing packets", ...)
};

// The cameras' pixel format (GenICam PixelFormat). The boundary detector reads 8-bit
// grey levels. A Mono10, Mono12 or Mono16 frame (unpacked: one little-endian 16-bit word
// per pixel, the value in its low 10, 12 or 16 bits) is reduced to 8 bits by keeping its
// 8 most significant bits, v >> (bits - 8): what a camera does itself to give Mono8 from
// its 10 or 12 bit converter. The map is linear, so an edge's grey-level profile keeps its
// shape and the sub-pixel boundary does not move (a gamma or a window would bend the
// profile toward one side of the edge); full scale stays full scale, and one 8-bit level
// is 4 (Mono10), 16 (Mono12) or 256 (Mono16) raw levels. It costs one pass into a new
// image: the one copy Mono8 does not need. Packed formats (Mono10p, Mono12Packed) are
// not read.
enum class PixelFormat { kMono8, kMono10, kMono12, kMono16 };
// "Mono8", "Mono10", "Mono12", "Mono16" (the GenICam names); throws InputError
// "<option> '<name>': expected ..." for any other.
PixelFormat ParsePixelFormat(const std::string& name, const std::string& option);
std::string PixelFormatName(PixelFormat format);
int PixelFormatBits(PixelFormat format);  // 8, 10, 12, 16
// The rule above on a width x height frame of 16-bit words (row after row, `stride_words`
// words apart) holding `bits`-bit values; a value above full scale (a camera that fills
// unused bits) gives 255.
cv::Mat1b ReduceToMono8(const uint16_t* pixels, int width, int height, size_t stride_words, int bits);

// Where a frame's exposure starts (GenICam TriggerSelector FrameStart).
enum class TriggerSource { kSoftware, kLine0 };

struct AcquisitionSettings {
  TriggerSource trigger = TriggerSource::kSoftware;
  // A fake camera offers Mono8 and Mono16 (Aravis 0.8.26): in Mono16 it shows each 8-bit
  // grey level v of its fill as v * 257 (full scale to full scale).
  PixelFormat pixel_format = PixelFormat::kMono8;
  // The recipe's (station/recipe.h `camera:`); nullopt: leave the camera's own setting.
  std::optional<double> exposure_us, gain_db;
  int buffers = 8;         // frames the camera can hold before the station takes them
  // A fake camera has no input line: with kLine0 it runs free at this rate, every frame
  // a "pulse" (both fakes tick together), its n-th frame filled with tag n.
  double fake_line_hz = 10;
};

// Faults a fake camera's trigger can be told to make (tests, `aravis-fake:`); a real
// camera ignores them.
struct FakeTriggerFault {
  bool drop = false;               // no frame for this trigger (a lost frame)
  std::chrono::milliseconds delay{0};  // the frame is exposed this much later (Trigger blocks as long)
  bool incomplete = false;         // the buffer is too small: Aravis reports it incomplete
  // The camera disappears at this trigger: Aravis's control-lost signal, as for a camera
  // unplugged or off the network; it takes no trigger from then on (the source reopens it).
  bool lose = false;
};

class AravisCamera {
 public:
  // The camera whose id or serial number is `name` (discovery first, on `interfaces`),
  // or, with gige among them, the GigE Vision camera at IPv4 address `name` (no
  // discovery: nothing is sent but to that address). Throws InputError naming it and how
  // many cameras were found when there is none such, or when it cannot be opened.
  static std::unique_ptr<AravisCamera> Open(const std::string& name, const CameraInterfaces& interfaces);
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

  // Triggered acquisition (settings.pixel_format; frames reduced to 8 bits as stated at
  // PixelFormat): sets pixel format, exposure, gain and trigger and
  // queues the buffers. Throws InputError naming the camera and the setting it refused.
  // A fake camera ignores triggers (Aravis 0.8.26): it fills a buffer at every tick of
  // its frame period (set to 4 ms here), so it is given one buffer per Trigger().
  void Start(const AcquisitionSettings& settings);
  void Stop();  // idempotent; frames still held stay valid
  // GenICam ExposureTime (us) and Gain (dB on an SFNC camera; the fake's GainRaw is a
  // plain number), each when given; while acquiring too (the next frames have them).
  // Throws InputError naming the camera, the value and the camera's reason.
  void SetExposureAndGain(std::optional<double> exposure_us, std::optional<double> gain_db);
  double ExposureUs() const;  // as the camera reports them
  double GainDb() const;
  // A software trigger now (any thread); `tag` reaches a fake camera's fill. Throws
  // InputError when the camera refuses it, or is lost (ControlLost).
  void Trigger(uint64_t tag = 0, const FakeTriggerFault& fault = {});
  // The next frame, waiting at most `wait`; nullopt when none came, or when stopped.
  // Not concurrently with Start or Stop.
  std::optional<CameraFrame> NextFrame(std::chrono::microseconds wait);
  bool IsFake() const;
  // The camera stopped answering (Aravis's control-lost signal: a GigE camera's heartbeat
  // unanswered, a USB3 camera unplugged). It stays lost: the camera must be opened again.
  bool ControlLost() const;
  // A fake camera started with kLine0 holds its buffers until this queues them all (the
  // source queues both fakes' between two ticks, so that their n-th frames match).
  void QueueFakeLine();
  // A fake camera's frames come at multiples of its frame period (host clock): waits
  // until the next tick is at least `margin` away, so that two fake lines queued now
  // take the same tick as their first pulse. Returns at once for a real camera.
  void AwayFromFakeTick(std::chrono::microseconds margin) const;

 private:
  class Impl;
  static std::unique_ptr<AravisCamera> OpenGigEByAddress(const std::string& address);
  explicit AravisCamera(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The share statistics of one Mono8 frame added to `stats` (weighted by pixel count).
void AddGreyStatistics(const uint8_t* pixels, size_t count, GrabStatistics& stats, size_t& pixels_so_far);

}  // namespace flatscan
