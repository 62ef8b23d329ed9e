// A small plugin for plugin_test.cpp: a diffuse fibre with an azimuthal ripple,
//   eval = albedo * cos(theta_i) / pi^2 * (1 + ripple * cos(phi_i - phi_o)),
// whose albedo is `albedo` for every wo (the ripple integrates to 0 over phi). It is
// sampled with the ripple-free density cos(theta_i) / pi^2: sin(theta_i) is the x of a
// uniform point in the unit disk. Every row of eval reports the value as TRRT+.
// Compiled also with TEST_PLUGIN_ABI, TEST_PLUGIN_NO_ENTRY and TEST_PLUGIN_NULL_SAMPLE (broken
// libraries), TEST_PLUGIN_NAN (eval gives NaN at grazing wi), TEST_PLUGIN_FAIL (eval returns an
// error code for ripple < 0) and TEST_PLUGIN_BAD_RANGE (a schema whose range is empty); the
// Python tests build these (plugin/tests/test_plugins.py).
#include <cmath>
#include <cstdio>

#include "hairbsdf/plugin.h"

#ifndef TEST_PLUGIN_ABI
#define TEST_PLUGIN_ABI HAIRBSDF_PLUGIN_ABI_VERSION
#endif

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Instance {
    double albedo[3];
    double ripple;
};

const hairbsdf_param kParams[] = {
    {"albedo", HAIRBSDF_PARAM_RGB, {0.5, 0.5, 0.5}, 0.0, 1.0, "directional albedo"},
#ifdef TEST_PLUGIN_BAD_RANGE
    {"ripple", HAIRBSDF_PARAM_FLOAT, {0.5, 0, 0}, 1.0, -1.0, "amplitude of the cos(delta phi) term"},
#else
    {"ripple", HAIRBSDF_PARAM_FLOAT, {0.5, 0, 0}, -1.0, 1.0, "amplitude of the cos(delta phi) term"},
#endif
};

void* create(const double* v, char* error, size_t error_size) {
    if (v[3] == 0.25) {  // a value the plugin itself refuses, for the error path
        if (error_size > 0) std::snprintf(error, error_size, "ripple 0.25 is refused by the test plugin");
        return nullptr;
    }
    return new Instance{{v[0], v[1], v[2]}, v[3]};
}
void destroy(void* p) { delete static_cast<Instance*>(p); }

double density(const double* wi) { return std::sqrt(std::fmax(0.0, 1.0 - wi[0] * wi[0])) / (kPi * kPi); }

void value_at(const Instance& m, const double* wo, const double* wi, double* value) {
    const double dphi = std::atan2(wi[2], wi[1]) - std::atan2(wo[2], wo[1]);
    const double f = density(wi) * (1.0 + m.ripple * std::cos(dphi));
    for (int c = 0; c < 3; ++c) value[c] = m.albedo[c] * f;
}

int eval(const void* p, size_t n, const double* wo, const double* wi, const double*, const double*, double* value,
         double* lobes) {
    const Instance& m = *static_cast<const Instance*>(p);
#ifdef TEST_PLUGIN_FAIL
    if (m.ripple < 0) return 7;
#endif
    for (size_t i = 0; i < n; ++i) {
        value_at(m, wo + 3 * i, wi + 3 * i, value + 3 * i);
#ifdef TEST_PLUGIN_NAN
        if (std::fabs(wi[3 * i]) > 0.99) value[3 * i + 1] = std::nan("");
#endif
        if (lobes) {
            for (int k = 0; k < 12; ++k) lobes[12 * i + k] = 0.0;
            for (int c = 0; c < 3; ++c) lobes[12 * i + 9 + c] = value[3 * i + c];
        }
    }
    return 0;
}

int pdf(const void*, size_t n, const double*, const double* wi, const double*, const double*, double* out) {
    for (size_t i = 0; i < n; ++i) out[i] = density(wi + 3 * i);
    return 0;
}

int sample(const void* p, size_t n, const double* wo, const double*, const double*, const double* u, double* wi,
           double* weight, double* pdf_out, int32_t* lobe) {
    const Instance& m = *static_cast<const Instance*>(p);
    for (size_t i = 0; i < n; ++i) {
        const double s = std::sqrt(u[3 * i + 2]) * std::cos(2 * kPi * u[3 * i + 1]);
        const double c = std::sqrt(std::fmax(0.0, 1.0 - s * s)), phi = 2 * kPi * u[3 * i];
        double* w = wi + 3 * i;
        w[0] = s;
        w[1] = c * std::cos(phi);
        w[2] = c * std::sin(phi);
        pdf_out[i] = density(w);
        lobe[i] = pdf_out[i] > 0 ? HAIRBSDF_LOBE_TRRT : -1;
        double value[3];
        value_at(m, wo + 3 * i, w, value);
        for (int k = 0; k < 3; ++k) weight[3 * i + k] = pdf_out[i] > 0 ? value[k] / pdf_out[i] : 0.0;
        if (pdf_out[i] <= 0) pdf_out[i] = 0;
    }
    return 0;
}

const hairbsdf_plugin kPlugin = {
    TEST_PLUGIN_ABI, HAIRBSDF_PLUGIN_HAS_LOBES, "test_ripple", "diffuse fibre with an azimuthal ripple", 2, kParams,
    create, destroy, eval,
#ifdef TEST_PLUGIN_NULL_SAMPLE
    nullptr,
#else
    sample,
#endif
    pdf,
};

}  // namespace

#ifndef TEST_PLUGIN_NO_ENTRY
HAIRBSDF_PLUGIN_ENTRY {
    (void)host_abi_version;
    return &kPlugin;
}
#endif
