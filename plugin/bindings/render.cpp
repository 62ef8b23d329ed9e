// pybind11 bindings: hairbsdf._render, the path tracer (Embree + TBB). A separate module
// from _core so that `import hairbsdf` never loads TBB / Embree: the Python wrapper
// (hairbsdf/render.py) imports it lazily at render time.
//
// render(scene: dict, progress=None, cancel=None, threads=0) -> {"combined": (H, W, 4)
// float32, "stats": {...}}. The scene dict follows docs/scene_desc.md; conversion errors
// name the key. The render runs on a worker thread with the GIL released; the calling
// thread re-acquires it every 50 ms to poll cancel() (and Ctrl-C) and every 250 ms to
// report progress(fraction).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <iterator>
#include <memory>
#include <optional>
#include <thread>

#include "hairbsdf/render/render.h"
#include "hairbsdf/render/shading.h"
#include "model_params.h"
#include "render_passes.h"
#include "scene_schema.h"

namespace py = pybind11;
using namespace hairbsdf;
using namespace hairbsdf::render;

namespace {

[[noreturn]] void fail(const std::string& key, const std::string& what) { throw py::value_error(key + ": " + what); }

// ----- the test entry points' own arguments (not scene keys) -----

template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> as_array(py::handle h, const std::string& key) {
    try {
        return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(h);
    } catch (const py::error_already_set&) {
    }
    throw py::type_error(key + ": expected an array of numbers");
}

template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> array_shape(py::handle h, const std::string& key, int cols) {
    auto a = as_array<T>(h, key);
    if (!a) throw py::type_error(key + ": expected an array of numbers");
    if (cols == 0 ? a.ndim() != 1 : (a.ndim() != 2 || a.shape(1) != cols)) {
        fail(key, cols == 0 ? "expected a 1-D array" : "expected shape (N, " + std::to_string(cols) + ")");
    }
    return a;
}

// ----- the scene: check_scene (scene_schema.h) has checked every key, its type, shape, dtype,
// allowed values, array lengths and the rules between keys, and dropped None; the readers below
// only copy. Plain values and arrays go through the schema's field bindings
// (bindings::read_fields, bindings::read_list); keys with rules of their own are copied here. -----

py::dict dict_at(const py::dict& d, const char* name) { return py::reinterpret_borrow<py::dict>(d[name]); }

void read_curves(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("curves")) return;
    const py::dict c = dict_at(scene, "curves");
    CurveData& cd = out.curves;
    bindings::read_fields("curves", c, cd);
    if (cd.offsets.empty()) {  // no curves, no points: nothing else is read
        cd = CurveData{};
        return;
    }
    bindings::read_list("curves.attributes", c, cd.attributes);
}

// An image the programs sample: an item of `images`, checked.
ImageDesc read_image(const py::dict& d) {
    ImageDesc im;
    bindings::read_fields(std::string(bindings::kImagesPath) + "[]", d, im);
    return im;
}

ShadingProgram read_program(const py::dict& d, const std::string& path = bindings::kMaterialProgramPath) {
    ShadingProgram p;
    bindings::read_fields(path, d, p);
    return p;
}

void read_meshes(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("meshes")) return;
    const py::dict m = dict_at(scene, "meshes");
    bindings::read_fields("meshes", m, out.meshes);
    bindings::read_list("meshes.attributes", m, out.meshes.attributes);
}

ClosureDesc read_closure(const py::dict& c, const std::string& key) {
    ClosureDesc cd;
    auto link = [&cd](int input, int reg) { cd.links.push_back({ClosureDesc::Input(input), int32_t(reg)}); };
    bindings::read_fields(bindings::kClosuresPath, c, cd, link);
    if (cd.type == ClosureDesc::Type::PrincipledHair && c.contains("inputs")) {
        const py::dict inputs = dict_at(c, "inputs");
        bindings::read_fields(bindings::kPrincipledHairInputsPath, inputs, cd.hair, link);
        cd.random_from_curve = !inputs.contains("random");  // Cycles' curve_random where unlinked
    } else if (cd.type == ClosureDesc::Type::Model && c.contains("params")) {  // model and path: bound rows
        const std::string pk = key + "['params']";  // checked and built by model_factory.h
        cd.model_params = bindings::model_params_from_dict(
            dict_at(c, "params"), [&](const std::string& n) { return pk + "['" + n + "']"; });
    }
    return cd;
}

MaterialDesc read_material(const py::dict& m, const std::string& key) {
    MaterialDesc md;
    bindings::read_fields(bindings::kMaterialsPath, m, md);
    if (m.contains("program")) md.program = read_program(dict_at(m, "program"));
    size_t j = 0;
    for (py::handle ch : py::reinterpret_borrow<py::list>(m["closures"]))
        md.closures.push_back(
            read_closure(py::reinterpret_borrow<py::dict>(ch), key + "['closures'][" + std::to_string(j++) + "]"));
    return md;
}

void read_materials(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("materials")) return;
    size_t i = 0;
    for (py::handle mh : py::reinterpret_borrow<py::list>(scene["materials"]))
        out.materials.push_back(read_material(py::reinterpret_borrow<py::dict>(mh),
                                              "scene['materials'][" + std::to_string(i++) + "]"));
}

void read_camera(const py::dict& scene, SceneDesc& out) {
    const py::dict c = dict_at(scene, "camera");
    CameraDesc& cam = out.camera;
    bindings::read_fields("camera", c, cam);
    const py::tuple resolution = py::reinterpret_borrow<py::tuple>(c["resolution"]);  // IntPair
    cam.width = resolution[0].cast<int>();
    cam.height = resolution[1].cast<int>();
}

void read_lights(const py::dict& scene, SceneDesc& out) {
    if (!scene.contains("lights")) return;
    for (py::handle lh : py::reinterpret_borrow<py::list>(scene["lights"])) {
        const py::dict l = py::reinterpret_borrow<py::dict>(lh);
        LightDesc d;
        bindings::read_fields("lights[]", l, d);
        if (l.contains("matrix_world")) {  // SPOT (optional: the cone's scale), AREA (required)
            const auto m = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(l["matrix_world"]);
            std::copy(m.data(), m.data() + 16, d.matrix_world.begin());
            d.has_matrix = true;
        }
        if (d.type == LightType::Area) d.size_y = l.contains("size_y") ? l["size_y"].cast<double>() : d.size_x;
        out.lights.push_back(d);
    }
}

void read_integrator(const py::dict& scene, SceneDesc& out) {
    const py::dict in = dict_at(scene, "integrator");
    IntegratorSettings& s = out.integrator;
    bindings::read_fields("integrator", in, s);
    if (in.contains("passes"))  // checked names of render_passes()
        for (py::handle name : py::reinterpret_borrow<py::list>(in["passes"]))
            for (const bindings::RenderPass& pass : bindings::render_passes())
                if (std::string(py::str(name)) == pass.name) s.*pass.flag = true;
}

// The scene dict -> SceneDesc: check_scene (scene_schema.h) validates and normalises it
// against the schema; the readers above copy the checked values.
SceneDesc scene_from_dict(py::handle scene_dict) {
    const py::dict scene = bindings::check_scene(scene_dict);
    SceneDesc out;
    bindings::read_fields("", scene, out);  // curve_shape, curve_subdivisions, curve_backface_culling
    read_curves(scene, out);
    read_meshes(scene, out);
    read_materials(scene, out);
    bindings::read_list(bindings::kImagesPath, scene, out.images);
    read_camera(scene, out);
    read_lights(scene, out);
    if (scene.contains("world")) {
        const py::dict world = dict_at(scene, "world");
        bindings::read_fields("world", world, out, [&](int, int reg) { out.world_color_register = reg; });
        if (world.contains("program")) out.world_program = read_program(dict_at(world, "program"), "world.program");
        if (world.contains("texture"))
            bindings::read_fields("world.texture", dict_at(world, "texture"), out.world_texture,
                                  [&](int, int reg) { out.world_texture_weight_register = reg; });
    }
    read_integrator(scene, out);
    return out;
}

py::dict py_render(py::handle scene_dict, py::object progress, py::object cancel, int threads) {
    SceneDesc scene = scene_from_dict(scene_dict);
    if (!progress.is_none() && !PyCallable_Check(progress.ptr())) throw py::type_error("progress: expected a callable or None");
    if (!cancel.is_none() && !PyCallable_Check(cancel.ptr())) throw py::type_error("cancel: expected a callable or None");
    if (threads < 0) throw py::value_error("threads: must be >= 0 (0 = all cores)");

    std::unique_ptr<RenderJob> job_ptr;
    std::exception_ptr worker_error;
    std::optional<py::error_already_set> callback_error;
    {
        py::gil_scoped_release release;
        job_ptr = std::make_unique<RenderJob>(std::move(scene), threads);  // scene repair, no GIL
        RenderJob& job = *job_ptr;
        std::atomic<bool> done{false};
        std::thread worker([&] {
            try {
                job.run();
            } catch (...) {
                worker_error = std::current_exception();
            }
            done.store(true);
        });
        using clock = std::chrono::steady_clock;
        auto last_cancel = clock::now(), last_progress = clock::now();
        while (!done.load()) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
            const auto now = clock::now();
            const bool poll_cancel = now - last_cancel >= std::chrono::milliseconds(50);
            const bool poll_progress = !progress.is_none() && now - last_progress >= std::chrono::milliseconds(250);
            if (!(poll_cancel || poll_progress) || job.cancelled()) continue;
            py::gil_scoped_acquire acquire;
            try {
                // Progress first: on a loaded machine one wake-up may be due for both, and a
                // cancelled render still reports how far it got.
                if (poll_progress) {
                    last_progress = now;
                    progress(job.progress());
                }
                if (poll_cancel) {
                    last_cancel = now;
                    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
                    if (!cancel.is_none() && py::bool_(cancel())) job.cancel();
                }
            } catch (py::error_already_set& e) {
                callback_error.emplace(std::move(e));
                job.cancel();
            }
        }
        worker.join();
    }
    if (callback_error) throw *callback_error;
    if (worker_error) std::rethrow_exception(worker_error);

    const RenderOutput out = job_ptr->output();
    if (!progress.is_none() && !out.stats.cancelled) progress(1.0);
    py::array_t<float> combined({py::ssize_t(out.height), py::ssize_t(out.width), py::ssize_t(4)});
    std::memcpy(combined.mutable_data(), out.rgba.data(), out.rgba.size() * sizeof(float));
    py::dict stats;
    stats["samples"] = out.stats.samples;
    stats["seconds"] = out.stats.seconds;
    stats["build_seconds"] = out.stats.build_seconds;
    stats["rays"] = out.stats.rays;
    stats["peak_memory_bytes"] = out.stats.peak_memory_bytes;
    stats["nan_count"] = out.stats.nan_count;
    stats["kernel_hits"] = out.stats.kernel_hits;
    stats["curve_intersector"] = out.stats.sweep_curves ? "SWEEP" : "EMBREE";
    stats["cancelled"] = out.stats.cancelled;
    stats["warnings"] = out.warnings;
    py::dict result;
    result["combined"] = combined;
    result["stats"] = stats;
    const py::ssize_t h = out.height, w = out.width;
    auto image = [&](const std::vector<float>& data, std::vector<py::ssize_t> shape, size_t offset, size_t stride,
                     size_t channels) {
        py::array_t<float> a(shape);
        float* dst = a.mutable_data();
        const size_t n = size_t(h) * size_t(w);
        for (size_t i = 0; i < n; ++i)
            for (size_t c = 0; c < channels; ++c) dst[i * channels + c] = data[i * stride + offset + c];
        return a;
    };
    for (const bindings::RenderPass& pass : bindings::render_passes()) {
        const std::vector<float>& data = out.passes.*pass.data;
        if (data.empty()) continue;
        size_t stride = 0, offset = 0;
        for (const bindings::PassImage& im : pass.images) stride += size_t(im.channels());
        if (data.size() != size_t(h) * size_t(w) * stride)
            throw std::logic_error(std::string("render pass ") + pass.name + ": the film wrote " +
                                   std::to_string(data.size()) + " values, the pass table's images take " +
                                   std::to_string(size_t(h) * size_t(w) * stride));
        for (const bindings::PassImage& im : pass.images) {
            const size_t c = size_t(im.channels());
            result[im.key] = image(data, c == 1 ? std::vector<py::ssize_t>{h, w} : std::vector<py::ssize_t>{h, w, py::ssize_t(c)},
                                   offset, stride, c);
            offset += c;
        }
    }
    return result;
}

// eval_program(program, random, intercept, length, is_strand, attributes=None, images=None) -> (M, registers)
// float32: the program run once per row of the context arrays (M values each, or scalars).
py::array_t<float> py_eval_program(py::handle program, py::handle random, py::handle intercept, py::handle length,
                                   py::handle is_strand, py::handle attributes, py::handle images) {
    // Checked as a material's program and an `images` list are (scene_schema.h).
    const ShadingProgram p =
        read_program(py::reinterpret_borrow<py::dict>(bindings::check_value(bindings::kMaterialProgramPath, program, "program")));
    auto column = [](py::handle h, const char* name) {
        auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(h);
        if (!a || a.ndim() > 1) throw py::value_error(std::string(name) + ": expected a number or a 1-D array");
        return a;
    };
    const auto r = column(random, "random"), i = column(intercept, "intercept"), l = column(length, "length"),
               s = column(is_strand, "is_strand");
    size_t m = 1;
    for (const auto* a : {&r, &i, &l, &s})
        if (a->ndim() == 1) m = std::max(m, size_t(a->shape(0)));
    auto at = [&](const py::array_t<float, py::array::c_style | py::array::forcecast>& a, size_t k, const char* name) {
        if (a.ndim() == 0) return a.data()[0];
        if (size_t(a.shape(0)) != m) throw py::value_error(std::string(name) + ": expected " + std::to_string(m) + " values");
        return a.data()[k];
    };
    int n_attr = 0;
    py::array_t<float, py::array::c_style | py::array::forcecast> attr;
    if (!attributes.is_none()) {
        attr = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(attributes);
        if (!attr || attr.ndim() != 3 || size_t(attr.shape(0)) != m || attr.shape(2) != 4)
            throw py::value_error("attributes: expected shape (M, attribute count, 4)");
        n_attr = int(attr.shape(1));
    }
    std::vector<ImageDesc> image_descs;
    std::vector<ShadingImage> image_views;
    if (!images.is_none()) {
        for (py::handle h : bindings::check_value(bindings::kImagesPath, images, "images"))
            image_descs.push_back(read_image(py::reinterpret_borrow<py::dict>(h)));
        for (const ImageDesc& im : image_descs) image_views.push_back({im.width, im.height, im.pixels.data()});
    }
    try {
        validate_program(p, n_attr, int(image_views.size()));
    } catch (const std::invalid_argument& e) {
        throw py::value_error(e.what());
    }
    py::array_t<float> out({py::ssize_t(m), py::ssize_t(p.register_count)});
    float* dst = out.mutable_data();
    for (size_t k = 0; k < m; ++k) {
        ShadingHitContext ctx;
        ctx.random = at(r, k, "random");
        ctx.intercept = at(i, k, "intercept");
        ctx.length = at(l, k, "length");
        ctx.is_strand = at(s, k, "is_strand");
        if (n_attr > 0) {
            ctx.attributes = attr.data() + k * size_t(n_attr) * 4;
            ctx.attribute_count = n_attr;
        }
        ctx.images = image_views.data();
        ctx.image_count = int(image_views.size());
        run_program(p, ctx, dst + k * size_t(p.register_count));
    }
    return out;
}

// The keys under `path` of a folded closure (or its Principled Hair inputs, `source`): the bound
// fields as numbers, and {"register": k} for an input still linked to the folded program.
py::dict folded_keys(const std::string& path, const std::string& type, std::type_index owner, const void* source,
                     const std::vector<ClosureDesc::Link>& links) {
    py::dict out = bindings::fields_as_python(path, type, owner, source);
    for (const bindings::SceneKey* k : bindings::rows_under(path, type))
        for (const ClosureDesc::Link& l : links)
            if (k->register_link && k->link_input == int(l.input) && k->field && k->field.owner == owner) {
                py::dict reg;
                reg["register"] = l.reg;
                const std::string name = std::string(k->path).substr(path.size() + 1);
                out[name.c_str()] = reg;
            }
    return out;
}

// folded_material(material, attribute_count=0, images=None) -> {"closures", "registers", "warnings"}:
// one exported material as the scene loader makes it (repair_programs: its program checked and
// folded, closures of weight 0 dropped). Each closure holds its keys as numbers; an input that
// still depends on the hit is {"register": k} of the folded program (`registers` slots, 0: none);
// Principled Hair's `random` is None where it is the curve's.
py::dict py_folded_material(py::handle material, int attribute_count, py::handle images) {
    if (attribute_count < 0) throw py::value_error("attribute_count: must be >= 0, got " + std::to_string(attribute_count));
    const py::dict checked = bindings::check_value(bindings::kMaterialsPath, material, "material");
    SceneDesc scene;
    scene.materials.push_back(read_material(checked, "material"));
    if (!images.is_none())
        for (py::handle h : bindings::check_value(bindings::kImagesPath, images, "images"))
            scene.images.push_back(read_image(py::reinterpret_borrow<py::dict>(h)));
    scene.curves.attributes.resize(size_t(attribute_count));
    std::vector<std::string> warnings;
    repair_programs(scene, warnings);
    const MaterialDesc& md = scene.materials[0];
    py::list closures;
    for (const ClosureDesc& c : md.closures) {
        const std::string closure_path = bindings::kClosuresPath;
        const std::string type = py::str(bindings::fields_as_python(closure_path, "", typeid(ClosureDesc), &c)["type"]);
        py::dict d = folded_keys(closure_path, type, typeid(ClosureDesc), &c, c.links);
        if (c.type == ClosureDesc::Type::PrincipledHair) {
            py::dict inputs =
                folded_keys(bindings::kPrincipledHairInputsPath, "", typeid(PrincipledHairInputs), &c.hair, c.links);
            if (c.random_from_curve) inputs["random"] = py::none();
            d["inputs"] = inputs;
        }
        closures.append(d);
    }
    py::dict out;
    out["closures"] = closures;
    out["registers"] = md.program.register_count;
    py::list w;
    for (const std::string& s : warnings) w.append(s);
    out["warnings"] = w;
    return out;
}

// eval_hit_bsdf(scene, material, wo, wi, h, normal, random, seed, blur) -> (value (N, 3), pdf (N,),
// lobes (N, 6, 3)): the engine's BSDF at N hits on a fibre along +x (the fibre frame of the Python
// API), set up and evaluated by the integrator's own code (render::Bsdf). Row i seeds a stochastic
// eval with lookup3_hash_uint2(i, seed), as Closure.cycles_estimate does; `normal` (N, 3) is the
// hit's shading normal (diffuse, the legacy Hair BSDF's N test), wo where None.
py::tuple py_eval_hit_bsdf(py::handle scene_dict, int material, py::handle wo_h, py::handle wi_h, py::handle h_h,
                           py::handle normal_h, double random, uint32_t seed, double blur) {
    SceneDesc scene = scene_from_dict(scene_dict);
    std::vector<std::string> program_warnings;  // the renderer reports them; not this probe
    repair_programs(scene, program_warnings);    // folded as the renderer folds them
    if (material < 0 || size_t(material) >= scene.materials.size()) throw py::value_error("material: no such index");
    const IntegratorSettings& is = scene.integrator;
    const MaterialShader shader(scene.materials[size_t(material)], is.tilt, is.accuracy, is.huang_sampler);
    const auto wo = array_shape<double>(wo_h, "wo", 3), wi = array_shape<double>(wi_h, "wi", 3);
    const auto h = as_array<double>(h_h, "h");
    const size_t n = size_t(wo.shape(0));
    if (size_t(wi.shape(0)) != n || size_t(h.size()) != n) throw py::value_error("wo, wi, h: expected N rows each");
    py::array_t<double, py::array::c_style | py::array::forcecast> normal;
    if (!normal_h.is_none()) {
        normal = array_shape<double>(normal_h, "normal", 3);
        if (size_t(normal.shape(0)) != n) throw py::value_error("normal: expected N rows");
    }
    py::array_t<double> value({py::ssize_t(n), py::ssize_t(3)}), pdf({py::ssize_t(n)});
    py::array_t<double> lobes({py::ssize_t(n), py::ssize_t(kLobeCount), py::ssize_t(3)});
    auto row = [](const double* p, size_t i) { return Vec3{p[3 * i], p[3 * i + 1], p[3 * i + 2]}; };
    double *ov = value.mutable_data(), *op = pdf.mutable_data(), *ol = lobes.mutable_data();
    Bsdf bsdf;
    for (size_t i = 0; i < n; ++i) {
        ShadingGeometry g;
        g.wo = row(wo.data(), i);
        g.n = normal.size() ? row(normal.data(), i) : g.wo;
        g.ng = g.n;
        g.tangent = Vec3{1, 0, 0};
        g.h = h.data()[i];
        g.random = random;
        bsdf.set_seeded(shader, g, blur, lookup3_hash_uint2(uint32_t(i), seed), true);
        const BsdfValue b = bsdf.empty() ? BsdfValue{} : bsdf.eval(row(wi.data(), i));
        for (int c = 0; c < 3; ++c) {
            ov[3 * i + size_t(c)] = b.value[c];
            for (int k = 0; k < kLobeCount; ++k) ol[(i * kLobeCount + size_t(k)) * 3 + size_t(c)] = b.lobes[size_t(k)][c];
        }
        op[i] = b.pdf;
    }
    return py::make_tuple(value, pdf, lobes);
}

// shading_vm_instruction_set() -> {"ops": {name: opcode}, "argument_counts": {name: n},
// "operands": {name: [{"arg", "width", "write", "what", "width_arg", "width_per_arg"}]}, enum name: {name: value}}
py::dict py_shading_vm_instruction_set() {
    const ShadingInstructionSet& set = shading_instruction_set();
    py::dict ops, counts, operands, out;
    for (const ShadingOpInfo& op : set.ops) {
        ops[op.name] = int32_t(op.op);
        counts[op.name] = op.argument_count;
        py::list blocks;
        for (const ShadingOperandSpec& o : op.operands)
            blocks.append(py::dict(py::arg("arg") = o.arg, py::arg("width") = o.width, py::arg("write") = o.write,
                                   py::arg("what") = o.what, py::arg("width_arg") = o.width_arg,
                                   py::arg("width_per_arg") = o.width_per_arg));
        operands[op.name] = blocks;
    }
    out["ops"] = ops;
    out["argument_counts"] = counts;
    out["operands"] = operands;
    for (const auto& [table, entries] : set.enums) {
        py::dict d;
        for (const ShadingNamedValue& e : entries) d[e.name] = e.value;
        out[table.c_str()] = d;
    }
    return out;
}

// render()'s docstring: the result keys from the pass table.
const std::string& render_doc() {
    static const std::string doc = [] {
        std::string d = "Renders a scene_desc dict (docs/scene_desc.md). Returns {'combined': (H, W, 4) float32 RGBA, "
                        "'stats': {samples, seconds, build_seconds, rays, peak_memory_bytes, nan_count, kernel_hits, "
                        "curve_intersector (the one that traced THICK curves), cancelled, warnings}} plus the passes asked for in integrator['passes']:";
        for (const bindings::RenderPass& pass : bindings::render_passes()) {
            d += std::string(" ") + pass.name + " ->";
            for (const bindings::PassImage& im : pass.images)
                d += std::string(" '") + im.key + "'" + (im.channels() == 1 ? " (H, W)" : " (H, W, " + std::to_string(im.channels()) + ")");
            d += std::string(" (") + pass.meaning + ");";
        }
        d.back() = '.';
        return d;
    }();
    return doc;
}

}  // namespace

PYBIND11_MODULE(_render, m) {
    m.doc() = "hairbsdf path tracer (Embree + TBB); use hairbsdf.render.render, not this module";
    m.def("render", &py_render, py::arg("scene"), py::arg("progress") = py::none(), py::arg("cancel") = py::none(),
          py::arg("threads") = 0, render_doc().c_str());
    m.def("eval_program", &py_eval_program, py::arg("program"), py::arg("random") = 0.0f,
          py::arg("intercept") = 0.0f, py::arg("length") = 0.0f, py::arg("is_strand") = 1.0f,
          py::arg("attributes") = py::none(), py::arg("images") = py::none(),
          "Runs a material's shading program (docs/shading_vm.md) for M hit contexts (numbers or (M,) arrays; "
          "attributes (M, A, 4) RGBA; images: the scene's `images` list). Returns the registers, "
          "(M, program['registers']) float32.");
    m.def("folded_material", &py_folded_material, py::arg("material"), py::arg("attribute_count") = 0,
          py::arg("images") = py::none(),
          "One exported material (docs/scene_desc.md `materials[]`) as the scene loader folds it: "
          "{'closures': [closure keys as numbers, {'register': k} where an input still depends on the hit], "
          "'registers': the folded program's size (0: none), 'warnings': [...]}. attribute_count: the curve "
          "attributes its program may read; images: the scene's `images`.");
    m.def("shading_vm_instruction_set", &py_shading_vm_instruction_set,
          "The shading VM's opcodes, their argument counts, the register blocks each reads and writes, and its "
          "enums under Blender's identifiers "
          "(render/shading_vm.h); the exporter's compiler derives its numbers from this.");
    m.def("eval_hit_bsdf", &py_eval_hit_bsdf, py::arg("scene"), py::arg("material"), py::arg("wo"), py::arg("wi"),
          py::arg("h"), py::arg("normal") = py::none(), py::arg("random") = 0.0, py::arg("seed") = 0u,
          py::arg("blur") = 0.0,
          "The engine's BSDF at N hits on a fibre along +x, for tests: scene['materials'][material] set up and "
          "evaluated by the integrator's code. Returns (value (N, 3), pdf (N,), lobes (N, 6, 3)).");
}
