#include "photos/capture_export.h"

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/file_io.h"
#include "core/srgb.h"

namespace loom::photos {
namespace {

namespace fs = std::filesystem;

// R, G, B channels of `image` as a BGR OpenCV matrix of `type` (CV_8UC3, CV_16UC3), each value
// encoded by `encode` from [0, 1] (clipped).
template <typename Encode>
cv::Mat Encoded(const Image& image, int type, double top, const Encode& encode) {
  cv::Mat out(image.height(), image.width(), type);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      for (int c = 0; c < 3; ++c) {
        const double v = std::clamp(encode(std::max(0.0f, image.at(c, y, x))), 0.0, 1.0);
        const double stored = std::round(v * top);
        if (type == CV_8UC3) {
          out.at<cv::Vec3b>(y, x)[2 - c] = static_cast<uint8_t>(stored);
        } else {
          out.at<cv::Vec3w>(y, x)[2 - c] = static_cast<uint16_t>(stored);
        }
      }
    }
  }
  return out;
}

Status WriteImage(const fs::path& path, const cv::Mat& image) {
  std::vector<uint8_t> bytes;
  const std::string extension = path.extension().string();
  if (!cv::imencode(extension, image, bytes, {cv::IMWRITE_JPEG_QUALITY, 95})) {
    return InternalError(path.string(), extension + " encoding failed");
  }
  return WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()));
}

std::string Numbered(int k, int digits, const std::string& extension = ".png") {
  std::ostringstream name;
  name << std::setw(digits) << std::setfill('0') << k << extension;
  return name.str();
}

Status WriteMask(const fs::path& path, const Image& mask_image) {
  cv::Mat mask(mask_image.height(), mask_image.width(), CV_8UC1);
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) mask.at<uint8_t>(y, x) = mask_image.at(0, y, x) != 0 ? 255 : 0;
  }
  return WriteImage(path, mask);
}

}  // namespace

Status WritePhotometricStereo(const fs::path& dir, const PhotometricStereoCapture& capture) {
  LOOM_RETURN_IF_ERROR(CreateDirectories(dir));
  std::ostringstream names, directions, intensities;
  directions << std::setprecision(9);
  for (size_t k = 0; k < capture.images.size(); ++k) {
    const std::string name = Numbered(static_cast<int>(k) + 1, 3);
    LOOM_RETURN_IF_ERROR(
        WriteImage(dir / name, Encoded(capture.images[k], CV_16UC3, 65535, [&](double v) { return v / capture.white; })));
    const Eigen::Vector3d& d = capture.light_directions[k];
    names << name << "\n";
    directions << d.x() << " " << d.y() << " " << d.z() << "\n";
    intensities << "1 1 1\n";
  }
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "filenames.txt", names.str()));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "light_directions.txt", directions.str()));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "light_intensities.txt", intensities.str()));
  if (capture.mask) LOOM_RETURN_IF_ERROR(WriteMask(dir / "mask.png", *capture.mask));
  return Status::Ok();
}

Status WriteLightPositions(const fs::path& dir, const PhotometricStereoCapture& capture) {
  LOOM_RETURN_IF_ERROR(CreateDirectories(dir));
  std::ostringstream lp;
  lp << capture.images.size() << "\n" << std::setprecision(9);
  for (size_t k = 0; k < capture.images.size(); ++k) {
    const std::string name = Numbered(static_cast<int>(k) + 1, 3, ".jpg");
    LOOM_RETURN_IF_ERROR(WriteImage(
        dir / name, Encoded(capture.images[k], CV_8UC3, 255, [&](double v) { return SrgbEncode(v / capture.white); })));
    const Eigen::Vector3d& d = capture.light_directions[k];
    lp << name << " " << d.x() << " " << d.y() << " " << d.z() << "\n";
  }
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "capture.lp", lp.str()));
  if (capture.mask) LOOM_RETURN_IF_ERROR(WriteMask(dir / "mask.png", *capture.mask));
  return Status::Ok();
}

Status WriteFlash(const fs::path& dir, const FlashCapture& capture) {
  LOOM_RETURN_IF_ERROR(CreateDirectories(dir));
  std::ostringstream cameras, lights;
  cameras << std::fixed << std::setprecision(4);
  lights << std::fixed << std::setprecision(4);
  for (size_t k = 0; k < capture.images.size(); ++k) {
    LOOM_RETURN_IF_ERROR(
        WriteImage(dir / Numbered(static_cast<int>(k), 2),
                   Encoded(capture.images[k], CV_8UC3, 255, [&](double v) { return std::pow(v / capture.white, 1 / 2.2); })));
    const Eigen::Vector3d& c = capture.cameras_cm[k];
    const Eigen::Vector3d& l = capture.lights_cm[k];
    cameras << c.x() << "," << c.y() << "," << c.z() << "\n";
    lights << l.x() << "," << l.y() << "," << l.z() << "\n";
  }
  std::ostringstream size, power;
  size << std::fixed << std::setprecision(4) << capture.width_cm << "\n";
  power << std::fixed << std::setprecision(4) << capture.power.x() << "," << capture.power.y() << "," << capture.power.z()
        << "\n";
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "camera_pos.txt", cameras.str()));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "light_pos.txt", lights.str()));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "image_size.txt", size.str()));
  return WriteFileAtomically(dir / "light_power.txt", power.str());
}

}  // namespace loom::photos
