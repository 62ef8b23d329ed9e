/* hairbsdf plugin ABI: a hair BSDF in a shared library, loaded at run time by
 * hairbsdf.load_plugin (Python) or hairbsdf::load_plugin (C++, models/plugin_hair.h).
 * Plain C; a plugin includes only this header. Walk-through: docs/plugins.md.
 *
 * The library exports one function, HAIRBSDF_PLUGIN_ENTRY, that returns a pointer to a
 * static descriptor. The host calls it once with its own ABI version, checks
 * `abi_version` (the first field) before it reads anything else, then checks that every
 * function pointer is set and that the parameter schema is well formed.
 *
 * Frame and conventions (docs/conventions.md): directions are unit vectors in the fibre
 * frame, x = fibre tangent (root to tip), y and z across the fibre; wo points towards the
 * viewer, wi towards the light. sin(theta) = w[0], phi = atan2(w[2], w[1]). h in [-1, 1]
 * is the offset across the fibre, `random` the per-strand random number in [0, 1]
 * (Blender's Hair Info > Random). The host may rotate both directions about x: a plugin
 * must depend on phi only through phi_i - phi_o.
 *
 * eval returns Cycles' value *including the cosine factor* (pbrt's f * |cos theta_i|), so
 * the directional albedo is the integral of eval over the sphere of wi. pdf is a density
 * per unit solid angle; sample returns weight = eval / pdf at the sampled direction.
 *
 * Threads: eval, sample and pdf are called concurrently on one instance from many threads;
 * they must not modify the instance (treat it as const). create and destroy are not
 * called concurrently for the same instance.
 *
 * Batches: every array holds n rows, row-major: wo, wi, u, value, weight: 3 doubles per
 * row; lobes: 12 (R, TT, TRT, TRRT+, RGB each); h, random, pdf: 1 double; lobe: 1 int32.
 * Input arrays are never NULL. Functions return 0 on success; any other value marks the
 * whole batch as failed (the host reports it: NaN values, no sample).
 */
#ifndef HAIRBSDF_PLUGIN_H
#define HAIRBSDF_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

/* Bumped whenever the layout or meaning of anything below changes. */
#define HAIRBSDF_PLUGIN_ABI_VERSION 1u
/* The name of the exported entry function, as a string for dlsym. */
#define HAIRBSDF_PLUGIN_ENTRY_NAME "hairbsdf_plugin_entry"

#ifdef __cplusplus
extern "C" {
#endif

/* Parameter types. A float parameter uses one value, an RGB parameter three. */
enum hairbsdf_param_type { HAIRBSDF_PARAM_FLOAT = 0, HAIRBSDF_PARAM_RGB = 1 };

/* Descriptor flags. */
enum hairbsdf_plugin_flags {
    /* eval fills `lobes` (R, TT, TRT, TRRT+) when the host passes a non-NULL pointer.
     * Without it the host never asks, and reports the value as one lobe. */
    HAIRBSDF_PLUGIN_HAS_LOBES = 1u << 0
};

/* Lobe indices of eval's `lobes` and sample's `lobe` (-1: no sample). */
enum hairbsdf_lobe { HAIRBSDF_LOBE_R = 0, HAIRBSDF_LOBE_TT = 1, HAIRBSDF_LOBE_TRT = 2, HAIRBSDF_LOBE_TRRT = 3 };

typedef struct hairbsdf_param {
    const char* name;         /* a Python identifier, unique within the plugin */
    int32_t type;             /* enum hairbsdf_param_type */
    double default_value[3];  /* FLOAT: [0] only */
    double min_value;         /* inclusive range, every channel of an RGB */
    double max_value;
    const char* description;  /* one line, or NULL */
} hairbsdf_param;

typedef struct hairbsdf_plugin {
    uint32_t abi_version;     /* HAIRBSDF_PLUGIN_ABI_VERSION the plugin was built with */
    uint32_t flags;           /* enum hairbsdf_plugin_flags */
    const char* name;         /* short identifier, e.g. "kajiya_kay" */
    const char* description;  /* one line, or NULL */
    uint32_t param_count;
    const hairbsdf_param* params;

    /* A new instance from parameter values: 3 doubles per schema parameter, in schema
     * order (a FLOAT uses the first). The host has checked the ranges. On failure return
     * NULL and write a message (NUL-terminated, at most error_size bytes) to `error`. */
    void* (*create)(const double* values, char* error, size_t error_size);
    void (*destroy)(void* instance);

    /* value (n x 3) = sum of the lobes. `lobes` (n x 12) is NULL unless the plugin
     * declares HAIRBSDF_PLUGIN_HAS_LOBES and the caller wants them. */
    int (*eval)(const void* instance, size_t n, const double* wo, const double* wi, const double* h,
                const double* random, double* value, double* lobes);
    /* From three uniforms u in [0, 1] per row (docs/conventions.md for their usual roles):
     * wi (unit), weight = eval(wi) / pdf(wi), pdf = pdf(wi) and the lobe, or lobe = -1
     * with weight 0 and pdf 0 when the row produced no direction. */
    int (*sample)(const void* instance, size_t n, const double* wo, const double* h, const double* random,
                  const double* u, double* wi, double* weight, double* pdf, int32_t* lobe);
    /* The density `sample` draws wi with, per unit solid angle. */
    int (*pdf)(const void* instance, size_t n, const double* wo, const double* wi, const double* h,
               const double* random, double* pdf);
} hairbsdf_plugin;

/* The entry point: `host_abi_version` is the host's HAIRBSDF_PLUGIN_ABI_VERSION. Return the
 * descriptor (static storage; the host never frees it), or NULL to refuse to load. */
typedef const hairbsdf_plugin* (*hairbsdf_plugin_entry_fn)(uint32_t host_abi_version);

#if defined(_WIN32)
#define HAIRBSDF_PLUGIN_EXPORT __declspec(dllexport)
#else
#define HAIRBSDF_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

/* Declares the entry point with C linkage and default visibility; define it with
 *   HAIRBSDF_PLUGIN_ENTRY { return &my_descriptor; }                              */
#ifdef __cplusplus
#define HAIRBSDF_PLUGIN_ENTRY \
    extern "C" HAIRBSDF_PLUGIN_EXPORT const hairbsdf_plugin* hairbsdf_plugin_entry(uint32_t host_abi_version)
#else
#define HAIRBSDF_PLUGIN_ENTRY \
    HAIRBSDF_PLUGIN_EXPORT const hairbsdf_plugin* hairbsdf_plugin_entry(uint32_t host_abi_version)
#endif

#ifdef __cplusplus
}
#endif

#endif /* HAIRBSDF_PLUGIN_H */
