#pragma once
// A new scan on a rig (acquisition/rig_scan.h) with every device backend loom has, the rig and
// preset named as on the command line (a file, or a name in configs/), and a real rig's objects
// placed by the operator at the terminal: what `loom scan` runs and the main job (demo/) asks for.

#include "core/status.h"
#include "scan/scan_request.h"

namespace loom::apps {

Status NewScan(const scan::ScanRequest& request);

}  // namespace loom::apps
