// Cycles' Emission closure (the `emission` closure of docs/scene_desc.md): radiance =
// strength x colour x the closure's weight, the same on both sides of the surface and in every
// direction. It scatters nothing: no eval, no sample (the renderer adds it where a path hits).
#pragma once

#include "hairbsdf/math.h"

namespace hairbsdf {

class Emission {
public:
    Emission(RGB color, double strength) : color_(color), strength_(strength) {}
    RGB color() const { return color_; }
    double strength() const { return strength_; }
    // The emitted radiance of the closure `weight` x this.
    RGB radiance(RGB weight) const { return strength_ * (weight * color_); }

private:
    RGB color_;
    double strength_;
};

}  // namespace hairbsdf
