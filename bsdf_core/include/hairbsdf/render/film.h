// Pixel filter and film accumulation, as Cycles does them.
//
// Pixel filter (scene/film.cpp, util/math_cdf.*, kernel camera): no splatting; each camera
// sample is placed at pixel + offset, the offset drawn independently per axis by inverting
// a 1024-entry table built from the filter's half profile:
//   Blackman-Harris: support +-width around the pixel centre (the profile is evaluated on
//     a window twice the width);  Gaussian: sigma = width / 4 on a +-1.5 width support
//     (Cycles evaluates it on a window 3x the width);  Box: uniform +-0.5 px (Blender's
//     sync forces width 1 whatever filter_width says).
// The table is built the same way, including its last entry, which Cycles leaves at 0
// (the top 1/1023 of the random range interpolates towards offset -0.5): reproducing it
// keeps the expected pixel value identical.
#pragma once

#include <vector>

#include "hairbsdf/closure.h"
#include "hairbsdf/render/scene.h"

namespace hairbsdf::render {

constexpr int kFilterTableSize = 1024;

class FilterTable {
public:
    FilterTable(IntegratorSettings::Filter type, double width);
    // Offset from the pixel's integer corner (0.5 = pixel centre) for a uniform u in [0, 1].
    double sample(double u) const;
    const std::vector<float>& table() const { return table_; }

private:
    std::vector<float> table_;
};

// Per-pixel sums of sample radiance and background transparency, in samples order, plus
// the sums of the passes the settings ask for.
class Film {
public:
    Film(int width, int height) : width_(width), height_(height), sum_(size_t(width) * height * 4, 0.0),
                                  count_(size_t(width) * height, 0) {}
    // Allocates the pass sums (before the first add).
    void enable_passes(const IntegratorSettings& settings);
    int width() const { return width_; }
    int height() const { return height_; }
    // Pixel index = row * width + column, row 0 at the top.
    void add(size_t pixel, RGB radiance, double transparent) {
        double* s = &sum_[4 * pixel];
        s[0] += radiance.r;
        s[1] += radiance.g;
        s[2] += radiance.b;
        s[3] += transparent;
        ++count_[pixel];
    }
    // The passes of one sample (only the enabled ones are kept).
    void add_passes(size_t pixel, const std::array<RGB, kLobeCount>& lobes, bool hit, double depth, Vec3 normal,
                    RGB radiance);
    // (H, W, 4) RGBA: exposure x mean radiance; alpha = 1 - mean transparency when the
    // film is transparent, else 1. Pixels without samples are 0.
    void resolve(float* rgba, double exposure, bool film_transparent) const;
    // Pass images, row 0 at the top: hair lobes (H, W, 4 lobes, 3) x exposure, depth (H, W)
    // averaged over the samples that hit a surface (1e10 where none did, as Cycles' background),
    // normal (H, W, 3) averaged likewise, variance (H, W, 3) of the pixel mean x exposure^2.
    // Each is empty when not enabled.
    struct Passes {
        std::vector<float> hair_lobes, depth, normal, variance;
    };
    Passes resolve_passes(double exposure) const;
    size_t memory_bytes() const {
        return (sum_.size() + lobes_.size() + depth_.size() + normal_.size() + square_.size()) * sizeof(double) +
               (count_.size() + hits_.size()) * sizeof(int);
    }

private:
    int width_, height_;
    std::vector<double> sum_;
    std::vector<int> count_;
    std::vector<double> lobes_, depth_, normal_, square_;  // pass sums
    std::vector<int> hits_;                                // samples that hit a surface
};

}  // namespace hairbsdf::render
