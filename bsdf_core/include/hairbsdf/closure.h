// The OSL-style closure interface: a shading context, per-lobe evaluation results,
// samples, and weighted sums of closures. Conventions: docs/conventions.md.
#pragma once

#include <array>
#include <variant>
#include <vector>

#include "hairbsdf/math.h"

namespace hairbsdf {

enum class RayType { Camera, Reflection, Transmission, Shadow };

// The role of OSL's ShaderGlobals for one hair hit. All directions share one space
// (world space in the renderer, the fibre frame in the Python API).
struct ShadingContext {
    Vec3 tangent{1, 0, 0};  // unit fibre tangent, root to tip
    Vec3 wo{0, 0, 1};       // unit direction towards the viewer
    double h = 0;           // offset across the fibre in [-1, 1], gamma_o = asin(h)
    RayType ray_type = RayType::Camera;
    double random = 0;      // per-strand random ("Hair Info > Random")
    // Optional per-sample fields used by the Huang model only (Chiang ignores them); the
    // defaults give Cycles' behaviour for a non-camera ray on particle hair. docs/huang.md §1.
    Vec3 normal{0, 0, 0};       // curve normal = ellipse major axis; zero: Cycles' fallback frame
    double pixel_coverage = 1;  // half a pixel's footprint at the hit, in units of the radius (0.5 dP / r)
    bool near_field = false;    // allow the near field (Cycles: camera rays hitting curves)
    // Optional field used by the Epic model's multiple-scattering term only (docs/models.md §2):
    // the light's visibility through the hair volume estimated by the engine (Karis 2016's
    // "Shadow", deep-opacity / shadow-map fraction), 1 = unoccluded (the default), 0 = fully in
    // the hair's shadow.
    double shadow = 1;
    // Optional fields of surfaces in the renderer (the diffuse model and the legacy Hair BSDF's
    // reflection test): the hit's shading normal N and geometric normal Ng, on the viewer's side;
    // zero: the model's own choice.
    Vec3 shading_normal{0, 0, 0};
    Vec3 geometric_normal{0, 0, 0};
};

// R, TT, TRT, TRRT+ (Chiang), then the medulla-scattered TTs and TRTs of yan_fur (docs/models.md §7);
// models with fewer lobes leave the rest 0. Python's eval_lobes reports the first
// kChiangLobeCount slots unless a yan_fur closure is present.
constexpr int kLobeCount = 6;
constexpr int kChiangLobeCount = 4;
enum Lobe { LobeR = 0, LobeTT = 1, LobeTRT = 2, LobeTRRT = 3, LobeTTs = 4, LobeTRTs = 5 };

inline RGB sum_of_lobes(const std::array<RGB, kLobeCount>& lobes) {
    RGB sum = lobes[0];
    for (int p = 1; p < kLobeCount; ++p) sum += lobes[size_t(p)];
    return sum;
}

// What a sampled direction is to the renderer (Cycles' LABEL_*): reflection or transmission,
// and its bounce class, diffuse or glossy (the path's bounce budgets); transparent: straight on.
enum ScatterLabel : uint8_t {
    LabelNone = 0, LabelReflect = 1, LabelTransmit = 2, LabelDiffuse = 4, LabelGlossy = 8, LabelTransparent = 16
};
// Hair lobes as Cycles labels Principled Hair's: R a glossy reflection, the others glossy transmissions.
inline uint8_t hair_lobe_label(int lobe) { return uint8_t(LabelGlossy | (lobe == LobeR ? LabelReflect : LabelTransmit)); }

// Value of a closure for one direction pair: per-lobe RGB values including the cosine
// factor, and the density `sample` reports for this direction.
struct BsdfEval {
    std::array<RGB, kLobeCount> lobes{};
    double pdf = 0;
    RGB value() const { return sum_of_lobes(lobes); }
};

// A sample as the renderer takes it from a model (closures.h, sample_at_hit): the direction,
// the value and per-lobe values there (without the closure weight; lobes only when asked), the
// pdf and lobe. `value_from_lobes`: the value is the sum of the weighted lobes (a stochastic
// eval's); `blur_pdf_one`: Filter Glossy sees pdf 1 (Cycles' Huang sampler reports 1).
struct ScatterSample {
    Vec3 wi{};
    RGB value{};
    std::array<RGB, 6> lobes{};
    double pdf = 0;
    int lobe = -1;  // -1: no sample
    bool value_from_lobes = false;
    bool blur_pdf_one = false;
};

struct BsdfSample {
    Vec3 wi{};
    RGB value{};   // eval at wi (including the cosine)
    RGB weight{};  // value / pdf
    double pdf = 0;
    int lobe = -1;  // -1: no sample (zero weight)
};

// The sample in direction wi from the closure's evaluation there (weight = value / pdf), or no
// sample when the pdf is not positive or anything is not finite.
inline BsdfSample sample_from_eval(Vec3 wi, const BsdfEval& e, int lobe) {
    BsdfSample out;
    const RGB value = e.value();
    const RGB weight = (1.0 / e.pdf) * value;
    if (!(e.pdf > 0) || !std::isfinite(e.pdf) || !isfinite(weight) || !isfinite(wi)) return out;
    out.wi = wi;
    out.value = value;
    out.pdf = e.pdf;
    out.weight = weight;
    out.lobe = lobe;
    return out;
}

// The per-shading-point frame Cycles uses for hair (docs/cycles.md §4.1):
// x = tangent, y = normalize(x × wo), z = x × y. The view direction sits at phi = -pi/2.
struct FibreFrame {
    Vec3 x, y, z;
    FibreFrame(Vec3 tangent, Vec3 wo) : x(tangent) {
        y = cross(x, wo);
        const double len = length(y);
        if (len > 1e-12) {
            y = (1.0 / len) * y;
        } else {  // wo along the fibre: any perpendicular will do
            y = normalize(std::fabs(x.x) < 0.9 ? cross(x, Vec3{1, 0, 0}) : cross(x, Vec3{0, 1, 0}));
        }
        z = cross(x, y);
    }
    double sin_theta(Vec3 w) const { return clamp(dot(w, x), -1.0, 1.0); }
    double phi(Vec3 w) const { return std::atan2(dot(w, z), dot(w, y)); }
    Vec3 direction(double sin_theta, double cos_theta, double phi) const {
        return sin_theta * x + (cos_theta * std::cos(phi)) * y + (cos_theta * std::sin(phi)) * z;
    }
};

}  // namespace hairbsdf
