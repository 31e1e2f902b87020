#include "sim/fast_path_stack.h"

#include <optional>
#include <ostream>
#include <vector>

#include "core/memory.h"
#include "core/observation_stack.h"
#include "sim/material.h"
#include "sim/plan_observations.h"
#include "sim/scan_emulation.h"
#include "sim/stack.h"

namespace loom::sim {

Status WriteFastPathStack(const Scene& scene, const scan::Preset& preset, const FastPathStackRequest& request,
                          std::ostream& report) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<Observation> observations, PresetObservations(scene.rig(), preset));
  std::optional<ScanEmulation> emulation;
  if (!request.scan_emulation.empty()) {
    LOOM_ASSIGN_OR_RETURN(emulation, LoadScanEmulation(request.scan_emulation));
  }
  const StackOptions options{.width_px = request.size_px, .height_px = request.size_px};
  const uint64_t side = request.size_px > 0 ? static_cast<uint64_t>(request.size_px) : 4096;  // the sample's side is at most that
  LOOM_RETURN_IF_ERROR(CheckFitsInMemory(
      side * side * (kStackGeometryChannels + observations.size()) * sizeof(float),
      "--size " + std::to_string(request.size_px) + " with " + std::to_string(observations.size()) + " observations"));
  ObservationStack stack = RenderStack(scene, observations, options);
  if (emulation) {
    const Status emulated = EmulateScan(*emulation, request.seed, stack);
    if (!emulated.ok()) return emulated.WithContext("--scan-emulation " + request.scan_emulation.string());
    report << "degraded as a scan: " << request.scan_emulation.string() << " (seed " << request.seed << ")\n";
  }
  LOOM_RETURN_IF_ERROR(WriteObservationStack(request.out, stack));
  if (!request.truth.empty()) {
    LOOM_RETURN_IF_ERROR(WriteMaterial(TruthOnStackGrid(scene, options), request.truth));
    report << "wrote " << request.truth.string() << ": the ground-truth maps on the stack's grid\n";
  }
  report << "wrote " << request.out.string() << ": " << stack.image.width() << "x" << stack.image.height() << " px, "
         << observations.size() << " observations (preset " << preset.name << ")\n";
  return Status::Ok();
}

}  // namespace loom::sim
