#pragma once
// BackendRegistry: device factories keyed by the `backend:` string of the rig YAML.
// apps/ fills it (the only place that picks backends); `sim` registers like any real backend.
//
//   registry.Register<Camera>("aravis", &MakeAravisCamera);
//   LOOM_ASSIGN_OR_RETURN(auto camera, registry.Create<Camera>(config));
//
// A factory reads its backend-specific keys (address, endpoint, ...) from `config.node`; keys
// nobody reads are reported by the document's Finish() as unknown.

#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "core/config.h"
#include "hal/camera.h"
#include "hal/led_array.h"
#include "hal/motion.h"
#include "hal/projector.h"

namespace loom::hal {

struct DeviceConfig {
  std::string name;     // the device's name in the rig
  std::string backend;  // the registry key
  ConfigNode node;      // the device's YAML mapping
};

template <typename D>
using DeviceFactory = std::function<Result<std::unique_ptr<D>>(const DeviceConfig&)>;

class BackendRegistry {
 public:
  template <typename D>
  void Register(const std::string& backend, DeviceFactory<D> factory) {
    Table<D>()[backend] = std::move(factory);
  }

  // An unknown backend is InvalidArgument naming the key and the backends that exist.
  template <typename D>
  Result<std::unique_ptr<D>> Create(const DeviceConfig& config) const {
    const auto& table = Table<D>();
    const auto it = table.find(config.backend);
    if (it == table.end()) {
      std::string known;
      for (const auto& [name, factory] : table) known += (known.empty() ? "" : ", ") + name;
      return InvalidArgumentError(
          "key '" + (config.node.path().empty() ? "" : config.node.path() + ".") + "backend'",
          "device '" + config.name + "': no backend '" + config.backend + "' (known: " + (known.empty() ? "none" : known) + ")");
    }
    return it->second(config);
  }

  // A simulated backend's devices live in virtual time (hal/clock.h): a rig made only of them
  // waits on a SimClock.
  void MarkSimulated(const std::string& backend) { simulated_.insert(backend); }
  bool IsSimulated(const std::string& backend) const { return simulated_.contains(backend); }

  template <typename D>
  std::vector<std::string> Backends() const {
    std::vector<std::string> names;
    for (const auto& [name, factory] : Table<D>()) names.push_back(name);
    return names;
  }

 private:
  template <typename D>
  using TableOf = std::map<std::string, DeviceFactory<D>>;

  template <typename D>
  TableOf<D>& Table() {
    return std::get<TableOf<D>>(tables_);
  }
  template <typename D>
  const TableOf<D>& Table() const {
    return std::get<TableOf<D>>(tables_);
  }

  std::tuple<TableOf<Camera>, TableOf<LedArray>, TableOf<FilterWheel>, TableOf<Turntable>, TableOf<LinearLight>,
             TableOf<Projector>>
      tables_;
  std::set<std::string> simulated_;
};

}  // namespace loom::hal
