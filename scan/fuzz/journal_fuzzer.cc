// libFuzzer target: any bytes as a scan's journal.jsonl (scan/capture_store.h), beside the
// scan.yaml and plan.yaml of a tiny simulated scan (fuzz/journal-scan/), opened for reading and,
// when accepted, every recorded frame read back (the frames are absent: each read must fail
// cleanly). It must refuse or accept; never crash, hang or allocate without bound. Built with
// LOOM_BUILD_FUZZERS=ON under clang (scripts/fuzz.sh); seeded from fuzz/journal-corpus/.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "scan/capture_store.h"

namespace {

namespace fs = std::filesystem;

// A scan directory of this process's own, holding the tiny scan's scan.yaml and plan.yaml.
const fs::path& ScanDirectory() {
  static const fs::path dir = [] {
    const fs::path made = fs::temp_directory_path() / ("loom_journal_fuzzer_" + std::to_string(::getpid()));
    fs::remove_all(made);
    fs::create_directories(made / "frames");
    for (const char* file : {"scan.yaml", "plan.yaml"}) {
      fs::copy_file(fs::path(LOOM_JOURNAL_SCAN_DIR) / file, made / file);
    }
    return made;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const fs::path& dir = ScanDirectory();
  std::ofstream(dir / "journal.jsonl", std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  loom::Result<loom::scan::CaptureStore> store = loom::scan::CaptureStore::Open(dir);
  if (!store.ok()) return 0;
  for (const loom::scan::FrameRecord& record : store->records()) (void)store->ReadFrame(record);
  return 0;
}
