#pragma once
// The `aravis` backend: GigE Vision (and USB3 Vision) cameras through Aravis 0.8 (GenICam).
//
// Rig YAML keys of an aravis camera (besides name, backend, settings):
//   address: 192.168.10.11      # IP address (unicast, no discovery), or an Aravis device id
//                               # ("Basler-21234567"), which makes Aravis discover devices
//   reconnect_attempts: 2       # optional: reopen attempts after the camera dropped out
//
// Opening by device id broadcasts discovery on every interface: on a rig that is the point; in
// tests it happens only inside a private network namespace.

#include <ostream>
#include <string>
#include <vector>

#include "hal/registry.h"

namespace loom::hal {

void RegisterAravisBackend(BackendRegistry& registry);

struct DiscoveredCamera {
  std::string id;  // Aravis device id, usable as `address:`
  std::string vendor;
  std::string model;
  std::string serial;
  std::string address;   // IP address for GigE Vision
  std::string protocol;  // "GigEVision", "USB3Vision"
};

// Every camera Aravis can find. BROADCASTS GigE Vision discovery on every network interface:
// for setting up a rig on its camera network; tests call it only inside a private namespace.
std::vector<DiscoveredCamera> DiscoverAravisCameras();
// One line per camera: id, protocol, address, vendor, model and serial (loom rig list --discover).
void ListDiscoveredCameras(const std::vector<DiscoveredCamera>& cameras, std::ostream& out);

}  // namespace loom::hal
