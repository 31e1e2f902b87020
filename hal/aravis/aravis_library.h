#pragma once
// The Aravis (GenICam / GigE Vision) library this build loaded.
#include "core/version.h"

namespace loom::hal {
LinkedLibrary AravisLibrary();
}
