#include "hal/aravis/internal/aravis_camera.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/log.h"
#include "hal/aravis/aravis_backend.h"

namespace loom::hal {
namespace {

Result<ArvPixelFormat> ToArv(scan::PixelFormat format) {
  switch (format) {
    case scan::PixelFormat::kMono8:
      return ARV_PIXEL_FORMAT_MONO_8;
    case scan::PixelFormat::kMono12:
      return ARV_PIXEL_FORMAT_MONO_12;
    case scan::PixelFormat::kMono16:
      return ARV_PIXEL_FORMAT_MONO_16;
  }
  return InternalError("pixel format", "unknown");
}

std::optional<scan::PixelFormat> FromArv(ArvPixelFormat format) {
  switch (format) {
    case ARV_PIXEL_FORMAT_MONO_8:
      return scan::PixelFormat::kMono8;
    case ARV_PIXEL_FORMAT_MONO_12:
      return scan::PixelFormat::kMono12;
    case ARV_PIXEL_FORMAT_MONO_16:
      return scan::PixelFormat::kMono16;
    default:
      return std::nullopt;
  }
}

std::string_view BufferStatusName(ArvBufferStatus status) {
  switch (status) {
    case ARV_BUFFER_STATUS_SUCCESS:
      return "success";
    case ARV_BUFFER_STATUS_CLEARED:
      return "cleared";
    case ARV_BUFFER_STATUS_TIMEOUT:
      return "timeout";
    case ARV_BUFFER_STATUS_MISSING_PACKETS:
      return "missing packets";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID:
      return "wrong packet id";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH:
      return "size mismatch";
    case ARV_BUFFER_STATUS_FILLING:
      return "filling";
    case ARV_BUFFER_STATUS_ABORTED:
      return "aborted";
    default:
      return "unknown";
  }
}

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

AravisCamera::AravisCamera(std::string name, AravisCameraOptions options)
    : Camera(std::move(name), "aravis", options.address), options_(std::move(options)) {}

AravisCamera::~AravisCamera() {
  StopStream();
  g_clear_object(&camera_);
}

Status AravisCamera::FromGError(GError* error, const std::string& what, StatusCode code) const {
  if (error == nullptr) return Status::Ok();
  const std::string message = what + ": " + error->message;
  g_error_free(error);
  return Error(code, message);
}

Status AravisCamera::Connect() {
  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(options_.address.c_str(), &error);
  if (camera == nullptr) return FromGError(error, "cannot open camera");
  g_clear_object(&camera_);
  camera_ = camera;
  return Status::Ok();
}

Result<DeviceIdentity> AravisCamera::DoOpen() {
  LOOM_RETURN_IF_ERROR(Connect());
  GError* error = nullptr;
  DeviceIdentity identity;
  const auto text = [&](const char* value) { return std::string(value ? value : ""); };
  identity.vendor = text(arv_camera_get_vendor_name(camera_, nullptr));
  identity.model = text(arv_camera_get_model_name(camera_, nullptr));
  identity.serial = text(arv_camera_get_device_serial_number(camera_, nullptr));
  if (identity.serial.empty()) identity.serial = text(arv_camera_get_device_id(camera_, nullptr));

  CameraCapabilities caps;
  arv_camera_get_sensor_size(camera_, &caps.sensor_width, &caps.sensor_height, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading the sensor size"));
  guint n_formats = 0;
  gint64* formats = arv_camera_dup_available_pixel_formats(camera_, &n_formats, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading the pixel formats"));
  for (guint i = 0; i < n_formats; ++i) {
    if (std::optional<scan::PixelFormat> format = FromArv(static_cast<ArvPixelFormat>(formats[i]))) {
      caps.pixel_formats.push_back(*format);
    }
  }
  g_free(formats);
  arv_camera_get_exposure_time_bounds(camera_, &caps.exposure_min_us, &caps.exposure_max_us, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading the exposure range"));
  arv_camera_get_gain_bounds(camera_, &caps.gain_min, &caps.gain_max, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading the gain range"));
  set_capabilities(std::move(caps));
  return identity;
}

Status AravisCamera::ApplyStreamSettings(CameraSettings* applied) {
  GError* error = nullptr;
  if (applied->packet_size_bytes == 0) {
    const guint negotiated = arv_camera_gv_auto_packet_size(camera_, &error);
    LOOM_RETURN_IF_ERROR(FromGError(error, "negotiating the packet size"));
    LOOM_LOG(Info) << description() << ": packet size " << negotiated << " bytes (negotiated)";
  } else {
    gint64 min = 0, max = 0;
    arv_camera_get_integer_bounds(camera_, "GevSCPSPacketSize", &min, &max, &error);
    LOOM_RETURN_IF_ERROR(FromGError(error, "reading the packet size's bounds"));
    arv_camera_gv_set_packet_size(camera_, static_cast<gint>(std::clamp<gint64>(applied->packet_size_bytes, min, max)), &error);
    LOOM_RETURN_IF_ERROR(FromGError(error, "setting the packet size"));
    applied->packet_size_bytes = static_cast<int>(arv_camera_gv_get_packet_size(camera_, &error));
    LOOM_RETURN_IF_ERROR(FromGError(error, "reading back the packet size"));
  }
  // A camera without GevSCPD can only send back to back: fine unless a delay was asked for.
  const bool has_delay = arv_camera_is_feature_available(camera_, "GevSCPD", &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "looking for GevSCPD"));
  if (!has_delay) {
    if (applied->packet_delay_ns == 0) return Status::Ok();
    return Error(StatusCode::kInvalidArgument, "has no inter-packet delay (GevSCPD): set packet_delay_ns to 0");
  }
  arv_camera_gv_set_packet_delay(camera_, applied->packet_delay_ns, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "setting the inter-packet delay (GevSCPD)"));
  applied->packet_delay_ns = static_cast<int>(arv_camera_gv_get_packet_delay(camera_, &error));
  return FromGError(error, "reading back the inter-packet delay");
}

Status AravisCamera::ApplySettings(CameraSettings* applied) {
  GError* error = nullptr;
  LOOM_ASSIGN_OR_RETURN(const ArvPixelFormat format, ToArv(applied->pixel_format));
  arv_camera_set_pixel_format(camera_, format, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "setting the pixel format"));
  const scan::Roi& roi = applied->roi;
  arv_camera_set_region(camera_, roi.x, roi.y, roi.width, roi.height, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "setting the region of interest"));
  arv_camera_set_exposure_time(camera_, applied->exposure_us, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "setting the exposure"));
  arv_camera_set_gain(camera_, applied->gain, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "setting the gain"));
  arv_camera_set_acquisition_mode(camera_, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "setting continuous acquisition"));
  switch (applied->trigger) {
    case TriggerMode::kFreeRun:
      arv_camera_clear_triggers(camera_, &error);
      break;
    case TriggerMode::kSoftware:
      arv_camera_set_trigger(camera_, "Software", &error);
      break;
    case TriggerMode::kHardware:
      arv_camera_set_trigger(camera_, "Line0", &error);
      break;
  }
  LOOM_RETURN_IF_ERROR(FromGError(error, "setting the trigger"));
  if (arv_camera_is_gv_device(camera_)) LOOM_RETURN_IF_ERROR(ApplyStreamSettings(applied));
  // Record what the camera really applied (exposure and gain come in steps).
  applied->exposure_us = arv_camera_get_exposure_time(camera_, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading back the exposure"));
  applied->gain = arv_camera_get_gain(camera_, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading back the gain"));
  scan::Roi actual;
  arv_camera_get_region(camera_, &actual.x, &actual.y, &actual.width, &actual.height, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading back the region"));
  applied->roi = actual;
  return Status::Ok();
}

Status AravisCamera::DoConfigure(CameraSettings* applied) { return ApplySettings(applied); }

Status AravisCamera::StartStream() {
  GError* error = nullptr;
  stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &error);
  if (stream_ == nullptr) return FromGError(error, "cannot create the stream");
  const guint payload = arv_camera_get_payload(camera_, &error);
  LOOM_RETURN_IF_ERROR(FromGError(error, "reading the payload size"));
  for (int i = 0; i < settings().buffer_count; ++i) {
    arv_stream_push_buffer(stream_, arv_buffer_new_allocate(payload));
  }
  arv_camera_start_acquisition(camera_, &error);
  return FromGError(error, "cannot start acquisition");
}

void AravisCamera::StopStream() {
  if (camera_ != nullptr && stream_ != nullptr) arv_camera_stop_acquisition(camera_, nullptr);
  g_clear_object(&stream_);
}

Status AravisCamera::DoStart() {
  const Status started = StartStream();
  if (!started.ok()) StopStream();
  return started;
}

Status AravisCamera::DoStop() {
  GError* error = nullptr;
  if (stream_ != nullptr) arv_camera_stop_acquisition(camera_, &error);
  g_clear_object(&stream_);
  return FromGError(error, "stopping acquisition");
}

Status AravisCamera::DoClose() {
  StopStream();
  g_clear_object(&camera_);
  return Status::Ok();
}

Status AravisCamera::DoMakeSafe() {
  StopStream();
  return Status::Ok();
}

AravisCamera::StreamStatistics AravisCamera::stream_statistics() const {
  StreamStatistics statistics;
  if (stream_ == nullptr) return statistics;
  guint64 completed = 0, failures = 0, underruns = 0;
  arv_stream_get_statistics(stream_, &completed, &failures, &underruns);
  statistics.completed = completed;
  statistics.failures = failures;
  statistics.underruns = underruns;
  return statistics;
}

Status AravisCamera::DoTriggerSoftware() {
  GError* error = nullptr;
  arv_camera_software_trigger(camera_, &error);
  return FromGError(error, "software trigger");
}

bool AravisCamera::Answers() {
  GError* error = nullptr;
  arv_camera_get_exposure_time(camera_, &error);
  if (error == nullptr) return true;
  g_error_free(error);
  return false;
}

bool AravisCamera::KeepsSettings() {
  GError* error = nullptr;
  const double exposure_us = arv_camera_get_exposure_time(camera_, &error);
  scan::Roi roi;
  if (error == nullptr) arv_camera_get_region(camera_, &roi.x, &roi.y, &roi.width, &roi.height, &error);
  const ArvPixelFormat format = error == nullptr ? arv_camera_get_pixel_format(camera_, &error) : 0;
  if (error != nullptr) {
    g_error_free(error);
    return false;
  }
  return std::abs(exposure_us - settings().exposure_us) <= 1e-6 * std::max(1.0, exposure_us) && roi == settings().roi &&
         FromArv(format) == settings().pixel_format;
}

Status AravisCamera::Reconnect() {
  StopStream();
  Status last;
  for (int attempt = 1; attempt <= options_.reconnect_attempts; ++attempt) {
    last = Connect();
    if (last.ok()) {
      CameraSettings applied = settings();
      last = ApplySettings(&applied);
      if (last.ok()) last = StartStream();
      if (last.ok()) return last;
    }
    LOOM_LOG(Warning) << "reconnect attempt " << attempt << " of " << options_.reconnect_attempts
                      << " failed: " << last.ToString();
  }
  return last;
}

Result<scan::RawFrame> AravisCamera::ToRawFrame(ArvBuffer* buffer) const {
  const std::optional<scan::PixelFormat> format = FromArv(arv_buffer_get_image_pixel_format(buffer));
  if (!format) {
    return Error(StatusCode::kDataLoss,
                 "frame in an unsupported pixel format 0x" + std::to_string(arv_buffer_get_image_pixel_format(buffer)));
  }
  scan::RawFrame frame;
  frame.width = arv_buffer_get_image_width(buffer);
  frame.height = arv_buffer_get_image_height(buffer);
  const size_t pixels = static_cast<size_t>(frame.width) * frame.height;
  const size_t bytes_per_pixel = *format == scan::PixelFormat::kMono8 ? 1 : 2;
  size_t size = 0;
  const void* data = arv_buffer_get_data(buffer, &size);
  // Aravis 0.8's fake camera with a custom fill pattern reports size 0: trust the geometry.
  if (size == 0) size = pixels * bytes_per_pixel;
  if (data == nullptr || size < pixels * bytes_per_pixel) {
    return Error(StatusCode::kDataLoss, "frame of " + std::to_string(size) + " bytes is too small for " +
                                            std::to_string(frame.width) + "x" + std::to_string(frame.height));
  }
  frame.pixels.resize(pixels);
  if (bytes_per_pixel == 1) {
    const uint8_t* bytes = static_cast<const uint8_t*>(data);
    std::copy(bytes, bytes + pixels, frame.pixels.begin());
  } else {
    std::memcpy(frame.pixels.data(), data, pixels * 2);  // GigE Vision Mono16 is little-endian
  }
  scan::FrameMetadata& meta = frame.metadata;
  meta.camera = name();
  meta.camera_serial = identity().serial;
  meta.pixel_format = *format;
  meta.roi = settings().roi;
  meta.exposure_us = settings().exposure_us;
  meta.gain = settings().gain;
  meta.frame_id = arv_buffer_get_frame_id(buffer);
  meta.device_timestamp_ns = arv_buffer_get_timestamp(buffer);
  meta.host_timestamp_ns = NowNs();
  return frame;
}

ArvBuffer* AravisCamera::PopFrameBuffer(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return nullptr;
    ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream_, static_cast<guint64>(left.count()));
    // A cleared buffer never received a frame (e.g. one Aravis recycled at acquisition start):
    // it is not a frame, complete or not. Give it back and keep waiting.
    if (buffer == nullptr || arv_buffer_get_status(buffer) != ARV_BUFFER_STATUS_CLEARED) return buffer;
    arv_stream_push_buffer(stream_, buffer);
  }
}

Result<scan::RawFrame> AravisCamera::DoWaitFrame(std::chrono::milliseconds timeout) {
  ArvBuffer* buffer = PopFrameBuffer(timeout);
  if (buffer == nullptr) {
    // No frame: an untriggered hardware trigger, or a camera that dropped out or restarted
    // (a restarted camera answers again but has lost its settings and its stream).
    const bool answers = Answers();
    if (answers && KeepsSettings()) {
      return Error(StatusCode::kTimeout, "no frame within " + std::to_string(timeout.count()) + " ms");
    }
    const std::string what =
        answers ? "camera restarted mid-acquisition (it lost its settings)" : "camera dropped out mid-acquisition";
    const Status reconnected = Reconnect();
    if (!reconnected.ok()) {
      return Error(StatusCode::kUnavailable, what + " and could not be reconnected (" + reconnected.message() + ")");
    }
    return Error(StatusCode::kUnavailable,
                 what + "; reconnected and acquiring again, but this frame is lost: repeat the capture");
  }
  const ArvBufferStatus status = arv_buffer_get_status(buffer);
  Result<scan::RawFrame> frame =
      status == ARV_BUFFER_STATUS_SUCCESS
          ? ToRawFrame(buffer)
          : Result<scan::RawFrame>(
                Error(StatusCode::kDataLoss, "frame arrived incomplete (" + std::string(BufferStatusName(status)) + ")"));
  arv_stream_push_buffer(stream_, buffer);
  return frame;
}

Status AravisCamera::DoDiscardFrames() {
  while (ArvBuffer* buffer = arv_stream_try_pop_buffer(stream_)) arv_stream_push_buffer(stream_, buffer);
  return Status::Ok();
}

std::vector<DiscoveredCamera> DiscoverAravisCameras() {
  arv_update_device_list();
  std::vector<DiscoveredCamera> cameras;
  const auto text = [](const char* value) { return std::string(value ? value : ""); };
  for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
    cameras.push_back({text(arv_get_device_id(i)), text(arv_get_device_vendor(i)), text(arv_get_device_model(i)),
                       text(arv_get_device_serial_nbr(i)), text(arv_get_device_address(i)), text(arv_get_device_protocol(i))});
  }
  return cameras;
}

void ListDiscoveredCameras(const std::vector<DiscoveredCamera>& cameras, std::ostream& out) {
  for (const DiscoveredCamera& c : cameras) {
    out << "  " << c.id << "  " << c.protocol << "  " << c.address << "  " << c.vendor << " " << c.model << " serial " << c.serial
        << "\n";
  }
}

Status AravisCameraOptions::Check() const {
  std::vector<std::string> problems;
  if (address.empty()) problems.push_back("address must not be empty");
  if (reconnect_attempts < 0 || reconnect_attempts > 100) problems.push_back("reconnect_attempts must be in [0, 100]");
  return ProblemsStatus("AravisCameraOptions", problems);
}

void RegisterAravisBackend(BackendRegistry& registry) {
  registry.Register<Camera>("aravis", [](const DeviceConfig& config) -> Result<std::unique_ptr<Camera>> {
    AravisCameraOptions options;
    config.node.Required("address", &options.address);
    config.node.Optional("reconnect_attempts", &options.reconnect_attempts);
    if (const Status checked = options.Check(); !checked.ok()) {
      return InvalidArgumentError("camera '" + config.name + "'", checked.message());
    }
    return std::unique_ptr<Camera>(std::make_unique<AravisCamera>(config.name, options));
  });
}

}  // namespace loom::hal
