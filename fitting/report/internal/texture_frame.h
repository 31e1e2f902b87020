#pragma once
// What loom's renderer exports (glTF, MaterialX) share: the tangent frame of the sample's quad,
// the GGX roughness that stands for a Ward lobe, and the specular scale of a set of maps.

#include <opencv2/core.hpp>

#include <Eigen/Core>

#include "core/image.h"

namespace loom::fitting::internal {

// The GGX α that stands for a Ward σ: √2 σ, clamped to [1e-4, 1]. The Ward lobe is a Beckmann
// distribution of slope RMS σ, and √2 matches the two distributions' curvature at the peak.
double GgxAlphaOfWardSigma(double sigma);

// Tangent space on the quad: T = the sample's +x (along the image's columns, +u), B = the
// sample's −y (up the image: rows run along +y), N = +z.
Eigen::Vector3d ToTangentSpace(const Eigen::Vector3d& in_sample);

// A unit vector encoded as (v + 1) / 2 in 8 bits, in OpenCV's BGR order.
cv::Vec3b UnitVectorRgb(const Eigen::Vector3d& v);

// The largest a_s · F0 over the maps' pixels: the specular reflectance at normal incidence
// that a renderer's dielectric must reach.
double MaxSpecularF0(const Image& maps);

}  // namespace loom::fitting::internal
