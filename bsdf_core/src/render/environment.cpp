// The world's environment texture; see render/environment.h.
#include "hairbsdf/render/environment.h"

#include <algorithm>

#include "hairbsdf/render/shading_vm.h"

namespace hairbsdf::render {

namespace {

constexpr double kUniformShare = 0.1;  // share of uniform-sphere samples in the mixture

int wrap(int i, int n) {
    const int m = i % n;
    return m < 0 ? m + n : m;
}

Vec3 uniform_sphere(double u0, double u1) {
    const double z = 1.0 - 2.0 * u0;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = kTwoPi * u1;
    return {r * std::cos(phi), r * std::sin(phi), z};
}

// Index k with cdf[k] <= u < cdf[k + 1] (cdf increasing from 0 to 1).
size_t find_interval(const double* cdf, size_t count, double u) {
    const double* it = std::upper_bound(cdf, cdf + count + 1, u);
    const size_t k = size_t(std::max<std::ptrdiff_t>(it - cdf - 1, 0));
    return std::min(k, count - 1);
}

}  // namespace

EnvironmentMap::EnvironmentMap(const EnvironmentDesc& d)
    : width_(d.width), height_(d.height), pixels_(d.pixels), weight_(d.weight), closest_(d.closest),
      srgb_encoded_(d.srgb_encoded), matrix_(d.matrix) {
    if (!d.has_texture()) {
        width_ = height_ = 0;
        return;
    }
    // A pure rotation (no translation, orthonormal rows) keeps the map samplable.
    const auto& m = matrix_;
    bool rotation = std::fabs(m[3]) < 1e-9 && std::fabs(m[7]) < 1e-9 && std::fabs(m[11]) < 1e-9;
    for (int i = 0; i < 3 && rotation; ++i)
        for (int j = 0; j < 3; ++j) {
            const double d_ij = m[4 * i] * m[4 * j] + m[4 * i + 1] * m[4 * j + 1] + m[4 * i + 2] * m[4 * j + 2];
            rotation = rotation && std::fabs(d_ij - (i == j ? 1.0 : 0.0)) < 1e-6;
        }
    rotation_only_ = rotation;
    if (!rotation_only_) return;

    const int w = width_, h = height_;
    std::vector<double> brightness(size_t(w) * h);
    for (int r = 0; r < h; ++r)
        for (int c = 0; c < w; ++c) {
            const RGB p = decoded(texel(c, h - 1 - r));
            brightness[size_t(r) * w + c] =
                (std::fabs(weight_.r * p.r) + std::fabs(weight_.g * p.g) + std::fabs(weight_.b * p.b)) / 3.0;
        }
    texel_prob_.assign(size_t(w) * h, 0.0);
    double total = 0;
    for (int r = 0; r < h; ++r) {
        const double sin_theta = std::sin(kPi * (r + 0.5) / h);
        for (int c = 0; c < w; ++c) {
            double largest = 0;
            for (int dr = -1; dr <= 1; ++dr)
                for (int dc = -1; dc <= 1; ++dc)
                    largest = std::max(largest, brightness[size_t(wrap(r + dr, h)) * w + size_t(wrap(c + dc, w))]);
            texel_prob_[size_t(r) * w + c] = largest * sin_theta;
            total += largest * sin_theta;
        }
    }
    if (!(total > 0) || !std::isfinite(total)) return;
    row_cdf_.assign(size_t(h) + 1, 0.0);
    column_cdf_.assign(size_t(h) * (size_t(w) + 1), 0.0);
    for (int r = 0; r < h; ++r) {
        double row_sum = 0;
        double* cdf = &column_cdf_[size_t(r) * (w + 1)];
        for (int c = 0; c < w; ++c) {
            texel_prob_[size_t(r) * w + c] /= total;
            row_sum += texel_prob_[size_t(r) * w + c];
            cdf[c + 1] = row_sum;
        }
        for (int c = 1; c <= w; ++c) cdf[c] = row_sum > 0 ? cdf[c] / row_sum : double(c) / w;
        row_cdf_[size_t(r) + 1] = row_cdf_[size_t(r)] + row_sum;
    }
    row_cdf_[size_t(h)] = 1.0;
    has_map_ = true;
}

void EnvironmentMap::equirectangular_uv(Vec3 l, double& u, double& v) {
    const double len = length(l);
    if (!(len > 0)) {
        u = v = 0;
        return;
    }
    u = 0.5 - std::atan2(l.y, l.x) / kTwoPi;
    v = 1.0 - std::acos(clamp(l.z / len, -1.0, 1.0)) / kPi;
}

Vec3 EnvironmentMap::lookup_vector(Vec3 d) const {
    const auto& m = matrix_;
    return {m[0] * d.x + m[1] * d.y + m[2] * d.z + m[3], m[4] * d.x + m[5] * d.y + m[6] * d.z + m[7],
            m[8] * d.x + m[9] * d.y + m[10] * d.z + m[11]};
}

RGB EnvironmentMap::texel(int column, int row_from_bottom) const {
    const float* p = &pixels_[(size_t(height_ - 1 - row_from_bottom) * width_ + size_t(column)) * 3];
    return {p[0], p[1], p[2]};
}

RGB EnvironmentMap::decoded(RGB c) const {
    if (!srgb_encoded_) return c;
    return {srgb_to_linear(float(c.r)), srgb_to_linear(float(c.g)), srgb_to_linear(float(c.b))};
}

RGB EnvironmentMap::lookup(double u, double v) const {
    return decoded(interpolated(u, v));
}

RGB EnvironmentMap::interpolated(double u, double v) const {
    const int w = width_, h = height_;
    if (closest_) return texel(wrap(int(u * w), w), wrap(int(v * h), h));
    const double x = u * w - 0.5, y = v * h - 0.5;  // texel centres at integer + 0.5
    const double fx0 = std::floor(x), fy0 = std::floor(y);
    const double fx = x - fx0, fy = y - fy0;
    const int x0 = wrap(int(fx0), w), x1 = wrap(int(fx0) + 1, w);
    const int y0 = wrap(int(fy0), h), y1 = wrap(int(fy0) + 1, h);
    return (1 - fy) * ((1 - fx) * texel(x0, y0) + fx * texel(x1, y0)) +
           fy * ((1 - fx) * texel(x0, y1) + fx * texel(x1, y1));
}

RGB EnvironmentMap::eval(Vec3 dir) const {
    if (width_ == 0) return RGB(0.0);
    double u, v;
    equirectangular_uv(lookup_vector(dir), u, v);
    return weight_ * lookup(u, v);
}

Vec3 EnvironmentMap::sample(double u0, double u1, double& pdf_out) const {
    Vec3 dir;
    if (!has_map_ || u0 < kUniformShare) {
        dir = uniform_sphere(has_map_ ? u0 / kUniformShare : u0, u1);
    } else {
        const double u = (u0 - kUniformShare) / (1.0 - kUniformShare);
        const size_t r = find_interval(row_cdf_.data(), size_t(height_), u);
        const double row_width = row_cdf_[r + 1] - row_cdf_[r];
        const double y_frac = row_width > 0 ? clamp((u - row_cdf_[r]) / row_width, 0.0, 1.0) : 0.5;
        const double* cdf = &column_cdf_[r * (size_t(width_) + 1)];
        const size_t c = find_interval(cdf, size_t(width_), u1);
        const double cell = cdf[c + 1] - cdf[c];
        const double x_frac = cell > 0 ? clamp((u1 - cdf[c]) / cell, 0.0, 1.0) : 0.5;
        // Texel space -> lookup direction: theta = pi y_top / H, atan2(y, x) = pi - 2 pi u.
        const double theta = kPi * (double(r) + y_frac) / height_;
        const double phi = kPi - kTwoPi * (double(c) + x_frac) / width_;
        const Vec3 l{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
        // dir = R^T l
        const auto& m = matrix_;
        dir = {m[0] * l.x + m[4] * l.y + m[8] * l.z, m[1] * l.x + m[5] * l.y + m[9] * l.z,
               m[2] * l.x + m[6] * l.y + m[10] * l.z};
    }
    pdf_out = pdf(dir);
    return dir;
}

double EnvironmentMap::pdf(Vec3 dir) const {
    const double uniform = 1.0 / (4.0 * kPi);
    if (!has_map_) return uniform;
    const Vec3 l = lookup_vector(dir);
    double u, v;
    equirectangular_uv(l, u, v);
    const int c = std::clamp(int(u * width_), 0, width_ - 1);
    const int r = std::clamp(int((1.0 - v) * height_), 0, height_ - 1);
    const double len = length(l);
    const double z = len > 0 ? clamp(l.z / len, -1.0, 1.0) : 1.0;
    const double sin_theta = std::max(std::sqrt(std::max(0.0, 1.0 - z * z)), 1e-12);
    const double map = texel_prob_[size_t(r) * width_ + c] * double(width_) * height_ / (2.0 * kPi * kPi * sin_theta);
    return kUniformShare * uniform + (1.0 - kUniformShare) * map;
}

}  // namespace hairbsdf::render
