// A hair BSDF from a plugin library (the C ABI of hairbsdf/plugin.h) behind the model
// interface of ChiangHair: prepare(ctx) -> ShadingPoint, eval, pdf, sample. The adapter
// moves directions between the shading space of the ShadingContext and the plugin's
// fibre frame (FibreFrame of closure.h) and calls the plugin's batch functions with n = 1.
// Loading and its checks: src/plugin_loader.cpp. Walk-through: docs/plugins.md.
#pragma once

#include <array>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "hairbsdf/closure.h"
#include "hairbsdf/plugin.h"

namespace hairbsdf {

// Every loading or parameter error: the message names the path, the symbol or the
// parameter, and what was expected.
class PluginError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct PluginParam {
    std::string name;
    bool rgb = false;
    std::array<double, 3> default_value{};
    double min_value = 0, max_value = 0;
    std::string description;
};

// A loaded and checked plugin library; shared by the instances made from it. The library
// stays loaded for the life of the process (plugins may leave thread-local or atexit state).
class PluginLibrary {
public:
    const std::string& path() const { return path_; }
    const std::string& name() const { return name_; }
    const std::string& description() const { return description_; }
    uint32_t abi_version() const { return descriptor_->abi_version; }
    bool has_lobes() const { return (descriptor_->flags & HAIRBSDF_PLUGIN_HAS_LOBES) != 0; }
    const std::vector<PluginParam>& params() const { return params_; }
    const hairbsdf_plugin& descriptor() const { return *descriptor_; }

    // Parameter values (3 per schema parameter, in schema order) from the defaults and the
    // given (name, value) pairs; a FLOAT takes value[0]. Throws PluginError for an unknown
    // name or a value out of range.
    std::vector<double> values(const std::vector<std::pair<std::string, std::array<double, 3>>>& given = {}) const;
    // Throws PluginError naming the first parameter out of its range (or NaN).
    void check_values(const std::vector<double>& values) const;

private:
    friend std::shared_ptr<const PluginLibrary> load_plugin(const std::string& path);
    std::string path_, name_, description_;
    const hairbsdf_plugin* descriptor_ = nullptr;
    std::vector<PluginParam> params_;
};

// Loads a plugin: dlopen, the entry symbol, the ABI version, every function pointer and the
// schema are checked, with a PluginError that says what is wrong. Loading the same path
// again returns the same library.
std::shared_ptr<const PluginLibrary> load_plugin(const std::string& path);

class PluginHair {
public:
    // A new plugin instance from values as PluginLibrary::values returns them.
    PluginHair(std::shared_ptr<const PluginLibrary> library, const std::vector<double>& values);

    const PluginLibrary& library() const { return *library_; }
    const std::vector<double>& values() const { return values_; }

    // The plugin's view of one shading point: wo in the fibre frame, h and the strand random.
    struct ShadingPoint {
        FibreFrame frame;
        std::array<double, 3> wo{};
        double h = 0, random = 0;
    };
    ShadingPoint prepare(const ShadingContext& ctx) const {
        ShadingPoint sp{FibreFrame(ctx.tangent, ctx.wo), {}, ctx.h, ctx.random};
        sp.wo = local(sp.frame, ctx.wo);
        return sp;
    }

    // Without HAIRBSDF_PLUGIN_HAS_LOBES the whole value is reported in lobe R. A failed call
    // gives NaN (so that checks see it); callers that need finite values test isfinite.
    BsdfEval eval(const ShadingPoint& sp, Vec3 wi) const {
        BsdfEval out;
        const std::array<double, 3> l = local(sp.frame, wi);
        const hairbsdf_plugin& d = library_->descriptor();
        double value[3] = {0, 0, 0}, lobes[12] = {};
        const bool want_lobes = library_->has_lobes();
        if (d.eval(instance_.get(), 1, sp.wo.data(), l.data(), &sp.h, &sp.random, value, want_lobes ? lobes : nullptr) != 0 ||
            d.pdf(instance_.get(), 1, sp.wo.data(), l.data(), &sp.h, &sp.random, &out.pdf) != 0) {
            return failed_eval();
        }
        if (want_lobes) {
            for (int p = 0; p < kChiangLobeCount; ++p) out.lobes[p] = RGB(lobes[3 * p], lobes[3 * p + 1], lobes[3 * p + 2]);
        } else {
            out.lobes[0] = RGB(value[0], value[1], value[2]);
        }
        return out;
    }
    BsdfEval eval(const ShadingContext& ctx, Vec3 wi) const { return eval(prepare(ctx), wi); }

    double pdf(const ShadingPoint& sp, Vec3 wi) const {
        const std::array<double, 3> l = local(sp.frame, wi);
        double pdf = 0;
        if (library_->descriptor().pdf(instance_.get(), 1, sp.wo.data(), l.data(), &sp.h, &sp.random, &pdf) != 0)
            return std::nan("");
        return pdf;
    }
    double pdf(const ShadingContext& ctx, Vec3 wi) const { return pdf(prepare(ctx), wi); }

    // A failed call gives lobe -1 with a NaN pdf.
    BsdfSample sample(const ShadingPoint& sp, const std::array<double, 3>& u) const {
        BsdfSample out;
        double wi[3] = {0, 0, 0}, weight[3] = {0, 0, 0}, pdf = 0;
        int32_t lobe = -1;
        if (library_->descriptor().sample(instance_.get(), 1, sp.wo.data(), &sp.h, &sp.random, u.data(), wi, weight,
                                          &pdf, &lobe) != 0) {
            out.pdf = std::nan("");
            return out;
        }
        if (lobe < 0) return out;
        out.wi = wi[0] * sp.frame.x + wi[1] * sp.frame.y + wi[2] * sp.frame.z;
        out.weight = RGB(weight[0], weight[1], weight[2]);
        out.value = pdf * out.weight;
        out.pdf = pdf;
        out.lobe = lobe;
        return out;
    }
    BsdfSample sample(const ShadingContext& ctx, const std::array<double, 3>& u) const {
        return sample(prepare(ctx), u);
    }

    // The plugin does not say how narrow its lobes are: quadratures (albedo) assume narrow ones.
    std::array<double, 2> angular_scales() const { return {0.02, 0.02}; }

private:
    static std::array<double, 3> local(const FibreFrame& f, Vec3 w) { return {dot(w, f.x), dot(w, f.y), dot(w, f.z)}; }
    static BsdfEval failed_eval() {
        BsdfEval e;
        const double nan = std::nan("");
        for (RGB& c : e.lobes) c = RGB(nan);
        e.pdf = nan;
        return e;
    }

    std::shared_ptr<const PluginLibrary> library_;
    std::shared_ptr<void> instance_;
    std::vector<double> values_;
};

}  // namespace hairbsdf
