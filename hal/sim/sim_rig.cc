#include "hal/sim/sim_rig.h"

namespace loom::hal {

Result<SimRig> MakeSimRig(const RigFile& file, const RigModel& model, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(sim::RigScene rig, sim::MakeRigScene(file, model, object));
  return SimRig{std::make_shared<SimWorld>(std::move(rig.scene), static_cast<uint64_t>(file.Seed())), rig.sample};
}

Status PlaceObject(const SimRig& rig, scan::ScanObject object) {
  if (rig.world->object() == object) return Status::Ok();  // e.g. a scan's first step: the sample is there
  sim::SampleSpec spec = rig.sample;
  switch (object) {
    case scan::ScanObject::kSample:
      break;
    case scan::ScanObject::kTarget:
      spec.kind = "target";
      break;
    case scan::ScanObject::kWhiteTile:
      spec.kind = "white-tile";
      break;
    case scan::ScanObject::kWhiteTileOnSpacer:
      spec.kind = "white-tile-on-spacer";
      break;
    case scan::ScanObject::kColourChart:
      spec.kind = "colour-chart";
      break;
    case scan::ScanObject::kChromeSphere:
      spec.kind = "chrome-sphere";
      break;
    case scan::ScanObject::kNothing:
      return Status::Ok();  // what lies there may stay
  }
  LOOM_ASSIGN_OR_RETURN(sim::Material material, sim::MakeSample(spec));
  const std::shared_ptr<const sim::Scene> current = rig.world->scene();
  rig.world->set_scene(std::make_shared<sim::Scene>(current->rig(), std::move(material)), object);
  return Status::Ok();
}

}  // namespace loom::hal
