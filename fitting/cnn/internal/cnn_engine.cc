#include "fitting/cnn/internal/cnn_engine.h"

#include <dlfcn.h>

#include <string>

namespace loom::fitting::internal {

Result<const CnnEngine*> LoadCnnEngine(const std::filesystem::path& module) {
  // RTLD_LOCAL: the module's symbols (and LibTorch's) stay out of the process's global scope.
  void* handle = dlopen(module.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    return UnavailableError(module.string(), std::string("cannot load the CNN's LibTorch module (built with loom as target "
                                                         "loom_cnn_torch): ") +
                                                 dlerror());
  }
  const auto entry = reinterpret_cast<CnnEngineEntry>(dlsym(handle, kCnnEngineEntry));
  if (entry == nullptr) {
    dlclose(handle);
    return FailedPreconditionError(module.string(), std::string("not a CNN module of this loom: it has no ") + kCnnEngineEntry +
                                                        " (a module built from other sources?)");
  }
  return entry();
}

Result<const CnnEngine*> BuiltCnnEngine() {
  static const Result<const CnnEngine*> engine = LoadCnnEngine(LOOM_CNN_TORCH_MODULE);
  return engine;
}

}  // namespace loom::fitting::internal
