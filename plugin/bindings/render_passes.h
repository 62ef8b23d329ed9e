// The render passes `integrator.passes` may name and the images each adds to render()'s result:
// written once here. The scene schema's allowed names, the reader's flags, the result keys and
// shapes, _render.render's docstring and the Blender engine's passes (hairbsdf.blender.passes,
// through _core.render_passes()) derive from it.
#pragma once

#include <pybind11/pybind11.h>

#include <cstring>
#include <string>
#include <vector>

#include "hairbsdf/render/film.h"
#include "hairbsdf/render/scene.h"

namespace hairbsdf::bindings {

struct PassImage {
    const char* key;           // in render()'s result
    const char* blender_name;  // the Blender render pass (a Render Layers output)
    const char* channel_ids;   // Blender's channel ids; one letter per channel: (H, W) for one, else (H, W, n)
    int channels() const { return int(std::strlen(channel_ids)); }
};

struct RenderPass {
    const char* name;  // in integrator.passes
    bool render::IntegratorSettings::*flag;
    std::vector<float> render::Film::Passes::*data;  // per pixel, the images' channels one after another
    std::vector<PassImage> images;
    const char* meaning;
};

inline const std::vector<RenderPass>& render_passes() {
    using S = render::IntegratorSettings;
    using P = render::Film::Passes;
    static const std::vector<RenderPass> passes = {
        {"hair_lobes", &S::pass_hair_lobes, &P::hair_lobes,
         {{"hair_r", "Hair R", "RGB"}, {"hair_tt", "Hair TT", "RGB"}, {"hair_trt", "Hair TRT", "RGB"},
          {"hair_trrt", "Hair TRRT", "RGB"}, {"hair_tts", "Hair TTs", "RGB"}, {"hair_trts", "Hair TRTs", "RGB"}},
         "the light leaving the camera ray's first hair hit, split by lobe (TTs, TRTs: yan_fur's medulla lobes, "
         "0 for other models)"},
        {"depth", &S::pass_depth, &P::depth, {{"depth", "Depth", "Z"}},
         "camera-space depth of the first hit (1e10 on the background)"},
        {"normal", &S::pass_normal, &P::normal, {{"normal", "Normal", "XYZ"}},
         "world-space shading normal of the first hit"},
        {"variance", &S::pass_variance, &P::variance, {{"variance", "Variance", "RGB"}},
         "variance of each pixel's mean (squared standard error)"},
    };
    return passes;
}

// [{"name", "meaning", "images": [{"key", "blender_name", "channel_ids", "channels"}]}] for Python.
inline pybind11::list render_passes_as_python() {
    namespace py = pybind11;
    py::list out;
    for (const RenderPass& p : render_passes()) {
        py::list images;
        for (const PassImage& im : p.images)
            images.append(py::dict(py::arg("key") = im.key, py::arg("blender_name") = im.blender_name,
                                   py::arg("channel_ids") = im.channel_ids, py::arg("channels") = im.channels()));
        out.append(py::dict(py::arg("name") = p.name, py::arg("meaning") = p.meaning, py::arg("images") = images));
    }
    return out;
}

inline std::vector<std::string> render_pass_names() {
    std::vector<std::string> names;
    for (const RenderPass& p : render_passes()) names.push_back(p.name);
    return names;
}

}  // namespace hairbsdf::bindings
