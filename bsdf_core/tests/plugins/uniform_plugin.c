/* A plugin in plain C99 (plugin/tests/test_plugins.py builds it with -std=c99 -pedantic -Werror):
 * a grey "sphere" BSDF, eval = albedo / (4 pi) for every direction pair, sampled uniformly.
 * No per-lobe values (no HAIRBSDF_PLUGIN_HAS_LOBES): the host reports the value as lobe R. */
#include <math.h>
#include <stdlib.h>

#include "hairbsdf/plugin.h"

static const double kPi = 3.14159265358979323846;

static const hairbsdf_param kParams[] = {
    {"albedo", HAIRBSDF_PARAM_FLOAT, {0.75, 0.0, 0.0}, 0.0, 1.0, "directional albedo"},
};

static void* create(const double* values, char* error, size_t error_size) {
    double* albedo = (double*)malloc(sizeof(double));
    (void)error;
    (void)error_size;
    if (albedo) *albedo = values[0];
    return albedo;
}

static void destroy(void* instance) { free(instance); }

static int eval(const void* instance, size_t n, const double* wo, const double* wi, const double* h,
                const double* random, double* value, double* lobes) {
    const double f = *(const double*)instance / (4.0 * kPi);
    size_t i;
    (void)wo, (void)wi, (void)h, (void)random, (void)lobes;
    for (i = 0; i < 3 * n; ++i) value[i] = f;
    return 0;
}

static int pdf(const void* instance, size_t n, const double* wo, const double* wi, const double* h,
               const double* random, double* out) {
    size_t i;
    (void)instance, (void)wo, (void)wi, (void)h, (void)random;
    for (i = 0; i < n; ++i) out[i] = 1.0 / (4.0 * kPi);
    return 0;
}

static int sample(const void* instance, size_t n, const double* wo, const double* h, const double* random,
                  const double* u, double* wi, double* weight, double* pdf_out, int32_t* lobe) {
    const double albedo = *(const double*)instance;
    size_t i;
    (void)wo, (void)h, (void)random;
    for (i = 0; i < n; ++i) {
        const double z = 1.0 - 2.0 * u[3 * i], r = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * kPi * u[3 * i + 1];
        wi[3 * i] = z;
        wi[3 * i + 1] = r * cos(phi);
        wi[3 * i + 2] = r * sin(phi);
        weight[3 * i] = weight[3 * i + 1] = weight[3 * i + 2] = albedo;
        pdf_out[i] = 1.0 / (4.0 * kPi);
        lobe[i] = HAIRBSDF_LOBE_R;
    }
    return 0;
}

static const hairbsdf_plugin kPlugin = {
    HAIRBSDF_PLUGIN_ABI_VERSION, 0u, "uniform_c", "grey sphere, plain C", 1u, kParams,
    create, destroy, eval, sample, pdf,
};

HAIRBSDF_PLUGIN_ENTRY {
    (void)host_abi_version;
    return &kPlugin;
}
