// The plain-data scene the renderer reads: the C++ mirror of docs/scene_desc.md.
// Built from the Python dict by the bindings (or by hand in tests); no Embree, no TBB.
// `repair_scene` drops or fixes invalid content and reports what it did.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hairbsdf/closures.h"
#include "hairbsdf/model_params.h"
#include "hairbsdf/params/principled_hair.h"
#include "hairbsdf/render/shading_vm.h"

namespace hairbsdf::render {

// Thick: round Catmull-Rom sweeps; ThickLinear: Blender 5.x's Linear 3D Curves (cones with spheres
// at the keys, Embree's round linear curves).
enum class CurveShape { Ribbons, Thick, ThickLinear };
// How THICK curves are intersected: Embree 3's round Catmull-Rom curves, or Embree's BVH over
// capped-cone proxies with hairbsdf's exact test of the same surface (render/curve_sweep.h:
// faster, with about 4x the memory); Auto, the default: Sweep while the scene's segments are at
// most sweep_auto_max_segments (geometry.h), else Embree.
enum class CurveIntersector { Auto, Embree, Sweep };

// All strands, concatenated. Curve c owns points [offsets[c], offsets[c+1]).
struct CurveData {
    std::vector<std::array<float, 4>> points;  // x, y, z, radius (world space)
    std::vector<int32_t> offsets;              // C + 1 entries
    std::vector<float> random;                 // Hair Info > Random per curve
    std::vector<int32_t> material;             // index into SceneDesc::materials
    // Optional curve normals per point (world space; empty = none, particle hair): the major
    // axis of Huang's elliptical cross-section, interpolated linearly along a segment.
    std::vector<std::array<float, 3>> normals;
    // Optional, for shading programs (docs/shading_vm.md): Hair Info > Intercept per point
    // (object-space arc length / curve length, linear along a segment), Hair Info > Length per
    // curve, and the named attributes the programs read, RGBA per point or per curve.
    std::vector<float> intercept;  // P entries or empty
    std::vector<float> length;     // C entries or empty
    struct Attribute {
        std::string name;
        bool point_domain = false;              // else one value per curve
        std::vector<std::array<float, 4>> rgba;  // float attributes as (f, f, f, 1)
    };
    std::vector<Attribute> attributes;
    // Optional: curves kept in their object's space. Cycles applies an object's transform to its
    // curves only when it is a uniform scale (with rotation and translation); other curves are
    // intersected in object space with the ray taken there, so a non-uniform scale or a shear
    // makes their cross-sections elliptical in the world. object[c] indexes object_transforms
    // (-1: points are world space); each transform is world-from-object, row-major 3 x 4.
    std::vector<int32_t> object;  // C entries, or empty: every curve in world space
    std::vector<std::array<double, 12>> object_transforms;
    size_t curve_count() const { return offsets.empty() ? 0 : offsets.size() - 1; }
};

// The determinant of the 3 x 3 part of a row-major 3 x 4 affine matrix (CurveData's
// object_transforms): zero or non-finite for a transform that cannot be inverted.
inline double linear_determinant(const std::array<double, 12>& m) {
    return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
           m[2] * (m[4] * m[9] - m[5] * m[8]);
}

struct MeshData {
    std::vector<std::array<float, 3>> vertices;
    std::vector<std::array<int32_t, 3>> triangles;
    std::vector<int32_t> material;  // per triangle
    // Optional corner normals per triangle (x, y, z of corners 0, 1, 2): Cycles' smooth shading
    // normal N is their barycentric interpolation. Empty: N = the face normal.
    std::vector<std::array<float, 9>> normals;
    // Optional, for shading programs: the attributes they read on meshes (UV maps), RGBA at each
    // triangle corner (corners 0, 1, 2), interpolated over the triangle as Cycles interpolates
    // corner attributes. Entry i is the programs' attribute i: the same names, in the same
    // order, as CurveData::attributes.
    struct CornerAttribute {
        std::string name;
        std::vector<std::array<float, 12>> corners;  // one row per triangle
    };
    std::vector<CornerAttribute> attributes;
    // Optional: the object of each triangle (any ids; empty: one object). Cycles 4.x's light
    // tree gives each emissive object a subtree of its triangles (render/light_tree.h).
    std::vector<int32_t> object;
    // Optional: 1 where the exporter reversed a triangle's corners (an object with a negative
    // scale, so that Ng points where Blender shows the normal). Cycles keeps the original order,
    // and its hair frame on a triangle, dP/du = v1 - v0 of that order, is v1 - v2 of ours there.
    std::vector<uint8_t> reversed;
};

// One entry of a material's flat weighted closure sum.
// Cycles' default surface colour (diffuse grey): a material without one, an unsupported node, and
// the colour of a diffuse / emission / cycles_hair closure that names none.
constexpr RGB kDefaultSurfaceColor{0.8};

struct ClosureDesc {
    enum class Type { PrincipledHair, Diffuse, Emission, CyclesHair, Model };  // Model: scene_desc.md `hair_model`
    enum class HairModel { Chiang, Huang };  // Principled Hair's model enum (Blender 4.0+)
    Type type = Type::Diffuse;
    HairModel hair_model = HairModel::Chiang;
    RGB weight{1.0};
    // principled_hair: node inputs; `random_from_curve` = the Random socket is unlinked
    // (Cycles then uses the per-curve curve_random; 0 on meshes).
    PrincipledHairInputs hair;
    bool random_from_curve = true;
    // diffuse / emission / cycles_hair
    RGB color = kDefaultSurfaceColor;
    double strength = 1.0;  // emission only
    // hair_model: a zoo model ("kajiya_kay", "epic", ...) or "plugin" (the library at
    // model_path) with named parameters; built by model_factory.h.
    std::string model_name;
    std::string model_path;
    ModelParams model_params;
    // cycles_hair (the legacy Hair BSDF node): component, Offset in radians, RoughnessU / V; defaults
    // the node's, as CyclesHairParams holds them (models/cycles_hair.h).
    bool transmission = false;
    double offset = CyclesHairParams{}.offset, roughness_u = CyclesHairParams{}.roughness_u,
           roughness_v = CyclesHairParams{}.roughness_v;
    // Inputs driven by the material's shading program: the input takes the register's value
    // (3 consecutive registers for a colour) at each hit instead of the constant above.
    enum class Input {
        Color, Melanin, MelaninRedness, Tint, AbsorptionCoefficient, Roughness, RadialRoughness, Coat, Ior,
        Offset, RandomColor, RandomRoughness, Random, AspectRatio, Reflection, Transmission, SecondaryReflection,
        Strength,  // emission; `Color` is the diffuse / emission / legacy Hair BSDF colour too
        Weight,    // the closure weight (Mix Shader factors); `weight` above is then 1
        RoughnessU, RoughnessV  // the legacy Hair BSDF's (`Offset` and `Color` too)
    };
    struct Link {
        Input input;
        int32_t reg;
    };
    std::vector<Link> links;
};

// Which sides of a material's emissive triangles next-event estimation samples (Cycles 4.x's
// Material > Settings > Emission Sampling; Cycles 3.x's Multiple Importance is FrontBack or
// None). Auto: FrontBack when the emission estimate's largest channel exceeds 0.5 (Cycles' rule).
enum class EmissionSampling { Auto, None, Front, Back, FrontBack };

struct MaterialDesc {
    std::string name;
    EmissionSampling emission_sampling = EmissionSampling::Auto;
    std::vector<ClosureDesc> closures;
    ShadingProgram program;  // empty: every input is constant
};

enum class CameraType { Perspective, Orthographic };
enum class SensorFit { Auto, Horizontal, Vertical };

struct CameraDesc {
    CameraType type = CameraType::Perspective;
    std::array<double, 16> matrix_world{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // row-major 4x4
    int width = 64, height = 64;
    double pixel_aspect = 1.0;  // pixel_aspect_y / pixel_aspect_x
    SensorFit sensor_fit = SensorFit::Auto;
    double sensor_width = 36.0, sensor_height = 24.0, lens = 50.0;  // mm
    double ortho_scale = 1.0;
    double shift_x = 0.0, shift_y = 0.0;
    double clip_start = 0.1, clip_end = 100.0;
};

enum class LightType { Sun, Point, Spot, Area };
enum class AreaShape { Square, Rectangle, Disk, Ellipse };

// Blender's raw light values (scene_desc.md); Cycles' normalisation happens in lights.h.
struct LightDesc {
    LightType type = LightType::Point;
    RGB strength{1.0};                      // color x energy (x 2^exposure), W or W/m^2 for the sun
    std::array<double, 3> position{0, 0, 0};
    std::array<double, 3> direction{0, 0, 1};  // SUN: towards the light; SPOT: the spot axis (light's -Z)
    std::array<double, 16> matrix_world{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // row-major
    bool has_matrix = false;                // SPOT: use matrix_world for the cone (object scale included)
    double angle = 0.0;                     // SUN: full angular diameter (rad)
    double radius = 0.0;                    // POINT / SPOT: shadow_soft_size
    bool soft_falloff = true;               // POINT / SPOT (Blender 4.x default on)
    bool spot_cosine = false;               // SPOT: Cycles < 4.0's cone, smoothstep x cos(angle to the axis)
    double spot_size = kPi / 4, spot_blend = 0.15;
    AreaShape shape = AreaShape::Square;
    double size_x = 1.0, size_y = 1.0;
    double spread = kPi;
    bool normalize = true;                  // Blender 4.x Light.normalize
    bool use_mis = true;                    // Light > Cycles > Multiple Importance
    bool visible_camera = true;             // Object > Visibility > Camera (Blender's default for lights: off)
};

struct IntegratorSettings {
    int samples = 16;
    uint32_t seed = 0;
    int max_bounces = 12, diffuse_bounces = 4, glossy_bounces = 4, transmission_bounces = 12;
    int transparent_bounces = 8, min_light_bounces = 0;
    enum class Filter { BlackmanHarris, Gaussian, Box } filter = Filter::BlackmanHarris;
    double filter_width = 1.5;  // pixels (Box is always 1 px, as Blender's sync forces it)
    double exposure = 1.0;
    bool film_transparent = false;
    double light_sampling_threshold = 0.0;  // unbiased in Cycles; ignored here (noise only)
    // Pick NEE lights with Cycles' light tree (render/light_tree.h; scene.cycles.use_light_tree,
    // Blender >= 4.0) instead of uniformly (Blender 3.x). Changes the expected image where a
    // closure's reported pdf is not its sampling density (hair).
    bool light_tree = false;
    double filter_glossy = 0.0;             // Cycles' blur_glossy; 0 = off
    double clamp_direct = 0.0, clamp_indirect = 0.0;  // 0 = off
    TiltConvention tilt = TiltConvention::Blender42;
    // Blender < 3.6: Chiang's longitudinal sample numbers from Cycles' per-hit LCG, correlated
    // along a path (LongitudinalNumbers in models/chiang.h); brightens multiple scattering.
    bool chiang_lcg = false;
    Accuracy accuracy = Accuracy::Cycles;   // Chiang's special functions: Cycles' or exact
    // Huang's BSDF sampler: Cycles' (its energy-estimate weight, pdf 1: Cycles' estimator, so the
    // image's expected value is Cycles') or the mixture with an exact pdf (docs/huang.md §10).
    HuangSampler huang_sampler = HuangSampler::Cycles;
    // Huang's energy-compensation tables: Cycles 4.x's or 5.x's (the exporter picks the running
    // Blender's; docs/blender5.md).
    GlassAlbedoTable huang_glass_albedo_table = GlassAlbedoTable::Cycles4;
    // Extra passes besides Combined (docs/engine.md, Passes).
    bool pass_hair_lobes = false;  // R, TT, TRT, TRRT+ of the light leaving the first hair hit
    bool pass_depth = false;       // camera-space depth of the first hit
    bool pass_normal = false;      // world-space shading normal of the first hit
    bool pass_variance = false;    // variance of the pixel's mean radiance (squared standard error)
    // Trace a tile's camera rays as one coherent Embree stream (the wavefront's camera stream,
    // render/wavefront.h); the same image at float rounding. Off: one rtcIntersect1 per camera ray.
    bool camera_ray_stream = false;
    // The wavefront path tracer (render/wavefront.h), the default: each bounce of a tile's paths
    // traced as Embree streams, hits shaded grouped by material; each path the per-pixel one to
    // float precision. Off: the per-pixel loop (render/integrator.h), one path at a time.
    bool wavefront = true;
    // The wavefront's bounce and shadow rays as Embree streams (rtcIntersect1M / rtcOccluded1M, whose
    // packets return some hits a rounding step away); off: one rtcIntersect1 / rtcOccluded1 per ray,
    // and without camera_ray_stream the image is the per-pixel loop's bit for bit.
    bool wavefront_streams = true;
    // The wavefront shades the hits of materials that are one Principled Hair (Chiang) closure through
    // the float32 batch kernels (docs/simd.md), a material's hits together; Filter Glossy's blurred hits,
    // the lobe passes' first hits and Cycles < 3.6's LCG stay on the scalar double path. The same image
    // in expectation (float instead of double rounding). Off: every hit on the scalar path.
    bool wavefront_kernels = true;
};

// An equirectangular Environment Texture on the world, as Cycles reads it: the lookup vector
// is matrix x (direction, 1) (a Mapping node; identity without one), u = 0.5 - atan2(y, x) / 2 pi,
// v = 1 - acos(z) / pi (v = 1 at the zenith), texels repeat in both axes, Linear (bilinear) or
// Closest interpolation. World radiance = world + weight x texture(direction).
struct EnvironmentDesc {
    int width = 0, height = 0;
    std::vector<float> pixels;  // (height, width, 3) scene-linear RGB; row 0 = the image's top row
    RGB weight{0.0};            // Background strength x Mix / Add weights
    bool closest = false;       // interpolation Closest (else Linear)
    bool srgb_encoded = false;  // pixels hold sRGB-encoded values, decoded after the lookup (Cycles)
    std::array<double, 12> matrix{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // row-major 3 x 4
    bool has_texture() const { return width > 0 && height > 0 && pixels.size() == size_t(width) * height * 3; }
};

// An image the shading programs sample (Image Texture nodes; docs/scene_desc.md `images`).
struct ImageDesc {
    std::string name;
    int width = 0, height = 0;
    std::vector<float> pixels;  // (height, width, 4) scene-linear RGBA; row 0 = the image's top row
    bool valid() const { return width > 0 && height > 0 && pixels.size() == size_t(width) * height * 4; }
};

struct SceneDesc {
    CurveData curves;
    CurveShape curve_shape = CurveShape::Thick;
    int curve_subdivisions = 2;
    CurveIntersector curve_intersector = CurveIntersector::Auto;
    // Cull back faces of THICK curves. Off in Cycles: Blender's Embree build flag
    // BACKFACE_CULLING_CURVES only affects round *linear* curves, not Catmull-Rom sweeps
    // (checked against Cycles 4.5 renders; docs/scene_desc.md).
    bool cull_curve_back_faces = false;
    MeshData meshes;
    std::vector<MaterialDesc> materials;
    CameraDesc camera;
    std::vector<LightDesc> lights;
    RGB world{0.0};
    EnvironmentDesc world_texture;
    // The world's inputs computed by nodes (docs/shading_vm.md): the loader runs this program once
    // and sets `world` and world_texture.weight from these registers (-1: the constant above).
    ShadingProgram world_program;
    int32_t world_color_register = -1, world_texture_weight_register = -1;
    std::vector<ImageDesc> images;  // read by the shading programs' ImageTexture op
    // World > Settings > Sampling (4.x Method != None, 3.x Multiple Importance). Even on, a
    // world without a texture is not sampled as a light (render/lights.h).
    bool world_mis = true;
    // World > Settings > Map Resolution for the light tree's importance map (res x res / 2); 0:
    // Cycles' automatic choice (the environment texture's size). render/lights.cpp.
    int world_map_resolution = 0;
    IntegratorSettings integrator;
};

// Drops or repairs content the renderer cannot use, in place, and returns one warning per
// kind of problem: curves with non-finite keys, fewer than two keys, no length or no
// radius are dropped; negative / non-finite radii become 0; material indices outside the
// list (e.g. -1) get Cycles' default surface (diffuse kDefaultSurfaceColor), appended as the last
// material; triangles with bad indices or non-finite vertices
// are dropped; non-finite light or world values turn the light off; camera values are
// clamped to something renderable.
std::vector<std::string> repair_scene(SceneDesc& scene);

// The materials' shading programs, as repair_scene prepares them: an invalid one (or a link outside
// its registers) is dropped with a warning; a valid one is folded (docs/shading_vm.md: inputs that
// do not depend on the hit become numbers). For callers that shade without rendering; the images
// are read as they are (repair_scene repairs them first).
void repair_programs(SceneDesc& scene, std::vector<std::string>& warnings);

}  // namespace hairbsdf::render
