// The world's equirectangular environment texture (scene.h EnvironmentDesc): lookup as Cycles'
// Environment Texture node does it, and importance sampling of directions.
//
// Sampling: a piecewise-constant density over the texels, each weighted by the largest
// luminance in its 3 x 3 neighbourhood (bilinear filtering spreads a texel's value over its
// neighbours) times sin(theta) of its row, mixed with 10 % uniform sphere so that every
// direction with radiance has a positive density. When the Mapping matrix is not a pure
// rotation the map cannot be pulled back to directions and the world is sampled uniformly.
// Only the noise depends on these choices, never the expected value.
#pragma once

#include <vector>

#include "hairbsdf/render/scene.h"

namespace hairbsdf::render {

class EnvironmentMap {
public:
    explicit EnvironmentMap(const EnvironmentDesc& desc);
    RGB eval(Vec3 dir) const;  // weight x texture at the world direction `dir` (unit)
    // A direction with its solid-angle density.
    Vec3 sample(double u0, double u1, double& pdf) const;
    double pdf(Vec3 dir) const;
    RGB weight() const { return weight_; }  // Background strength x Mix / Add weights
    int width() const { return width_; }    // the texture's size in texels
    int height() const { return height_; }

    // Texture coordinates of a lookup vector (Cycles' direction_to_equirectangular).
    static void equirectangular_uv(Vec3 lookup, double& u, double& v);

private:
    RGB texel(int column, int row_from_bottom) const;  // as stored
    RGB interpolated(double u, double v) const;         // as stored, Closest or bilinear
    RGB decoded(RGB stored) const;                      // scene-linear (sRGB decoded when encoded)
    RGB lookup(double u, double v) const;               // decoded(interpolated(u, v))
    Vec3 lookup_vector(Vec3 dir) const;

    int width_, height_;
    std::vector<float> pixels_;
    RGB weight_;
    bool closest_;
    bool srgb_encoded_;
    std::array<double, 12> matrix_;
    bool rotation_only_ = false;  // matrix = [R | 0] with R orthonormal: the map can be sampled
    std::vector<double> row_cdf_;      // (height + 1), marginal over rows (top row first)
    std::vector<double> column_cdf_;   // height x (width + 1), conditional per row
    std::vector<double> texel_prob_;   // height x width, probability of each texel
    bool has_map_ = false;
};

}  // namespace hairbsdf::render
