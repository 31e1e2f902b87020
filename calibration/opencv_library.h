#pragma once
// The OpenCV library this build loaded.
#include "core/version.h"

namespace loom::calibration {
LinkedLibrary OpenCvLibrary();
}
