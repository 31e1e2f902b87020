#pragma once
// The sRGB transfer function (IEC 61966-2-1): linear light ↔ the encoded values of 8-bit images,
// PNGs and JPEGs. Neither clamps: values outside [0, 1] follow the same curve.

#include <cmath>

namespace loom {

inline double SrgbEncode(double linear) {
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
}

inline double SrgbDecode(double encoded) {
  return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

}  // namespace loom
