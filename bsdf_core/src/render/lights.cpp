// Light sampling and evaluation with Cycles' normalisation; see render/lights.h.
#include "hairbsdf/render/lights.h"

#include <algorithm>
#include <array>
#include <cfloat>
#include <limits>
#include <optional>
#include <vector>

namespace hairbsdf::render {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Vec3 to_vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }
Vec3 to_vec3(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }
bool is_zero(RGB c) { return c.r == 0 && c.g == 0 && c.b == 0; }

// 1 - cos(asin(sqrt(s2))) without cancellation.
double sin_sqr_to_one_minus_cos(double s2) { return s2 / (1.0 + std::sqrt(std::max(1.0 - s2, 0.0))); }

double smoothstep(double x) {
    if (!(x > 0)) return 0.0;  // also NaN (spot_blend = 0 on the cone edge)
    if (x >= 1) return 1.0;
    return x * x * (3.0 - 2.0 * x);
}

// Nearest t in (tmin, tmax) where the ray meets the sphere.
bool ray_sphere(Vec3 o, Vec3 d, double tmin, double tmax, Vec3 c, double r, double& t) {
    const Vec3 oc = o - c;
    const double b = dot(oc, d);
    const double cc = dot(oc, oc) - r * r;
    const double disc = b * b - cc;
    if (disc < 0) return false;
    const double s = std::sqrt(disc);
    const double t0 = -b - s, t1 = -b + s;
    if (t0 > tmin && t0 < tmax) {
        t = t0;
        return true;
    }
    if (t1 > tmin && t1 < tmax) {
        t = t1;
        return true;
    }
    return false;
}

void invert3(const std::array<double, 9>& m, std::array<double, 9>& inv) {
    const double a = m[0], b = m[1], c = m[2], d = m[3], e = m[4], f = m[5], g = m[6], h = m[7], i = m[8];
    const double A = e * i - f * h, B = -(d * i - f * g), C = d * h - e * g;
    const double det = a * A + b * B + c * C;
    const double s = det != 0 ? 1.0 / det : 0.0;
    inv = {A * s, -(b * i - c * h) * s, (b * f - c * e) * s, B * s, (a * i - c * g) * s, -(a * f - c * d) * s,
           C * s, -(a * h - b * g) * s, (a * e - b * d) * s};
}

}  // namespace

// A rectangle seen from a point, sampled uniformly in solid angle: Urena, Fajardo and King,
// "An Area-Preserving Parametrization for Spherical Rectangles" (EGSR 2013), §3-4. The
// rectangle is corner + [0, len_u] axis_u + [0, len_v] axis_v (unit, orthogonal axes).
struct SphericalRectangle {
    Vec3 o, x, y, z;                 // shading point and the local frame (z points away from the rectangle)
    double x0 = 0, x1 = 0, y0 = 0, y1 = 0, z0 = 0;
    double b0 = 0, b1 = 0, k = 0, solid_angle = 0;

    SphericalRectangle(Vec3 point, Vec3 corner, Vec3 axis_u, Vec3 axis_v, double len_u, double len_v)
        : o(point), x(axis_u), y(axis_v), z(cross(axis_u, axis_v)) {
        const Vec3 d = corner - o;
        x0 = dot(d, x);
        y0 = dot(d, y);
        z0 = dot(d, z);
        if (z0 > 0) {
            z0 = -z0;
            z = -1.0 * z;
        }
        x1 = x0 + len_u;
        y1 = y0 + len_v;
        // Normals of the four planes through o and an edge (§3, Fig. 2), in the local frame.
        const Vec3 v00{x0, y0, z0}, v01{x0, y1, z0}, v10{x1, y0, z0}, v11{x1, y1, z0};
        const Vec3 n0 = normalize(cross(v00, v10)), n1 = normalize(cross(v10, v11));
        const Vec3 n2 = normalize(cross(v11, v01)), n3 = normalize(cross(v01, v00));
        auto interior = [](Vec3 a, Vec3 b) { return std::acos(std::clamp(-dot(a, b), -1.0, 1.0)); };
        const double g0 = interior(n0, n1), g1 = interior(n1, n2), g2 = interior(n2, n3), g3 = interior(n3, n0);
        b0 = n0.z;
        b1 = n2.z;
        k = kTwoPi - g2 - g3;
        solid_angle = g0 + g1 - k;  // Girard: the sum of the angles minus 2 pi
    }

    // The point on the rectangle for (u, v) in [0, 1)^2 (§4, Algorithm 1).
    Vec3 sample(double u, double v) const {
        const double au = u * solid_angle + k;
        const double fu = (std::cos(au) * b0 - b1) / std::sin(au);
        double cu = (fu >= 0 ? 1.0 : -1.0) / std::sqrt(fu * fu + b0 * b0);
        cu = std::clamp(cu, -1.0, 1.0);
        double xu = -(cu * z0) / std::sqrt(std::max(1.0 - cu * cu, 1e-300));
        xu = std::clamp(xu, x0, x1);
        const double dist = std::sqrt(xu * xu + z0 * z0);
        const double h0 = y0 / std::sqrt(dist * dist + y0 * y0), h1 = y1 / std::sqrt(dist * dist + y1 * y1);
        const double hv = h0 + v * (h1 - h0), hv2 = hv * hv;
        const double yv = hv2 < 1.0 - 1e-12 ? hv * dist / std::sqrt(1.0 - hv2) : y1;
        return o + xu * x + yv * y + z0 * z;
    }
};

// Below this solid angle Girard's formula loses its digits; such lights are sampled by area.
constexpr double kMinRectangleSolidAngle = 1e-7;

struct RectangleView {
    std::optional<SphericalRectangle> rectangle;
    bool unreachable = false;  // a narrowed spread: no part of the light reaches p
};

RectangleView Light::solid_angle_rectangle(Vec3 p) const {
    if (ellipse_) return {};
    double u0 = -0.5 * len_u_, u1 = 0.5 * len_u_, v0 = -0.5 * len_v_, v1 = 0.5 * len_v_;
    if (!full_spread_) {
        // Only points within distance x tan(spread / 2) of p's foot on the plane emit towards p:
        // clip the rectangle to the square around that disk, as Cycles does.
        const Vec3 d = p - co_;
        const double reach = dot(d, normal_) * tan_half_spread_;
        const double pu = dot(d, axis_u_), pv = dot(d, axis_v_);
        u0 = std::max(u0, pu - reach);
        u1 = std::min(u1, pu + reach);
        v0 = std::max(v0, pv - reach);
        v1 = std::min(v1, pv + reach);
        if (!(u1 > u0 && v1 > v0)) return {std::nullopt, true};
    }
    const Vec3 corner = co_ + u0 * axis_u_ + v0 * axis_v_;
    SphericalRectangle rect(p, corner, axis_u_, axis_v_, u1 - u0, v1 - v0);
    if (!(rect.solid_angle > kMinRectangleSolidAngle)) return {};
    return {rect, false};
}

Vec3 sample_uniform_cone(Vec3 axis, double one_minus_cos, double u0, double u1) {
    const double cos_t = 1.0 - u0 * one_minus_cos;
    const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
    const double phi = kTwoPi * u1;
    Vec3 a, b;
    make_orthonormals(axis, a, b);
    return normalize((sin_t * std::cos(phi)) * a + (sin_t * std::sin(phi)) * b + cos_t * axis);
}

static Vec3 sample_uniform_sphere(double u0, double u1) {
    const double z = 1.0 - 2.0 * u0;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = kTwoPi * u1;
    return {r * std::cos(phi), r * std::sin(phi), z};
}

Light::Light(RGB world_radiance, const EnvironmentDesc& texture, bool world_mis, int map_resolution, bool tree_energy)
    : world_(true), radiance_(world_radiance) {
    contributes_ = !is_zero(world_radiance) && isfinite(world_radiance);
    if (texture.has_texture() && !is_zero(texture.weight)) {
        environment_ = std::make_shared<const EnvironmentMap>(texture);
        contributes_ = true;
    }
    // Cycles enables the background light only for a spatially varying world shader.
    use_mis_ = world_mis && environment_ != nullptr;
    make_tree_emitter(nullptr, map_resolution, tree_energy);
}

Light::Light(const LightDesc& d) : type_(d.type) {
    contributes_ = !is_zero(d.strength) && isfinite(d.strength);
    visible_camera_ = d.visible_camera;
    RGB eval_fac{0.0};
    switch (d.type) {
        case LightType::Point:
        case LightType::Spot: {
            co_ = to_vec(d.position);
            radius_ = std::max(0.0, d.radius);
            sphere_ = !d.soft_falloff && radius_ > 0;
            const double area = radius_ > 0 ? 4.0 * kPi * radius_ * radius_ : 4.0;
            eval_fac = RGB((d.normalize ? 1.0 / area : 1.0) / kPi);
            use_mis_ = d.use_mis && radius_ > 0;
            if (d.type == LightType::Spot) {
                // The light's 3x3 matrix (columns u, v, w with w = -Z); without one, an
                // orthonormal frame around the given axis.
                std::array<double, 9> m3;
                Vec3 w = normalize(to_vec(d.direction));
                if (d.has_matrix) {
                    const auto& m = d.matrix_world;
                    m3 = {m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]};
                    w = normalize(Vec3{-m[2], -m[6], -m[10]});
                } else {
                    Vec3 a, b;
                    make_orthonormals(w, a, b);
                    // columns: x = a, y = b, z = -w (row-major storage)
                    m3 = {a.x, b.x, -w.x, a.y, b.y, -w.y, a.z, b.z, -w.z};
                }
                spot_dir_ = w;
                spot_cosine_ = d.spot_cosine;
                invert3(m3, spot_inv_);
                const double half = 0.5 * d.spot_size;
                cos_half_spot_ = std::cos(half);
                spot_smooth_ = 1.0 / ((1.0 - cos_half_spot_) * d.spot_blend);
                const double tan_half = std::tan(half);
                const double lu = m3[0] * m3[0] + m3[3] * m3[3] + m3[6] * m3[6];
                const double lv = m3[1] * m3[1] + m3[4] * m3[4] + m3[7] * m3[7];
                const double lw = m3[2] * m3[2] + m3[5] * m3[5] + m3[8] * m3[8];
                cos_half_larger_spread_ = 1.0 / std::sqrt(1.0 + tan_half * tan_half * std::max(lu, lv) / lw);
            }
            break;
        }
        case LightType::Sun: {
            co_ = normalize(to_vec(d.direction));
            half_angle_ = 0.5 * std::max(0.0, d.angle);
            if (half_angle_ > 0) {
                one_minus_cos_ = 2.0 * sqr(std::sin(0.5 * half_angle_));
                sun_pdf_ = 1.0 / (kTwoPi * one_minus_cos_);
                eval_fac = RGB(d.normalize ? 1.0 / (kPi * sqr(std::sin(half_angle_))) : 1.0);
            } else {
                sun_pdf_ = 1.0;
                eval_fac = RGB(1.0);
            }
            use_mis_ = d.use_mis && half_angle_ > 0;
            break;
        }
        case LightType::Area: {
            const auto& m = d.matrix_world;
            co_ = Vec3{m[3], m[7], m[11]};
            const Vec3 cu{m[0], m[4], m[8]}, cv{m[1], m[5], m[9]}, cw{m[2], m[6], m[10]};
            const bool square = d.shape == AreaShape::Square || d.shape == AreaShape::Disk;
            ellipse_ = d.shape == AreaShape::Disk || d.shape == AreaShape::Ellipse;
            len_u_ = length(cu) * d.size_x;
            len_v_ = length(cv) * (square ? d.size_x : d.size_y);
            axis_u_ = normalize(cu);
            axis_v_ = normalize(cv);
            normal_ = normalize(-1.0 * cw);
            area_ = len_u_ * len_v_ * (ellipse_ ? kPi / 4 : 1.0);
            if (!(area_ > 0)) contributes_ = false;
            eval_fac = RGB((d.normalize && area_ > 0 ? 1.0 / area_ : 1.0) / kPi);
            const double half_spread = 0.5 * std::max(0.0, d.spread);
            full_spread_ = d.spread >= kPi;
            if (!full_spread_) {
                tan_half_spread_ = std::tan(half_spread);
                normalize_spread_ = half_spread > 0.05 ? 1.0 / (tan_half_spread_ - half_spread)
                                                       : (half_spread > 0 ? 3.0 / std::pow(half_spread, 3.0) : 0.0);
                if (!(half_spread > 0)) contributes_ = false;  // a collimated light: Cycles' result is ~0
            }
            use_mis_ = d.use_mis && d.spread > 0;
            break;
        }
    }
    radiance_ = d.strength * eval_fac;
    make_tree_emitter(&d);
}

void Light::make_tree_emitter(const LightDesc* desc, int map_resolution, bool tree_energy) {
    LightTreeEmitter& e = tree_;
    auto avg_abs = [](RGB c) { return (std::fabs(c.r) + std::fabs(c.g) + std::fabs(c.b)) / 3.0; };
    if (world_) {
        // Cycles (scene/light.cpp, device_update_background; light_tree.cpp): E = pi x the
        // importance map's average radiance x the shader's emission estimate (the Background
        // strength, counted twice as Cycles does; avg(weight), exact for one Background node).
        // The map: the world at the pixel centres of a res_x x res_y latitude-longitude grid (row i
        // at polar angle pi (i + 0.5) / res_y from the zenith, column j at azimuth
        // pi - 2 pi (j + 0.5) / res_x, so an unmapped texture is read at its texel centres), its
        // average |radiance| weighted by sin(theta) over res_x res_y, times pi / 2. Resolution:
        // World > Settings > Map Resolution (res x res / 2) when set, else the texture's size
        // (Cycles' automatic choice), else 1024 x 512.
        e.kind = LightTreeEmitter::Kind::World;
        e.measure.cone = {{0, 0, 1}, kPi, 0.0};
        if (!tree_energy) return;
        int nx = map_resolution > 0 ? map_resolution : (environment_ ? environment_->width() : 0);
        int ny = map_resolution > 0 ? map_resolution / 2 : (environment_ ? environment_->height() : 0);
        if (nx <= 0 || ny <= 0) {
            nx = 1024;
            ny = 512;
        }
        // The columns' (cos, sin) of the azimuth once, not per row (the same numbers).
        std::vector<std::array<double, 2>> azimuth(static_cast<size_t>(nx));
        for (int j = 0; j < nx; ++j) {
            const double phi = kPi - kTwoPi * (j + 0.5) / nx;
            azimuth[size_t(j)] = {std::cos(phi), std::sin(phi)};
        }
        double sum = 0;
        for (int i = 0; i < ny; ++i) {
            const double theta = kPi * (i + 0.5) / ny, st = std::sin(theta), ct = std::cos(theta);
            double row = 0;
            for (int j = 0; j < nx; ++j) {
                LightHit h;
                eval_direction({st * azimuth[size_t(j)][0], st * azimuth[size_t(j)][1], ct}, h);
                row += avg_abs(h.radiance);
            }
            sum += st * row;
        }
        const double average_radiance = sum / (double(nx) * double(ny)) * (kPi / 2);
        const double estimate = environment_ ? avg_abs(environment_->weight()) : 1.0;
        e.measure.energy = kPi * average_radiance * estimate;
        return;
    }
    const LightDesc& d = *desc;
    const double strength = avg_abs(d.strength);
    switch (d.type) {
        case LightType::Point:
        case LightType::Spot: {
            e.kind = d.type == LightType::Point ? LightTreeEmitter::Kind::Point : LightTreeEmitter::Kind::Spot;
            e.position = e.centroid = co_;
            e.radius = radius_;
            e.sphere = sphere_;
            const double area = radius_ > 0 ? 4.0 * kPi * radius_ * radius_ : 4.0;
            e.measure.energy = strength / (4.0 * kPi) * (d.normalize ? 1.0 : area);
            e.measure.bbox.grow(co_ - Vec3{radius_, radius_, radius_});
            e.measure.bbox.grow(co_ + Vec3{radius_, radius_, radius_});
            if (d.type == LightType::Point) {
                e.measure.cone = {{0, 0, 1}, kPi, kPi / 2};  // axis irrelevant with theta_o = pi
                e.spot_dir = {0, 0, 1};
            } else {
                e.spot_dir = spot_dir_;
                e.spot_smooth = spot_smooth_;
                const double t = std::min(0.5 * d.spot_size, kPi / 2);
                double theta_e = kPi / 2;
                if (std::fabs(kPi / 2 - t) >= 1e-6) {
                    double lu = 1, lv = 1, lw = 1;
                    if (d.has_matrix) {
                        const auto& m = d.matrix_world;
                        lu = m[0] * m[0] + m[4] * m[4] + m[8] * m[8];
                        lv = m[1] * m[1] + m[5] * m[5] + m[9] * m[9];
                        lw = m[2] * m[2] + m[6] * m[6] + m[10] * m[10];
                    }
                    theta_e = std::atan(std::tan(t) * std::sqrt(std::max(lu, lv)) / std::sqrt(lw));
                }
                e.measure.cone = {spot_dir_, 0.0, theta_e};
            }
            break;
        }
        case LightType::Sun: {
            e.kind = LightTreeEmitter::Kind::Sun;
            e.to_sun = co_;
            const double area = half_angle_ > 0 ? kPi * sqr(std::sin(half_angle_)) : 1.0;
            e.measure.energy = strength * (d.normalize ? 1.0 : area);
            e.measure.cone = {-1.0 * co_, 0.0, half_angle_};
            break;
        }
        case LightType::Area: {
            e.kind = LightTreeEmitter::Kind::Area;
            e.position = e.centroid = co_;
            e.normal = normal_;
            e.extent_u = len_u_ * axis_u_;
            e.extent_v = len_v_ * axis_v_;
            for (int i = 0; i < 4; ++i)
                e.measure.bbox.grow(co_ + ((i & 1) ? 0.5 : -0.5) * e.extent_u + ((i & 2) ? 0.5 : -0.5) * e.extent_v);
            e.measure.energy = strength / kPi * (d.normalize ? 1.0 : area_);
            e.measure.cone = {normal_, 0.0, 0.5 * std::min(std::max(0.0, d.spread), kPi)};
            break;
        }
    }
}

double Light::spot_attenuation(Vec3 from_light) const {
    const auto& m = spot_inv_;
    Vec3 l{m[0] * from_light.x + m[1] * from_light.y + m[2] * from_light.z,
           m[3] * from_light.x + m[4] * from_light.y + m[5] * from_light.z,
           m[6] * from_light.x + m[7] * from_light.y + m[8] * from_light.z};
    l = normalize(l);
    const double a = smoothstep((-l.z - cos_half_spot_) * spot_smooth_);
    // Cycles 3.x (spot_light_attenuation): dot(axis, dir) times the smoothstep blend.
    return spot_cosine_ ? a * std::max(0.0, -l.z) : a;
}

double Light::spread_attenuation(Vec3 to_light) const {
    if (full_spread_) return 1.0;
    const double c = -dot(to_light, normal_);
    if (!(c > 0)) return 0.0;
    const double tan_a = std::sqrt(std::max(0.0, 1.0 - c * c)) / c;
    return std::max((tan_half_spread_ - tan_a) * normalize_spread_, 0.0);
}

bool Light::sample(Vec3 p, double u0, double u1, LightSample& out) const {
    if (!contributes_) return false;
    if (triangle_ >= 0) return sample_triangle(p, u0, u1, out);
    out.use_mis = use_mis_;
    if (world_) {
        out.distance = kInf;
        if (environment_) {
            out.wi = environment_->sample(u0, u1, out.pdf);
            out.radiance = radiance_ + environment_->eval(out.wi);
        } else {
            out.wi = sample_uniform_sphere(u0, u1);
            out.radiance = radiance_;
            out.pdf = 1.0 / (4.0 * kPi);
        }
        return out.pdf > 0;
    }
    switch (type_) {
        case LightType::Sun: {
            out.distance = kInf;
            out.radiance = radiance_;
            out.pdf = sun_pdf_;
            out.wi = half_angle_ > 0 ? sample_uniform_cone(co_, one_minus_cos_, u0, u1) : co_;
            return true;
        }
        case LightType::Point:
        case LightType::Spot: {
            const Vec3 to_p = p - co_;
            const double d2 = dot(to_p, to_p), d = std::sqrt(d2);
            if (!(d > 0)) return false;
            const Vec3 light_n = (1.0 / d) * to_p;
            const double r2 = radius_ * radius_;
            double attenuation = 1.0;
            if (sphere_) {
                if (d2 > r2) {
                    const double omc_sphere = sin_sqr_to_one_minus_cos(r2 / d2);
                    const double omc_spread = 1.0 - cos_half_larger_spread_;
                    if (type_ == LightType::Spot && omc_spread < omc_sphere) {
                        // The spread cone is narrower than the sphere: sample it, keep hits.
                        out.wi = sample_uniform_cone(-1.0 * spot_dir_, omc_spread, u0, u1);
                        double t;
                        if (!ray_sphere(p, out.wi, 0.0, kInf, co_, radius_, t)) return false;
                        out.distance = t;
                        out.pdf = 1.0 / (kTwoPi * omc_spread);
                    } else {
                        out.wi = sample_uniform_cone(-1.0 * light_n, omc_sphere, u0, u1);
                        const double cos_t = -dot(out.wi, light_n);
                        out.distance = d * cos_t - std::sqrt(std::max(0.0, r2 - d2 + d2 * cos_t * cos_t));
                        out.pdf = 1.0 / (kTwoPi * omc_sphere);
                    }
                    if (type_ == LightType::Spot) attenuation = spot_attenuation(-1.0 * out.wi);
                } else {
                    // Inside the sphere: uniform directions (Cycles: cosine or uniform; any
                    // density gives the same expected value), no spot attenuation.
                    out.wi = sample_uniform_sphere(u0, u1);
                    const double cos_t = -dot(out.wi, light_n);
                    out.distance = d * cos_t + std::sqrt(std::max(0.0, r2 - d2 + d2 * cos_t * cos_t));
                    out.pdf = 1.0 / (4.0 * kPi);
                }
            } else {
                // Point light, or a disk of radius r facing the shading point.
                Vec3 pl = co_;
                if (radius_ > 0) {
                    double x, y;
                    sample_concentric_disk(u0, u1, x, y);
                    Vec3 a, b;
                    make_orthonormals(light_n, a, b);
                    pl = pl + (radius_ * x) * a + (radius_ * y) * b;
                }
                const Vec3 dv = pl - p;
                const double t = length(dv);
                if (!(t > 0)) return false;
                out.wi = (1.0 / t) * dv;
                out.distance = t;
                const double cos_l = dot(light_n, -1.0 * out.wi);
                if (!(cos_l > 0)) return false;
                const double invarea = radius_ > 0 ? 1.0 / (kPi * r2) : 1.0;
                out.pdf = invarea * t * t / cos_l;
                if (type_ == LightType::Spot) attenuation = spot_attenuation(-1.0 * out.wi);
            }
            if (!(attenuation > 0)) return false;
            out.radiance = attenuation * radiance_;
            return out.pdf > 0;
        }
        case LightType::Area: {
            if (dot(co_ - p, normal_) > 0) return false;  // behind the one-sided light
            const RectangleView view = solid_angle_rectangle(p);
            if (view.unreachable) return false;
            if (const auto& rect = view.rectangle) {
                const Vec3 dv = rect->sample(u0, u1) - p;
                const double t = length(dv);
                if (!(t > 0)) return false;
                out.wi = (1.0 / t) * dv;
                out.distance = t;
                if (!(-dot(normal_, out.wi) > 0)) return false;
                const double att = spread_attenuation(out.wi);
                if (!(att > 0)) return false;
                out.pdf = 1.0 / rect->solid_angle;
                out.radiance = att * radiance_;
                return true;
            }
            double x, y;
            if (ellipse_) {
                sample_concentric_disk(u0, u1, x, y);
            } else {
                x = 2.0 * u0 - 1.0;
                y = 2.0 * u1 - 1.0;
            }
            const Vec3 pl = co_ + (0.5 * len_u_ * x) * axis_u_ + (0.5 * len_v_ * y) * axis_v_;
            const Vec3 dv = pl - p;
            const double t = length(dv);
            if (!(t > 0)) return false;
            out.wi = (1.0 / t) * dv;
            out.distance = t;
            const double cos_l = -dot(normal_, out.wi);
            if (!(cos_l > 0)) return false;
            out.pdf = t * t / (cos_l * area_);
            const double att = spread_attenuation(out.wi);
            if (!(att > 0)) return false;
            out.radiance = att * radiance_;
            return true;
        }
    }
    return false;
}

bool Light::intersect(const Ray& ray, double tmax, LightHit& out) const {
    if (!contributes_ || world_ || triangle_ >= 0) return false;
    switch (type_) {
        case LightType::Sun:
            return false;
        case LightType::Point:
        case LightType::Spot: {
            if (!(radius_ > 0)) return false;
            const Vec3 to_o = ray.org - co_;
            if (type_ == LightType::Spot && dot(ray.dir, to_o) >= 0) return false;  // one-sided
            const double d2 = dot(to_o, to_o), r2 = radius_ * radius_;
            double t;
            if (sphere_) {
                if (!ray_sphere(ray.org, ray.dir, ray.tmin, tmax, co_, radius_, t)) return false;
                double att = 1.0;
                if (d2 > r2) {
                    double omc = sin_sqr_to_one_minus_cos(r2 / d2);
                    if (type_ == LightType::Spot) {
                        omc = std::min(omc, 1.0 - cos_half_larger_spread_);
                        att = spot_attenuation(-1.0 * ray.dir);
                    }
                    out.pdf = 1.0 / (kTwoPi * omc);
                } else {
                    out.pdf = 1.0 / (4.0 * kPi);
                }
                if (!(att > 0)) return false;
                out.radiance = att * radiance_;
            } else {
                const Vec3 n = normalize(to_o);
                const double denom = dot(ray.dir, n);
                if (!(denom < 0)) return false;
                t = dot(co_ - ray.org, n) / denom;
                if (!(t > ray.tmin && t < tmax)) return false;
                const Vec3 hp = ray.org + t * ray.dir;
                if (dot(hp - co_, hp - co_) > r2) return false;
                out.pdf = t * t / (kPi * r2 * -denom);
                const double att = type_ == LightType::Spot ? spot_attenuation(-1.0 * ray.dir) : 1.0;
                if (!(att > 0)) return false;
                out.radiance = att * radiance_;
            }
            out.t = t;
            return true;
        }
        case LightType::Area: {
            const double denom = dot(ray.dir, normal_);
            if (!(denom < 0)) return false;  // one-sided
            const double t = dot(co_ - ray.org, normal_) / denom;
            if (!(t > ray.tmin && t < tmax)) return false;
            const Vec3 hp = ray.org + t * ray.dir - co_;
            const double x = dot(hp, axis_u_) / (0.5 * len_u_), y = dot(hp, axis_v_) / (0.5 * len_v_);
            if (ellipse_ ? (x * x + y * y > 1.0) : (std::fabs(x) > 1.0 || std::fabs(y) > 1.0)) return false;
            const double att = spread_attenuation(ray.dir);
            if (!(att > 0)) return false;
            out.t = t;
            out.pdf = t * t / (-denom * area_);
            if (const auto& rect = solid_angle_rectangle(ray.org).rectangle) out.pdf = 1.0 / rect->solid_angle;
            out.radiance = att * radiance_;
            return true;
        }
    }
    return false;
}

bool Light::eval_direction(Vec3 dir, LightHit& out) const {
    if (!contributes_ || triangle_ >= 0) return false;
    if (world_) {
        out.t = kInf;
        out.radiance = environment_ ? radiance_ + environment_->eval(dir) : radiance_;
        out.pdf = environment_ ? environment_->pdf(dir) : 1.0 / (4.0 * kPi);
        return true;
    }
    if (type_ != LightType::Sun || !(half_angle_ > 0)) return false;
    if (dot(dir, co_) < std::cos(half_angle_)) return false;
    out.t = kInf;
    out.radiance = radiance_;
    out.pdf = sun_pdf_;
    return true;
}


// ---------------------------------------------------------------------------------------
// Emissive triangles (Cycles' mesh lights, kernel/light/triangle.h)

Light::Light(const TriangleLightDesc& t) : triangle_(t.prim) {
    tri_v_[0] = t.v0;
    tri_v_[1] = t.v1;
    tri_v_[2] = t.v2;
    tri_front_ = t.front;
    tri_back_ = t.back;
    const Vec3 n = cross(t.v1 - t.v0, t.v2 - t.v0);
    area_ = 0.5 * length(n);
    contributes_ = area_ > 0 && (t.front || t.back);
    use_mis_ = true;           // Cycles sets SHADER_USE_MIS on every triangle light sample
    visible_camera_ = false;   // found by the BVH, not by LightSet::intersect
    LightTreeEmitter& e = tree_;
    e.kind = LightTreeEmitter::Kind::Triangle;
    e.object = t.object;
    for (int k = 0; k < 3; ++k) e.measure.bbox.grow(tri_v_[k]);
    e.position = e.centroid = (1.0 / 3.0) * (t.v0 + t.v1 + t.v2);
    e.tri_v[0] = t.v0;
    e.tri_v[1] = t.v1;
    e.tri_v[2] = t.v2;
    e.measure.energy = area_ * t.estimate;
    if (t.front != t.back) {
        // One-sided: the normal (reversed for Back), emitting into a hemisphere.
        const Vec3 axis = normalize(n);
        e.measure.cone = {t.front ? axis : -1.0 * axis, 0.0, kPi / 2};
    } else {
        // Two-sided: any axis in the plane, theta_o = pi / 2.
        e.measure.cone = {normalize(t.v0 - t.v1), kPi / 2, kPi / 2};
    }
}

bool Light::triangle_uses_solid_angle(Vec3 p) const {
    // Cycles' heuristic, kept literally: the longest edge against the distance to the plane
    // divided by |N| (N the unnormalised cross product, so the "distance" is dist / (2 area)).
    const Vec3 e0 = tri_v_[1] - tri_v_[0], e1 = tri_v_[2] - tri_v_[0], e2 = tri_v_[2] - tri_v_[1];
    const double longest2 = std::max(dot(e0, e0), std::max(dot(e1, e1), dot(e2, e2)));
    const Vec3 n = cross(e0, e1);
    const double d = dot(n, tri_v_[0] - p) / dot(n, n);
    return longest2 > d * d;
}

namespace {

// Solid angle of the spherical triangle of unit vectors a, b, c (Van Oosterom and Strackee).
double spherical_triangle_area(Vec3 a, Vec3 b, Vec3 c) {
    return 2.0 * std::atan2(std::fabs(dot(a, cross(b, c))), 1.0 + dot(b, c) + dot(a, c) + dot(a, b));
}

Vec3 safe_unit(Vec3 v) {
    const double l = length(v);
    return l > 0 ? (1.0 / l) * v : Vec3{0, 0, 0};
}

// Moeller-Trumbore: distance and barycentrics (of v1, v2) where the ray meets the triangle.
bool ray_triangle(Vec3 o, Vec3 d, Vec3 v0, Vec3 v1, Vec3 v2, double& t, double& u, double& v) {
    const Vec3 e1 = v1 - v0, e2 = v2 - v0, pv = cross(d, e2);
    const double det = dot(e1, pv);
    if (det == 0) return false;
    const double inv = 1.0 / det;
    const Vec3 tv = o - v0;
    u = dot(tv, pv) * inv;
    const Vec3 qv = cross(tv, e1);
    v = dot(d, qv) * inv;
    t = dot(e2, qv) * inv;
    const double eps = 1e-9;
    return u >= -eps && v >= -eps && u + v <= 1.0 + eps && t > 0;
}

}  // namespace

bool Light::sample_triangle(Vec3 p, double u0, double u1, LightSample& out) const {
    const Vec3 n = cross(tri_v_[1] - tri_v_[0], tri_v_[2] - tri_v_[0]);
    // Only the sides with Emission Sampling are sampled (Cycles 4.x); p behind N sees the back.
    const bool back = dot(n, tri_v_[0] - p) > 0;
    if (!samples_side(back)) return false;
    out.use_mis = true;
    out.triangle = triangle_;
    out.radiance = RGB(0.0);
    if (triangle_uses_solid_angle(p)) {
        // Uniform in the solid angle (Arvo 1995, "Stratified Sampling of Spherical Triangles").
        const Vec3 A = safe_unit(tri_v_[0] - p), B = safe_unit(tri_v_[1] - p), C = safe_unit(tri_v_[2] - p);
        const double solid_angle = spherical_triangle_area(A, B, C);
        if (!(solid_angle > 0)) return false;
        const double cos_alpha = std::clamp(dot(safe_unit(cross(A, B)), safe_unit(cross(A, C))), -1.0, 1.0);
        const double alpha = std::acos(cos_alpha), sin_alpha = std::sqrt(std::max(0.0, 1.0 - cos_alpha * cos_alpha));
        const double area_hat = u0 * solid_angle;
        const double s = std::sin(area_hat - alpha), c = std::cos(area_hat - alpha);
        const double uu = c - cos_alpha, vv = s + sin_alpha * dot(A, B);
        const double den = (vv * s + uu * c) * sin_alpha;
        const double q = den == 0 ? 1.0 : std::clamp(((vv * c - uu * s) * cos_alpha - vv) / den, -1.0, 1.0);
        const Vec3 U = safe_unit(C - dot(C, A) * A);
        const Vec3 C2 = safe_unit(q * A + std::sqrt(std::max(0.0, 1.0 - q * q)) * U);
        const double z = 1.0 - u1 * (1.0 - dot(C2, B));
        out.wi = safe_unit(z * B + std::sqrt(std::max(0.0, 1.0 - z * z)) * safe_unit(C2 - dot(C2, B) * B));
        double t, bu, bv;
        if (!ray_triangle(p, out.wi, tri_v_[0], tri_v_[1], tri_v_[2], t, bu, bv)) return false;
        out.distance = t;
        out.u = std::clamp(bu, 0.0, 1.0);
        out.v = std::clamp(bv, 0.0, 1.0 - out.u);
        out.pdf = 1.0 / solid_angle;
        return true;
    }
    // Uniform in area (Heitz 2019, "A Low-Distortion Map Between Triangle and Square").
    double bu = u0, bv = u1;
    if (bv > bu) {
        bu *= 0.5;
        bv -= bu;
    } else {
        bv *= 0.5;
        bu -= bv;
    }
    const Vec3 pl = (1.0 - bu - bv) * tri_v_[0] + bu * tri_v_[1] + bv * tri_v_[2];
    const Vec3 dv = pl - p;
    const double t = length(dv);
    if (!(t > 0)) return false;
    out.wi = (1.0 / t) * dv;
    out.distance = t;
    out.u = bu;
    out.v = bv;
    const double cos_l = std::fabs(dot(normalize(n), out.wi));
    if (!(cos_l > 0)) return false;
    out.pdf = t * t / (cos_l * area_);
    return true;
}

double Light::triangle_pdf(Vec3 origin, Vec3 on_light) const {
    if (triangle_uses_solid_angle(origin)) {
        const double sa = spherical_triangle_area(safe_unit(tri_v_[0] - origin), safe_unit(tri_v_[1] - origin),
                                                  safe_unit(tri_v_[2] - origin));
        return sa > 0 ? 1.0 / sa : 0.0;
    }
    const Vec3 n = normalize(cross(tri_v_[1] - tri_v_[0], tri_v_[2] - tri_v_[0]));
    const Vec3 d = on_light - origin;
    const double t2 = dot(d, d);
    const double cos_l = std::fabs(dot(n, d)) / std::sqrt(t2);
    return cos_l > 0 && area_ > 0 ? t2 / (cos_l * area_) : 0.0;
}

LightSet::LightSet(const SceneDesc& scene) {
    for (const LightDesc& d : scene.lights) {
        Light l(d);
        if (!l.has_contribution()) continue;
        if (d.type != LightType::Sun) {
            if (l.use_mis()) has_finite_mis_ = true;
            if (((d.type == LightType::Area) || d.radius > 0) && d.visible_camera) has_finite_camera_ = true;
        }
        lights_.push_back(l);
    }
    Light world(scene.world, scene.world_texture, scene.world_mis, scene.world_map_resolution, scene.integrator.light_tree);
    if (world.has_contribution()) {
        if (world.use_mis()) {
            world_ = int(lights_.size());
            lights_.push_back(world);
        } else {
            background_ = std::make_shared<const Light>(world);
        }
    }
    lamps_ = lights_.size();
    add_triangle_lights(scene);
    const size_t triangles = lights_.size() - lamps_;
    lamp_share_ = triangles == 0 ? 1.0 : (lamps_ == 0 ? 0.0 : 0.5);
    if (scene.integrator.light_tree && !lights_.empty()) {
        std::vector<LightTreeEmitter> emitters;
        for (const Light& l : lights_) emitters.push_back(l.tree_emitter());
        tree_ = std::make_shared<const LightTree>(std::move(emitters), mesh_object_centers(scene.meshes));
    }
}

EmissionSampling resolved_emission_sampling(const MaterialDesc& m, double& estimate) {
    // Cycles' emission estimate (scene/shader.cpp, output_estimate_emission): colour x strength of
    // each Emission closure; a linked colour counts as 1, and so does a linked strength (the node
    // feeding it has a non-closure output, which Cycles estimates as 1).
    RGB e(0.0);
    bool any = false;
    for (const ClosureDesc& c : m.closures) {
        if (c.type != ClosureDesc::Type::Emission) continue;
        any = true;
        bool color_linked = false, strength_linked = false;
        for (const ClosureDesc::Link& l : c.links) {
            color_linked |= l.input == ClosureDesc::Input::Color;
            strength_linked |= l.input == ClosureDesc::Input::Strength;
        }
        e += (strength_linked ? 1.0 : c.strength) * (c.weight * (color_linked ? RGB(1.0) : c.color));
    }
    estimate = (std::fabs(e.r) + std::fabs(e.g) + std::fabs(e.b)) / 3.0;
    if (!any) return EmissionSampling::None;
    if (m.emission_sampling != EmissionSampling::Auto) return m.emission_sampling;
    const double largest = std::max(std::fabs(e.r), std::max(std::fabs(e.g), std::fabs(e.b)));
    return largest > 0.5 ? EmissionSampling::FrontBack : EmissionSampling::None;
}

std::vector<std::pair<int, Vec3>> mesh_object_centers(const MeshData& md) {
    // Cycles' mesh-light centroid: the centre of the object's bounding box (all its triangles).
    std::vector<std::pair<int, LightTreeBBox>> boxes;
    for (size_t t = 0; t < md.triangles.size(); ++t) {
        const int obj = md.object.size() == md.triangles.size() ? md.object[t] : 0;
        auto it = std::find_if(boxes.begin(), boxes.end(), [&](const auto& b) { return b.first == obj; });
        if (it == boxes.end()) {
            boxes.push_back({obj, LightTreeBBox{}});
            it = boxes.end() - 1;
        }
        for (int k = 0; k < 3; ++k) it->second.grow(to_vec3(md.vertices[size_t(md.triangles[t][size_t(k)])]));
    }
    std::vector<std::pair<int, Vec3>> out;
    for (const auto& b : boxes) out.push_back({b.first, b.second.center()});
    return out;
}

void LightSet::add_triangle_lights(const SceneDesc& scene) {
    const MeshData& md = scene.meshes;
    std::vector<EmissionSampling> sampling(scene.materials.size());
    std::vector<double> estimate(scene.materials.size(), 0.0);
    bool any = false;
    for (size_t m = 0; m < scene.materials.size(); ++m) {
        sampling[m] = resolved_emission_sampling(scene.materials[m], estimate[m]);
        any |= sampling[m] != EmissionSampling::None;
    }
    if (!any) return;
    triangle_light_.assign(md.triangles.size(), -1);
    for (size_t t = 0; t < md.triangles.size(); ++t) {
        const int32_t m = t < md.material.size() ? md.material[t] : -1;
        if (m < 0 || size_t(m) >= sampling.size() || sampling[size_t(m)] == EmissionSampling::None) continue;
        TriangleLightDesc d;
        d.v0 = to_vec3(md.vertices[size_t(md.triangles[t][0])]);
        d.v1 = to_vec3(md.vertices[size_t(md.triangles[t][1])]);
        d.v2 = to_vec3(md.vertices[size_t(md.triangles[t][2])]);
        d.prim = int(t);
        d.object = md.object.size() == md.triangles.size() ? md.object[t] : 0;
        const EmissionSampling es = sampling[size_t(m)];
        d.front = es == EmissionSampling::Front || es == EmissionSampling::FrontBack;
        d.back = es == EmissionSampling::Back || es == EmissionSampling::FrontBack;
        d.estimate = estimate[size_t(m)];
        Light l(d);
        if (!l.has_contribution()) continue;
        triangle_light_[t] = int(lights_.size());
        triangle_area_total_ += l.triangle_area();
        triangle_cdf_.push_back(triangle_area_total_);
        lights_.push_back(l);
    }
}

bool LightSet::sample(const LightPickContext& at, double u_select, double u0, double u1, LightSample& out) const {
    if (lights_.empty()) return false;
    size_t i;
    double selection;
    if (tree_) {
        const int k = tree_->sample(at.p, at.n, at.transmission, u_select, selection);
        if (k < 0 || !(selection > 0)) return false;  // no light has importance: the sample is lost
        i = size_t(k);
    } else if (u_select < lamp_share_) {
        // Cycles 3.x's distribution: a lamp, uniformly.
        i = std::min(size_t(u_select / lamp_share_ * double(lamps_)), lamps_ - 1);
        selection = lamp_share_ / double(lamps_);
    } else {
        // ... or an emissive triangle by area.
        const double target = (u_select - lamp_share_) / (1.0 - lamp_share_) * triangle_area_total_;
        const size_t k = std::min(size_t(std::upper_bound(triangle_cdf_.begin(), triangle_cdf_.end(), target) -
                                         triangle_cdf_.begin()),
                                  triangle_cdf_.size() - 1);
        i = lamps_ + k;
        selection = (1.0 - lamp_share_) * lights_[i].triangle_area() / triangle_area_total_;
    }
    if (!lights_[i].sample(at.p, u0, u1, out)) return false;
    out.pdf *= selection;
    return out.pdf > 0 && std::isfinite(out.pdf);
}

int LightSet::intersect(const Ray& ray, double tmax, bool camera_ray, LightHit* hits, int max_hits) const {
    int n = 0;
    for (size_t i = 0; i < lamps_; ++i) {
        const Light& l = lights_[i];
        if (l.is_distant() || (!camera_ray && !l.use_mis()) || (camera_ray && !l.visible_camera())) continue;
        LightHit h;
        if (!l.intersect(ray, tmax, h)) continue;
        if (!(h.t > ray.tmin)) continue;  // before a transparent hit the ray went on from
        h.light = int(i);
        if (n < max_hits) {
            hits[n++] = h;
        } else {
            // keep the closest max_hits
            int far = 0;
            for (int k = 1; k < n; ++k)
                if (hits[k].t > hits[far].t) far = k;
            if (h.t < hits[far].t) hits[far] = h;
        }
    }
    std::sort(hits, hits + n, [](const LightHit& a, const LightHit& b) { return a.t < b.t; });
    return n;
}

int LightSet::eval_suns(Vec3 dir, bool camera_ray, LightHit* hits, int max_hits) const {
    int n = 0;
    for (size_t i = 0; i < lamps_ && n < max_hits; ++i) {
        const Light& l = lights_[i];
        // Cycles intersects sun discs only for MIS suns, camera rays included (when visible).
        if (l.is_world() || !l.is_distant() || !l.use_mis() || (camera_ray && !l.visible_camera())) continue;
        LightHit h;
        if (!l.eval_direction(dir, h)) continue;
        h.light = int(i);
        hits[n++] = h;
    }
    return n;
}

}  // namespace hairbsdf::render
