#include "apps/rig_loader.h"

#include "apps/backends.h"
#include "apps/config_paths.h"

namespace loom::apps {

Result<LoadedRig> LoadRig(const std::string& rig, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(ResolveRigPath(rig)));
  return acquisition::LoadRig(file, AllBackends(), object);
}

}  // namespace loom::apps
