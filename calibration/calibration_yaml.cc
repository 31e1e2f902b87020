#include "calibration/calibration_yaml.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>

#include "calibration/internal/provenance.h"
#include "core/config.h"
#include "core/file_io.h"
#include "core/output_file.h"

namespace loom::calibration {
namespace {

constexpr int kCalibrationSchemaVersion = 1;
constexpr char kCameraModel[] = "pinhole + OpenCV 5-term distortion (k1 k2 p1 p2 k3); pixel centres at integers";

}  // namespace

Status WriteCameraCalibration(const std::filesystem::path& path, const CameraCalibration& calibration) {
  const Intrinsics& in = calibration.intrinsics;
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap;
  out << YAML::Key << "schema_version" << YAML::Value << kCalibrationSchemaVersion;
  out << YAML::Key << "device" << YAML::Value << "camera";
  out << YAML::Key << "name" << YAML::Value << calibration.name;
  out << YAML::Key << "model" << YAML::Value << kCameraModel;
  out << YAML::Key << "image_size_px" << YAML::Value << YAML::Flow << std::vector<int>{in.width, in.height};
  out << YAML::Key << "K_px" << YAML::Value;
  internal::EmitMatrix(out, in.K);
  out << YAML::Key << "distortion" << YAML::Value << YAML::Flow
      << std::vector<double>(in.distortion.data(), in.distortion.data() + 5);
  if (calibration.cam_from_rig) {
    out << YAML::Key << "cam_from_rig" << YAML::Value << YAML::BeginMap << YAML::Key << "rotation" << YAML::Value;
    internal::EmitMatrix(out, calibration.cam_from_rig->linear());
    const Eigen::Vector3d t = calibration.cam_from_rig->translation();
    out << YAML::Key << "translation_mm" << YAML::Value << YAML::Flow << std::vector<double>{t.x(), t.y(), t.z()};
    out << YAML::EndMap;
  }
  out << YAML::Key << "quality" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "rms_px" << YAML::Value << in.rms_px;
  out << YAML::Key << "views" << YAML::Value << YAML::BeginSeq;
  for (size_t i = 0; i < in.per_view_rms_px.size(); ++i) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "source" << YAML::Value
        << (i < calibration.view_sources.size() ? calibration.view_sources[i] : "") << YAML::Key << "rms_px" << YAML::Value
        << in.per_view_rms_px[i] << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "skipped" << YAML::Value << YAML::Flow << calibration.skipped;
  out << YAML::EndMap;
  out << YAML::Key << "source" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "from" << YAML::Value << calibration.from;
  out << YAML::Key << "board" << YAML::Value << calibration.board;
  internal::EmitVersionAndTime(out);
  out << YAML::EndMap << YAML::EndMap;
  return WriteFileAtomically(path, std::string(kLoomTextMarker) + "\n" + out.c_str() + "\n");
}

Result<CameraCalibration> ReadCameraCalibration(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kCalibrationSchemaVersion));
  const ConfigNode root = doc.root();
  CameraCalibration calibration;
  Intrinsics& in = calibration.intrinsics;
  std::string device, model;
  root.Required("device", &device);
  if (device != "camera") root.AddError("device", "is '" + device + "', expected camera");
  root.Required("name", &calibration.name);
  root.Required("model", &model);
  if (model != kCameraModel) root.AddError("model", "unknown camera model '" + model + "'");
  std::vector<int> size;
  root.Required("image_size_px", &size);
  if (size.size() == 2) {
    in.width = size[0];
    in.height = size[1];
  } else {
    root.AddError("image_size_px", "needs [width, height]");
  }
  root.Required("K_px", &in.K);
  std::vector<double> distortion;
  root.Required("distortion", &distortion);
  if (distortion.size() == 5) {
    for (int i = 0; i < 5; ++i) in.distortion[i] = distortion[i];
  } else {
    root.AddError("distortion", "needs 5 terms: k1 k2 p1 p2 k3");
  }
  if (std::optional<ConfigNode> pose = root.OptionalChild("cam_from_rig")) {
    Eigen::Matrix3d rotation;
    Eigen::Vector3d translation;
    pose->Required("rotation", &rotation);
    pose->Required("translation_mm", &translation);
    calibration.cam_from_rig = MakeRigid(rotation, translation);
  }
  const ConfigNode quality = root.Child("quality");
  quality.Required("rms_px", &in.rms_px);
  for (const ConfigNode& view : quality.Sequence("views")) {
    std::string source;
    double rms = 0;
    view.Required("source", &source);
    view.Required("rms_px", &rms);
    calibration.view_sources.push_back(source);
    in.per_view_rms_px.push_back(rms);
  }
  quality.Optional("skipped", &calibration.skipped);
  const ConfigNode source = root.Child("source");
  source.Required("from", &calibration.from);
  source.Required("board", &calibration.board);
  source.Ignore("loom_version");
  source.Ignore("created");
  LOOM_RETURN_IF_ERROR(doc.Finish());
  if (calibration.cam_from_rig && !IsRigid(*calibration.cam_from_rig, 1e-6)) {
    return InvalidArgumentError(path.string(), "cam_from_rig.rotation is not a rotation");
  }
  return calibration;
}

Result<std::vector<std::string>> ApplyCameraCalibrations(const std::filesystem::path& directory, RigModel* rig) {
  if (!std::filesystem::is_directory(directory)) return NotFoundError(directory.string(), "no such calibration directory");
  std::vector<std::string> applied, with_pose;
  for (CameraModel& camera : rig->cameras) {
    const std::filesystem::path path = directory / (camera.name + ".yaml");
    if (!std::filesystem::exists(path)) continue;
    LOOM_ASSIGN_OR_RETURN(const CameraCalibration calibration, ReadCameraCalibration(path));
    const Intrinsics& intrinsics = calibration.intrinsics;
    if (intrinsics.width != camera.width || intrinsics.height != camera.height) {
      return InvalidArgumentError(path.string(), "is for " + std::to_string(intrinsics.width) + "x" +
                                                     std::to_string(intrinsics.height) + " px images, camera '" + camera.name +
                                                     "' of rig '" + rig->name + "' has " + std::to_string(camera.width) + "x" +
                                                     std::to_string(camera.height));
    }
    camera.K = intrinsics.K;
    camera.distortion = intrinsics.distortion;
    if (calibration.cam_from_rig) {
      camera.cam_from_rig = *calibration.cam_from_rig;
      with_pose.push_back(camera.name);
    }
    applied.push_back(camera.name);
  }
  if (with_pose.empty()) return applied;
  // Calibrated poses are in the turntable's frame: every camera needs one, or they disagree.
  for (const CameraModel& camera : rig->cameras) {
    if (std::find(with_pose.begin(), with_pose.end(), camera.name) == with_pose.end()) {
      return FailedPreconditionError((directory / (camera.name + ".yaml")).string(),
                                     "has no cam_from_rig while " + with_pose.front() +
                                         ".yaml has: calibrate every camera's pose together (loom calibrate geometry)");
    }
  }
  rig->turntable = TurntableModel{};
  return applied;
}

}  // namespace loom::calibration
