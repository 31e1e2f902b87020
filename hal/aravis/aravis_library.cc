#include "hal/aravis/aravis_library.h"

#include <arv.h>

namespace loom::hal {

LinkedLibrary AravisLibrary() {
  return {"Aravis", std::to_string(arv_get_major_version()) + "." + std::to_string(arv_get_minor_version()) + "." +
                        std::to_string(arv_get_micro_version())};
}

}  // namespace loom::hal
