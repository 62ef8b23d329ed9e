// A small shading VM: the node network feeding a material's closure inputs, compiled once by
// the exporter (plugin/hairbsdf/blender/shading_network.py) and evaluated per hit with Cycles'
// SVM semantics, in float as Cycles computes it (docs/shading_vm.md).
//
// Registers are float slots. Slots [0, constants.size()) hold the program's constants and are
// never written; the rest start at 0 for every evaluation. A colour or vector is 3 consecutive
// slots. An instruction is an opcode followed by a fixed number of int32 arguments
// (`shading_instruction_set()`); `validate_program` checks every slot index once, so `run_program` does
// no bounds checks. Depends on nothing but the standard library: the models never see it.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace hairbsdf::render {

enum class ShadingOp : int32_t {
    Math = 1,            // type, clamp, out, a, b, c
    MapRange = 2,        // type, clamp, out, value, from_min, from_max, to_min, to_max, steps
    Clamp = 3,           // type (ClampType), out, value, min, max
    ColorRamp = 4,       // lookup (RampLookup), table (RGBA x size), size, out_color(3), out_alpha, fac
    MixColor = 5,        // blend, flags (kMixClamp*), out(3), fac, a(3), b(3)
    MixFloat = 6,        // clamp factor, out, fac, a, b
    MixVector = 7,       // non_uniform, clamp factor, out(3), fac (1 or 3), a(3), b(3)
    Invert = 8,          // out(3), fac, color(3)
    Gamma = 9,           // out(3), color(3), gamma
    BrightContrast = 10, // out(3), color(3), bright, contrast
    Copy = 11,           // out, in (one float)
    Luminance = 12,      // out, color(3), weights(3)
    Average = 13,        // out, vector(3)
    HairInfo = 14,       // which (HairInfoOutput), out
    Attribute = 15,      // attribute index, out(5): r, g, b, fac = average(rgb), alpha
    ImageTexture = 16,   // image index, interpolation, extension, flags, out(4): r, g, b, alpha, vector(3)
};

// Image Texture node settings (Cycles' InterpolationType / ExtensionType, in Blender's enum
// order); Smart is evaluated as Cubic, as Cycles' CPU kernel does.
enum class ImageInterpolation : int32_t { Linear = 0, Closest = 1, Cubic = 2 };
enum class ImageExtension : int32_t { Repeat = 0, Extend = 1, Clip = 2, Mirror = 3 };
// Clamp's type (Blender's clamp_type); MixColor's flags; ColorRamp's lookup in its baked table
// (Blender's Constant interpolation steps, every other one is baked and read linearly).
enum class ClampType : int32_t { MinMax = 0, Range = 1 };
constexpr int32_t kMixClampFactor = 1;
constexpr int32_t kMixClampResult = 2;
enum class RampLookup : int32_t { Constant = 0, Linear = 1 };
// ImageTexture flags: divide the interpolated colour by its alpha (Cycles does so when the
// node's Alpha output is used and the image's alpha is associated at load); decode the
// interpolated colour from sRGB (8-bit sRGB images are stored encoded and decoded after the
// lookup, as Cycles does).
constexpr int32_t kImageUnassociateAlpha = 1;
constexpr int32_t kImageSrgbDecode = 2;

// An image a program samples: (height, width, 4) float RGBA, scene-linear, row 0 = the image's
// top row (as Blender shows it; texture v = 0 is the bottom row).
struct ShadingImage {
    int width = 0, height = 0;
    const float* rgba = nullptr;
};

enum class HairInfoOutput : int32_t { Random = 0, Intercept = 1, Length = 2, IsStrand = 3 };

// Cycles' NodeMathType values (the order of Blender's Math node enum).
enum class MathType : int32_t {
    Add = 0, Subtract, Multiply, Divide, Sine, Cosine, Tangent, Arcsine, Arccosine, Arctangent, Power,
    Logarithm, Minimum, Maximum, Round, LessThan, GreaterThan, Modulo, Absolute, Arctan2, Floor, Ceil,
    Fraction, Sqrt, InvSqrt, Sign, Exponent, Radians, Degrees, Sinh, Cosh, Tanh, Trunc, Snap, Wrap, PingPong,
    MultiplyAdd, Compare, SmoothMin, SmoothMax, FlooredModulo,
    Count
};

enum class MapRangeType : int32_t { Linear = 0, Stepped = 1, SmoothStep = 2, SmootherStep = 3 };

// Cycles' NodeMix values (the order of Blender's blend_type enum).
enum class MixBlend : int32_t {
    Mix = 0, Add, Multiply, Subtract, Screen, Divide, Difference, Darken, Lighten, Overlay, Dodge, Burn, Hue,
    Saturation, Value, Color, SoftLight, LinearLight, Exclusion,
    Count
};

// The instruction set as the exporter names it: each opcode with its argument count, and each
// enum under Blender's identifiers for the node setting it stands for. This is the one place
// these numbers are written; the exporter reads them through
// hairbsdf._render.shading_vm_instruction_set().
struct ShadingNamedValue {
    const char* name;
    int32_t value;
};
// A register block an instruction reads or writes, as declared: argument `arg` (0 = the first
// after the opcode) names its first slot; it spans width + width_per_arg * (argument width_arg)
// slots (width_arg -1: just width), so a ColorRamp's table is 4 x size and a non-uniform
// MixVector's factor 3.
struct ShadingOperandSpec {
    int arg;
    int32_t width;
    bool write;
    const char* what;
    int width_arg = -1;
    int32_t width_per_arg = 0;
};
struct ShadingOpInfo {
    const char* name;
    ShadingOp op;
    int32_t argument_count;  // after the opcode
    std::vector<ShadingOperandSpec> operands;  // the arguments that are registers; the others are enums or indices
};
struct ShadingInstructionSet {
    std::vector<ShadingOpInfo> ops;  // in opcode order, from 1
    // "math_types", "map_range_types", "clamp_types", "ramp_interpolations", "mix_blends", "mix_flags",
    // "hair_info_outputs", "image_interpolations", "image_extensions", "image_flags"
    std::vector<std::pair<std::string, std::vector<ShadingNamedValue>>> enums;
};
const ShadingInstructionSet& shading_instruction_set();

struct ShadingProgram {
    std::vector<int32_t> code;
    std::vector<float> constants;
    int32_t register_count = 0;  // constants included
    bool empty() const { return code.empty(); }
};

// What a program may read at one hit.
struct ShadingHitContext {
    float random = 0, intercept = 0, length = 0, is_strand = 0;
    const float* attributes = nullptr;  // RGBA per attribute at the hit (0 where absent)
    int attribute_count = 0;
    const ShadingImage* images = nullptr;  // the scene's images (ImageTexture op)
    int image_count = 0;
};

// Throws std::invalid_argument naming the instruction and what is wrong; `attribute_count`
// bounds the Attribute op's index, `image_count` the ImageTexture op's.
void validate_program(const ShadingProgram& program, int attribute_count, int image_count = 0);

// Evaluates a validated program; `registers` has program.register_count slots.
void run_program(const ShadingProgram& program, const ShadingHitContext& context, float* registers);

// A register block an instruction reads or writes: argument `arg` (0 = the first after the
// opcode) names slots [slot, slot + width). A ColorRamp's table is a read of 4 x size slots.
struct ShadingOperand {
    int arg;
    int32_t slot, width;
    bool write;
    const char* what;
};
// The blocks of the instruction at `code` (its opcode first), whose length has been checked:
// its ShadingOpInfo::operands applied to its arguments. validate_program and fold_program read
// them; the exporter reads the same declaration (shading_vm_instruction_set()["operands"]).
std::vector<ShadingOperand> instruction_operands(const int32_t* code);

// Constant folding, done once when a scene is loaded (render/scene.cpp): the program is run
// with `zero_hit` (Hair Info and attributes 0); an instruction is hit-dependent when it is a
// HairInfo or Attribute op or reads a register such an instruction wrote. `outputs` are the
// register blocks (slot, width) the closure inputs read.
struct FoldedProgram {
    bool folded = false;            // false: a program that writes a register twice or reads a temporary
                                    //   before writing it; keep the program as it is
    std::vector<float> values;      // every register of the program at the zero hit
    std::vector<char> dynamic;      // per register: depends on the hit
    ShadingProgram program;         // the hit-dependent instructions the dynamic outputs need, the constant
                                    //   values they read in its constants; empty when no output is dynamic
    std::vector<int32_t> slot;      // per register: its slot in `program` (-1: not kept)
};
// `program` must be valid (validate_program).
FoldedProgram fold_program(const ShadingProgram& program, const ShadingHitContext& zero_hit,
                           const std::vector<std::pair<int32_t, int32_t>>& outputs);

// The sRGB transfer function, decoding (0 below 0), in float as Cycles' color_srgb_to_linear:
// images Cycles keeps sRGB-encoded are decoded after the lookup (ImageTexture flag 2, the
// world's Environment Texture).
float srgb_to_linear(float c);

// The single ops, exposed for tests and for the exporter's constant folding checks.
float shading_math(MathType type, float a, float b, float c);
float shading_map_range(MapRangeType type, float value, float from_min, float from_max, float to_min, float to_max,
                        float steps);
void shading_mix(MixBlend blend, float t, const float* a, const float* b, float* out);
// Cycles' image lookup at texture coordinates (x, y) (texel centres at (i + 0.5) / width),
// before any alpha unassociation: RGBA into `out`.
void shading_image_lookup(const ShadingImage& image, ImageInterpolation interpolation, ImageExtension extension,
                          float x, float y, float* out);

}  // namespace hairbsdf::render
