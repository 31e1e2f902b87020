#pragma once
// The paper's 14-d training label of a WardParams (Merzbach et al. 2019, §"Labels"):
//
// | index  | value                  | why                                                 |
// |--------|------------------------|-----------------------------------------------------|
// | 0..2   | a_d (RGB)              |                                                     |
// | 3..5   | a_s (RGB)              |                                                     |
// | 6..8   | n_s                    | renormalised on decoding (n_z > 0)                  |
// | 9, 10  | σx', σy'               | σ' = ln(1 + 100 σ) / ln 101: [0,1] → [0,1], spreads |
// |        |                        | the small σ of glossy fabrics                       |
// | 11, 12 | cos 2α, sin 2α         | no wrap-around: α and α + π are the same lobe        |
// | 13     | F0                     |                                                     |
//
// Decoding accepts any network output: it renormalises n_s and (cos 2α, sin 2α) and clamps
// albedos to ≥ 0, σ to ≥ kSigmaFloor and F0 to [0, 1].

#include <array>

#include "fitting/model/ward_gd10.h"

namespace loom::fitting {

inline constexpr int kLabelSize = 14;
using Label = std::array<double, kLabelSize>;

// σ' = (ln(σ + 0.01) − ln 0.01) / (ln 1.01 − ln 0.01)
double EncodeSigma(double sigma);
// σ = 0.01 (101^σ' − 1)
double DecodeSigma(double encoded);

Label EncodeLabel(const WardParams<double>& params);
WardParams<double> DecodeLabel(const Label& label);

}  // namespace loom::fitting
