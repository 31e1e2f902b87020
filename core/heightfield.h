#pragma once
// Heightmap helpers shared by the simulator's material generator and renderer and by
// reconstruction, so that all use the same geometric normals (the heightmap blurred to what
// structured light resolves).

#include <vector>

#include <Eigen/Core>

namespace loom {

// Separable Gaussian blur (σ in pixels) with clamped edges; row-major width × height.
std::vector<double> BlurHeights(const std::vector<double>& heights, int width, int height, double sigma_px);

// Unit normal of a heightmap (mm) at a pixel, by central differences, in the sample frame.
Eigen::Vector3d HeightfieldNormal(const std::vector<double>& heights, int width, int height, int x, int y, double pixel_mm);

// The geometric normals of a heightmap: its normals after blurring to `blur_mm`.
std::vector<Eigen::Vector3d> GeometricNormals(const std::vector<double>& heights, int width, int height, double pixel_mm,
                                              double blur_mm);

}  // namespace loom
