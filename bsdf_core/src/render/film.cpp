// Cycles' pixel-filter importance table and film resolve; see render/film.h.
#include "hairbsdf/render/film.h"

#include <algorithm>
#include <cmath>

namespace hairbsdf::render {

namespace {

// Filter profiles as functions of the distance v from the centre and the window width.
float filter_box(float, float) { return 1.0f; }
float filter_gaussian(float v, float width) {
    v *= 6.0f / width;
    return std::exp(-2.0f * v * v);
}
float filter_blackman_harris(float v, float width) {
    v = float(kTwoPi) * (v / width + 0.5f);
    return 0.35875f - 0.48829f * std::cos(v) + 0.14128f * std::cos(2.0f * v) - 0.01168f * std::cos(3.0f * v);
}

}  // namespace

FilterTable::FilterTable(IntegratorSettings::Filter type, double width_in) : table_(kFilterTableSize, 0.0f) {
    float (*profile)(float, float) = filter_box;
    float width = float(width_in);
    switch (type) {
        case IntegratorSettings::Filter::Box:
            profile = filter_box;
            width = 1.0f;  // Blender's sync
            break;
        case IntegratorSettings::Filter::Gaussian:
            profile = filter_gaussian;
            width *= 3.0f;
            break;
        case IntegratorSettings::Filter::BlackmanHarris:
            profile = filter_blackman_harris;
            width *= 2.0f;
            break;
    }
    const float range = 0.5f * width;

    // CDF of |profile| on [0, range] sampled at kFilterTableSize - 1 points.
    const int n = kFilterTableSize - 1;
    std::vector<float> cdf(size_t(n) + 1, 0.0f);
    for (int i = 0; i < n; ++i) {
        const float x = range * float(i) / float(n - 1);
        cdf[size_t(i) + 1] = cdf[size_t(i)] + std::fabs(profile(x, width));
    }
    const float total = cdf[size_t(n)];
    const float scale = total == 0.0f ? 0.0f : 1.0f / total;
    for (float& c : cdf) c *= scale;
    cdf[size_t(n)] = 1.0f;

    // Symmetric inversion around the centre entry; the last entry stays 0 as in Cycles.
    const int half = (kFilterTableSize - 1) / 2;
    const int cdf_size = int(cdf.size());
    for (int i = 0; i <= half; ++i) {
        const float x = float(i) / float(half);
        int index = int(std::upper_bound(cdf.begin(), cdf.end(), x) - cdf.begin());
        float t;
        if (index < cdf_size - 1) {
            t = (x - cdf[size_t(index)]) / (cdf[size_t(index) + 1] - cdf[size_t(index)]);
        } else {
            t = 0.0f;
            index = cdf_size - 1;
        }
        const float y = ((float(index) + t) / float(kFilterTableSize - 1)) * (2.0f * range);
        table_[size_t(half + i)] = 0.5f * (1.0f + y);
        table_[size_t(half - i)] = 0.5f * (1.0f - y);
    }
}

double FilterTable::sample(double u) const {
    // Cycles' lookup_table_read: linear interpolation on a table of kFilterTableSize points.
    const float x = float(clamp(u, 0.0, 1.0)) * float(kFilterTableSize - 1);
    const int index = std::min(int(x), kFilterTableSize - 1);
    const int next = std::min(index + 1, kFilterTableSize - 1);
    const float t = x - float(index);
    const float a = table_[size_t(index)];
    if (t == 0.0f) return a;
    return (1.0f - t) * a + t * table_[size_t(next)];
}

void Film::resolve(float* rgba, double exposure, bool film_transparent) const {
    const size_t n = size_t(width_) * size_t(height_);
    for (size_t i = 0; i < n; ++i) {
        const double* s = &sum_[4 * i];
        const int c = count_[i];
        float* o = rgba + 4 * i;
        if (c == 0) {
            o[0] = o[1] = o[2] = o[3] = 0.0f;
            continue;
        }
        const double inv = 1.0 / double(c);
        o[0] = float(exposure * s[0] * inv);
        o[1] = float(exposure * s[1] * inv);
        o[2] = float(exposure * s[2] * inv);
        o[3] = film_transparent ? float(clamp(1.0 - s[3] * inv, 0.0, 1.0)) : 1.0f;
    }
}

void Film::enable_passes(const IntegratorSettings& st) {
    const size_t n = size_t(width_) * size_t(height_);
    if (st.pass_hair_lobes) lobes_.assign(n * kLobeCount * 3, 0.0);
    if (st.pass_depth) depth_.assign(n, 0.0);
    if (st.pass_normal) normal_.assign(n * 3, 0.0);
    if (st.pass_depth || st.pass_normal) hits_.assign(n, 0);
    if (st.pass_variance) square_.assign(n * 3, 0.0);
}

void Film::add_passes(size_t pixel, const std::array<RGB, kLobeCount>& lobes, bool hit, double depth, Vec3 normal,
                      RGB radiance) {
    if (!lobes_.empty()) {
        double* l = &lobes_[pixel * kLobeCount * 3];
        for (size_t k = 0; k < size_t(kLobeCount); ++k) {
            l[3 * k] += lobes[k].r;
            l[3 * k + 1] += lobes[k].g;
            l[3 * k + 2] += lobes[k].b;
        }
    }
    if (hit && !hits_.empty()) {
        ++hits_[pixel];
        if (!depth_.empty()) depth_[pixel] += depth;
        if (!normal_.empty()) {
            normal_[3 * pixel] += normal.x;
            normal_[3 * pixel + 1] += normal.y;
            normal_[3 * pixel + 2] += normal.z;
        }
    }
    if (!square_.empty()) {
        square_[3 * pixel] += radiance.r * radiance.r;
        square_[3 * pixel + 1] += radiance.g * radiance.g;
        square_[3 * pixel + 2] += radiance.b * radiance.b;
    }
}

Film::Passes Film::resolve_passes(double exposure) const {
    const size_t n = size_t(width_) * size_t(height_);
    Passes out;
    auto finite = [](double v) { return std::isfinite(v) ? float(v) : 0.0f; };
    if (!lobes_.empty()) {
        out.hair_lobes.resize(lobes_.size());
        for (size_t i = 0; i < n; ++i) {
            const double inv = count_[i] ? exposure / double(count_[i]) : 0.0;
            for (size_t j = 0; j < size_t(kLobeCount) * 3; ++j)
                out.hair_lobes[i * kLobeCount * 3 + j] = finite(lobes_[i * kLobeCount * 3 + j] * inv);
        }
    }
    if (!depth_.empty()) {
        out.depth.resize(n);
        for (size_t i = 0; i < n; ++i) out.depth[i] = hits_[i] ? finite(depth_[i] / hits_[i]) : 1e10f;
    }
    if (!normal_.empty()) {
        out.normal.resize(n * 3);
        for (size_t i = 0; i < n * 3; ++i) out.normal[i] = hits_[i / 3] ? finite(normal_[i] / hits_[i / 3]) : 0.0f;
    }
    if (!square_.empty()) {
        out.variance.resize(n * 3);
        for (size_t i = 0; i < n; ++i) {
            const int c = count_[i];
            for (size_t ch = 0; ch < 3; ++ch) {
                if (c < 2) {
                    out.variance[3 * i + ch] = 0.0f;
                    continue;
                }
                const double mean = sum_[4 * i + ch] / c;
                // Sample variance of one sample, divided by c: the variance of the pixel's mean.
                const double var = std::max(0.0, (square_[3 * i + ch] - c * mean * mean) / double(c - 1)) / c;
                out.variance[3 * i + ch] = finite(exposure * exposure * var);
            }
        }
    }
    return out;
}

}  // namespace hairbsdf::render
