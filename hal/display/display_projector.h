#pragma once
// The `display` backend: a projector driven as an HDMI display. Patterns go to a borderless
// full-screen OpenCV window placed on the projector's screen.
//
// Rig YAML keys of a display projector (besides name, backend, settings):
//   native_width: 1920, native_height: 1080   # the projector's resolution
//   screen_x: 1920, screen_y: 0               # where its screen starts on the desktop
//
// Needs a graphical session ($DISPLAY); Open() says so when there is none.

#include "hal/registry.h"

namespace loom::hal {

void RegisterDisplayBackend(BackendRegistry& registry);

}  // namespace loom::hal
