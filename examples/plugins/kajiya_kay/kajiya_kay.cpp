// Kajiya-Kay hair (1989) as a hairbsdf plugin: a diffuse and a specular cone lobe, normalised so
// that the albedo never exceeds 1, with an exact-pdf sampler. Walk-through: docs/plugins.md.
//   eval = (1 - w) Kd cos(ti) / pi^2  +  w Ks cos^p(ti + to)+ cos(ti) / (2 pi J(p + 2)),
//   J(n) = integral of cos^n over [-pi/2, pi/2]: each lobe's albedo is <= 1 (= 1 at to = 0).
// Sampler: pick the specular lobe with P = w avg(Ks) / (w avg(Ks) + (1 - w) avg(Kd)); then
//   diffuse:  sin(ti) = x of a uniform point in the unit disk (density cos(ti) / pi^2),
//   specular: sin(ti) from a logistic density around the mirror cone sin(ti) = -sin(to),
//             scale b = cos(to) / sqrt(2p) + 1 / (2p), trimmed to [-1, 1];
//   phi uniform for both; pdf = the mixture of the two densities (per unit solid angle).
#include <hairbsdf/plugin.h>

#include <cmath>

namespace {
const double kPi = 3.14159265358979323846;
struct KK { double kd[3], ks[3], w, p, norm, pick; };  // norm = 1 / (2 pi J(p + 2)), pick = P

const hairbsdf_param kParams[] = {
    {"color", HAIRBSDF_PARAM_RGB, {0.6, 0.4, 0.25}, 0, 1, "diffuse colour Kd"},
    {"specular_color", HAIRBSDF_PARAM_RGB, {1, 1, 1}, 0, 1, "specular colour Ks"},
    {"specular", HAIRBSDF_PARAM_FLOAT, {0.3}, 0, 1, "weight w of the specular lobe"},
    {"exponent", HAIRBSDF_PARAM_FLOAT, {40}, 1, 10000, "Phong exponent p of the specular cone"}};

void* create(const double* v, char*, size_t) {
    const double w = v[6], p = v[9], s = w * (v[3] + v[4] + v[5]), d = (1 - w) * (v[0] + v[1] + v[2]);
    const double J = std::sqrt(kPi) * std::exp(std::lgamma(0.5 * (p + 3)) - std::lgamma(0.5 * p + 2));
    return new KK{{v[0], v[1], v[2]}, {v[3], v[4], v[5]}, w, p, 1 / (2 * kPi * J), s + d > 0 ? s / (s + d) : -1};
}
void destroy(void* m) { delete static_cast<KK*>(m); }

double cos_of(double s) { return std::sqrt(std::fmax(0.0, 1 - s * s)); }
double cdf(double x, double s0, double b) { return 1 / (1 + std::exp((s0 - x) / b)); }  // logistic
// Values of both lobes (RGB each) and the sampling density for sin(ti) = si.
double lobes(const KK& m, const double* wo, double si, double* spec, double* diff) {
    const double so = wo[0], co = cos_of(so), ci = cos_of(si), cone = std::fmax(ci * co - si * so, 0.0);
    const double fs = m.w * std::pow(cone, m.p) * ci * m.norm, fd = (1 - m.w) * ci / (kPi * kPi);
    for (int c = 0; c < 3; ++c) spec[c] = m.ks[c] * fs, diff[c] = m.kd[c] * fd;
    const double b = co / std::sqrt(2 * m.p) + 0.5 / m.p, s0 = -so, e = std::exp(-std::fabs(si - s0) / b);
    const double logistic = e / (b * (1 + e) * (1 + e) * (cdf(1, s0, b) - cdf(-1, s0, b)));  // trimmed
    return m.pick < 0 ? 0 : m.pick * logistic / (2 * kPi) + (1 - m.pick) * ci / (kPi * kPi);
}

int eval(const void* i, size_t n, const double* wo, const double* wi, const double*, const double*, double* value,
         double* lobe) {
    for (size_t k = 0; k < n; ++k) {
        double s[3], d[3], *l = lobe ? lobe + 12 * k : nullptr;
        lobes(*static_cast<const KK*>(i), wo + 3 * k, wi[3 * k], s, d);
        for (int c = 0; c < 3; ++c) value[3 * k + c] = s[c] + d[c];
        for (int c = 0; l && c < 12; ++c) l[c] = c < 3 ? s[c] : (c >= 9 ? d[c - 9] : 0);  // R and TRRT+
    }
    return 0;
}
int pdf(const void* i, size_t n, const double* wo, const double* wi, const double*, const double*, double* pdf) {
    double s[3], d[3];
    for (size_t k = 0; k < n; ++k) pdf[k] = lobes(*static_cast<const KK*>(i), wo + 3 * k, wi[3 * k], s, d);
    return 0;
}
int sample(const void* i, size_t n, const double* wo, const double*, const double*, const double* u, double* wi,
           double* weight, double* pdf, int32_t* lobe) {
    const KK& m = *static_cast<const KK*>(i);
    for (size_t k = 0; k < n; ++k) {
        const double *o = wo + 3 * k, *r = u + 3 * k;
        double si, s[3], d[3], *w = wi + 3 * k;
        lobe[k] = m.pick < 0 ? -1 : (r[2] < m.pick ? HAIRBSDF_LOBE_R : HAIRBSDF_LOBE_TRRT);
        if (lobe[k] == HAIRBSDF_LOBE_R) {  // invert the trimmed logistic CDF
            const double b = cos_of(o[0]) / std::sqrt(2 * m.p) + 0.5 / m.p, s0 = -o[0];
            const double lo = cdf(-1, s0, b), q = lo + (r[2] / m.pick) * (cdf(1, s0, b) - lo);
            si = s0 - b * std::log(1 / q - 1);
        } else {  // x of a uniform point in the unit disk
            si = std::sqrt(std::fmax(0.0, (r[2] - m.pick) / (1 - m.pick))) * std::cos(2 * kPi * r[1]);
        }
        si = std::fmin(1.0, std::fmax(-1.0, si));
        w[0] = si, w[1] = cos_of(si) * std::cos(2 * kPi * r[0]), w[2] = cos_of(si) * std::sin(2 * kPi * r[0]);
        pdf[k] = lobe[k] < 0 ? 0 : lobes(m, o, si, s, d);
        if (!(pdf[k] > 0)) lobe[k] = -1, pdf[k] = 0;
        for (int c = 0; c < 3; ++c) weight[3 * k + c] = lobe[k] < 0 ? 0 : (s[c] + d[c]) / pdf[k];
    }
    return 0;
}

const hairbsdf_plugin kPlugin = {HAIRBSDF_PLUGIN_ABI_VERSION, HAIRBSDF_PLUGIN_HAS_LOBES, "kajiya_kay",
                                 "Kajiya-Kay 1989, energy-normalised, with an exact-pdf sampler", 4, kParams,
                                 create, destroy, eval, sample, pdf};
}  // namespace

HAIRBSDF_PLUGIN_ENTRY { return host_abi_version == HAIRBSDF_PLUGIN_ABI_VERSION ? &kPlugin : nullptr; }
