#pragma once
// Where tests and benchmarks find the source tree (configs/, testdata/) and the tools they run as
// child processes. The paths are compiled into one generated translation unit (build_tree.cc.in),
// not into every test's compile definitions: then every other test object compiles the same in
// any clone of the repository, and the compiler cache shares them between clones (CI's included).

#include <string>

namespace loom::testing {

// The repository's root, without a trailing slash.
const std::string& SourceDir();
// The built `loom` executable.
const std::string& LoomBinary();
// The built Modbus device simulator (hal/modbus/sim/modbus_sim_main.cc).
const std::string& ModbusSimBinary();

}  // namespace loom::testing
