#pragma once
// One stack pixel's observations as the per-pixel fitter takes them (fitting/solve/pixel_fitter.h): every
// observation its camera saw, in the pixel's local geometric frame (z = the stack's geometric
// normal, x = the sample's x made orthogonal to it: svbrdf_maps.h's frame), each emitter a light
// sample of irradiance I(p)/d². Emitters the heightmap (pos.Z) hides from the pixel are left
// out; an observation with no emitter left is a shadow and is left out as well, so cast
// shadows never reach the fit. The light model is the stack table's (core/observation_stack.h).
// Thread-safety: Observations() may run on many threads (kept frames are filled once each).

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "core/heightmap.h"
#include "core/observation_stack.h"
#include "fitting/model/internal/light_samples.h"
#include "fitting/model/observation.h"
#include "fitting/model/strip_quadrature.h"

namespace loom::fitting {

struct StackPixelOptions {
  bool cast_shadows = true;  // test every emitter against the stack's heightmap
  // Set: Observations(x, y, lobe) integrates each linear light's strip by Gauss–Legendre nodes
  // placed around that lobe (strip_quadrature.h) instead of the stack's emitters.
  std::optional<StripQuadratureOptions> strip_quadrature;
  // Remember each pixel's frame (its position, local frame and horizon bound: ~360 bytes) and
  // which of its observations' emitters the heightmap hides (a bit each: ~930 bytes a pixel in
  // all on tac7-mini, ~1.5 kB on tac7) from its first Observations() on: worth it where every
  // pixel is fitted more than once (a smoothing pass), since the horizon bound and the shadow
  // tests are most of building its observations.
  bool keep_frames = false;
};

class StackPixels {
 public:
  // Keeps a reference to `stack`: it must outlive this.
  explicit StackPixels(const ObservationStack& stack, const StackPixelOptions& options = {});

  int width() const { return stack_.image.width(); }
  int height() const { return stack_.image.height(); }

  // The pixel's usable observations (unseen and fully shadowed ones left out).
  std::vector<PixelObservation> Observations(int x, int y) const;
  // The same among the observations `only` (stack indices), in their order.
  std::vector<PixelObservation> Observations(int x, int y, std::span<const int> only) const;
  // The same, each linear-light strip integrated by StripNodes around the lobe of `lobe` (the
  // parameters a fit starts from) when options.strip_quadrature is set; else as Observations(x, y).
  std::vector<PixelObservation> Observations(int x, int y, const WardParams<double>& lobe) const;
  // Observations(x, y) and Observations(x, y, *lobe) written into `into`, replacing what it held
  // and reusing its observations' memory: a fit builds thousands of light samples per pixel,
  // each observation's in a vector of its own, and allocating them anew was a tenth of a
  // point-lit refinement.
  void ObservationsInto(int x, int y, const WardParams<double>* lobe, std::vector<PixelObservation>& into) const;
  // Per stack observation, the span of the strip (strip_quadrature.h's LobeSpan at `fraction` of
  // the peak) where the lobe of `params` lies at pixel (x, y); {0, 1} for observations that are
  // not a strip. With the spans at lobe_fraction of the parameters a fit's nodes were placed for,
  // and at moved_fraction of those it ended at, StripNodesCover tells whether the nodes still
  // hold. Needs options.strip_quadrature.
  std::vector<std::pair<double, double>> LobeSpans(int x, int y, const WardParams<double>& params, double fraction) const;
  bool integrates_strips() const { return options_.strip_quadrature.has_value(); }
  const StripQuadratureOptions& strip_quadrature() const { return *options_.strip_quadrature; }
  // local_from_sample of the pixel's geometric frame.
  Eigen::Matrix3d LocalFromSample(int x, int y) const;

 private:
  struct PixelFrame {
    Eigen::Vector3d position;
    Eigen::Matrix3d local_from_sample;
    Heightmap::Horizon horizon;  // of the position: most lights need no march
  };
  PixelFrame FrameOf(int x, int y) const;
  PixelFrame ComputeFrame(int x, int y) const;
  // Bit first_emitter_bit_[k] + i: emitter i of observation k is hidden from pixel (x, y) (0 for
  // observations the pixel does not see).
  std::vector<uint64_t> HiddenEmitters(int x, int y, const PixelFrame& frame) const;
  // Observation `k` of pixel (x, y) into `observation` (its light samples' memory reused); false
  // where it is unseen or fully shadowed. Its strip integrated around `lobe`'s span when given.
  bool Observe(int k, int x, int y, const PixelFrame& frame, PixelObservation& observation,
               const WardParams<double>* lobe = nullptr) const;

  const ObservationStack& stack_;
  StackPixelOptions options_;
  Heightmap heightmap_;
  double shadow_reach_mm_ = 0;                           // how far a shadow test marches towards a light at infinity
  std::vector<char> directional_;                        // per stack observation: it has a light at infinity
  std::vector<std::optional<StripSegment>> strips_;      // per stack observation: its linear light's strip
  std::vector<internal::EmitterArrays> emitter_arrays_;  // per stack observation: its emitters
  // With options_.keep_frames: each pixel's frame and hidden emitters, filled under its flag on
  // first use.
  mutable std::unique_ptr<std::once_flag[]> frame_filled_;
  mutable std::vector<PixelFrame> frames_;
  mutable std::vector<std::vector<uint64_t>> hidden_;
  std::vector<size_t> first_emitter_bit_;  // per stack observation
  size_t emitter_bits_ = 0;                // the stack's emitters, all observations'
};

}  // namespace loom::fitting
