#pragma once
// Every device backend loom ships, registered under its rig-YAML `backend:` key. The only
// place that knows them all (style.md: apps picks backends).

#include "hal/registry.h"

namespace loom::apps {

hal::BackendRegistry AllBackends();

}  // namespace loom::apps
