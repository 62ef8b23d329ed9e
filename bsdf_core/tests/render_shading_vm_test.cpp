// The shading VM (render/shading_vm.h): each op against values worked out by hand from Cycles'
// node definitions, program validation, and the per-hit context.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "hairbsdf/render/shading_vm.h"

using namespace hairbsdf::render;

namespace {

int32_t op(ShadingOp o) { return int32_t(o); }

// A program whose constants are `constants`, with `extra` writable registers after them.
ShadingProgram make_program(std::vector<float> constants, std::vector<int32_t> code, int extra) {
    ShadingProgram p;
    p.constants = std::move(constants);
    p.code = std::move(code);
    p.register_count = int32_t(p.constants.size()) + extra;
    return p;
}

std::vector<float> run(const ShadingProgram& p, const ShadingHitContext& ctx = {}) {
    validate_program(p, ctx.attribute_count, ctx.image_count);
    std::vector<float> r(size_t(p.register_count), -99.0f);
    run_program(p, ctx, r.data());
    return r;
}

float math(MathType t, float a, float b = 0.0f, float c = 0.0f) { return shading_math(t, a, b, c); }

}  // namespace

TEST(ShadingVm, MathSafeOperations) {
    EXPECT_EQ(math(MathType::Divide, 3.0f, 0.0f), 0.0f);
    EXPECT_FLOAT_EQ(math(MathType::Divide, 3.0f, 4.0f), 0.75f);
    EXPECT_EQ(math(MathType::Power, -2.0f, 0.5f), 0.0f);  // negative base, fractional exponent
    EXPECT_FLOAT_EQ(math(MathType::Power, -2.0f, 3.0f), -8.0f);
    EXPECT_FLOAT_EQ(math(MathType::Logarithm, 8.0f, 2.0f), 3.0f);
    EXPECT_EQ(math(MathType::Logarithm, -8.0f, 2.0f), 0.0f);
    EXPECT_EQ(math(MathType::Sqrt, -4.0f), 0.0f);
    EXPECT_FLOAT_EQ(math(MathType::InvSqrt, 4.0f), 0.5f);
    EXPECT_EQ(math(MathType::InvSqrt, 0.0f), 0.0f);
    EXPECT_EQ(math(MathType::Arcsine, 2.0f), std::asin(1.0f));  // clamped to [-1, 1]
    EXPECT_EQ(math(MathType::Arctan2, 0.0f, 0.0f), 0.0f);
    EXPECT_EQ(math(MathType::Sign, 0.0f), 0.0f);
    EXPECT_EQ(math(MathType::Sign, -3.0f), -1.0f);
}

TEST(ShadingVm, MathRoundingAndPeriodic) {
    EXPECT_EQ(math(MathType::Round, -2.5f), -2.0f);  // floor(a + 0.5)
    EXPECT_EQ(math(MathType::Trunc, -2.7f), -2.0f);
    EXPECT_FLOAT_EQ(math(MathType::Fraction, -0.25f), 0.75f);
    EXPECT_FLOAT_EQ(math(MathType::Modulo, -1.0f, 3.0f), -1.0f);        // fmod: sign of a
    EXPECT_FLOAT_EQ(math(MathType::FlooredModulo, -1.0f, 3.0f), 2.0f);  // sign of b
    EXPECT_EQ(math(MathType::Modulo, 1.0f, 0.0f), 0.0f);
    EXPECT_FLOAT_EQ(math(MathType::Snap, 7.0f, 3.0f), 6.0f);
    EXPECT_FLOAT_EQ(math(MathType::Wrap, 5.0f, 3.0f, 1.0f), 1.0f);  // into [1, 3)
    EXPECT_FLOAT_EQ(math(MathType::Wrap, 5.0f, 1.0f, 1.0f), 1.0f);  // empty range: min
    EXPECT_FLOAT_EQ(math(MathType::PingPong, 5.0f, 2.0f), 1.0f);
    EXPECT_FLOAT_EQ(math(MathType::PingPong, 3.0f, 2.0f), 1.0f);
    EXPECT_EQ(math(MathType::PingPong, 3.0f, 0.0f), 0.0f);
}

TEST(ShadingVm, MathComparisonsAndSmooth) {
    EXPECT_EQ(math(MathType::Compare, 1.0f, 1.05f, 0.1f), 1.0f);
    EXPECT_EQ(math(MathType::Compare, 1.0f, 1.2f, 0.1f), 0.0f);
    EXPECT_EQ(math(MathType::LessThan, 1.0f, 2.0f), 1.0f);
    EXPECT_EQ(math(MathType::GreaterThan, 1.0f, 2.0f), 0.0f);
    EXPECT_FLOAT_EQ(math(MathType::SmoothMin, 1.0f, 1.0f, 1.0f), 1.0f - 1.0f / 6.0f);
    EXPECT_FLOAT_EQ(math(MathType::SmoothMax, 1.0f, 1.0f, 1.0f), 1.0f + 1.0f / 6.0f);
    EXPECT_FLOAT_EQ(math(MathType::SmoothMin, 1.0f, 3.0f, 1.0f), 1.0f);  // farther apart than k
    EXPECT_FLOAT_EQ(math(MathType::MultiplyAdd, 2.0f, 3.0f, 4.0f), 10.0f);
    EXPECT_FLOAT_EQ(math(MathType::Degrees, 3.14159265f), 180.0f);
}

TEST(ShadingVm, MathClampFlag) {
    // r2 = clamp(0.7 + 0.6), r3 = 0.7 + 0.6 unclamped
    const auto p = make_program({0.7f, 0.6f}, {op(ShadingOp::Math), 0, 1, 2, 0, 1, 0,  //
                                               op(ShadingOp::Math), 0, 0, 3, 0, 1, 0},
                                2);
    const auto r = run(p);
    EXPECT_EQ(r[2], 1.0f);
    EXPECT_FLOAT_EQ(r[3], 1.3f);
}

TEST(ShadingVm, MapRangeTypes) {
    EXPECT_FLOAT_EQ(shading_map_range(MapRangeType::Linear, 0.25f, 0, 1, 10, 20, 4), 12.5f);
    EXPECT_FLOAT_EQ(shading_map_range(MapRangeType::Linear, 2.0f, 0, 1, 10, 20, 4), 30.0f);  // no clamp here
    EXPECT_FLOAT_EQ(shading_map_range(MapRangeType::Stepped, 0.55f, 0, 1, 0, 1, 4), 0.5f);   // floor(2.75) / 4
    EXPECT_EQ(shading_map_range(MapRangeType::Stepped, 0.55f, 0, 1, 0, 1, 0), 0.0f);
    EXPECT_FLOAT_EQ(shading_map_range(MapRangeType::SmoothStep, 0.25f, 0, 1, 0, 1, 4), 0.15625f);
    EXPECT_FLOAT_EQ(shading_map_range(MapRangeType::SmoothStep, 0.25f, 1, 0, 0, 1, 4), 0.84375f);  // reversed
    EXPECT_FLOAT_EQ(shading_map_range(MapRangeType::SmootherStep, 0.25f, 0, 1, 0, 1, 4), 0.103515625f);
    EXPECT_FLOAT_EQ(shading_map_range(MapRangeType::SmootherStep, 2.0f, 0, 1, 0, 1, 4), 1.0f);
    EXPECT_EQ(shading_map_range(MapRangeType::Linear, 0.5f, 1, 1, 10, 20, 4), 0.0f);  // empty from-range
}

TEST(ShadingVm, MapRangeClampInProgram) {
    // constants: value 2, from 0..1, to 10..0 (reversed), steps 4; clamped and unclamped
    const auto p = make_program({2.0f, 0.0f, 1.0f, 10.0f, 0.0f, 4.0f},
                                {op(ShadingOp::MapRange), 0, 1, 6, 0, 1, 2, 3, 4, 5,  //
                                 op(ShadingOp::MapRange), 0, 0, 7, 0, 1, 2, 3, 4, 5},
                                2);
    const auto r = run(p);
    EXPECT_EQ(r[6], 0.0f);  // -10 clamped into [0, 10]
    EXPECT_FLOAT_EQ(r[7], -10.0f);
}

TEST(ShadingVm, ClampModes) {
    // value 5, min 3, max 1: min-max gives max(min(...)) = 1, range swaps to [1, 3] -> 3
    const auto p = make_program({5.0f, 3.0f, 1.0f},
                                {op(ShadingOp::Clamp), 0, 3, 0, 1, 2, op(ShadingOp::Clamp), 1, 4, 0, 1, 2}, 2);
    const auto r = run(p);
    EXPECT_EQ(r[3], 1.0f);
    EXPECT_EQ(r[4], 3.0f);
}

TEST(ShadingVm, MixBlendModes) {
    const float a[3] = {0.25f, 0.75f, 0.5f}, b[3] = {0.5f, 0.25f, 0.0f};
    float out[3];
    auto mix = [&](MixBlend blend, float t) {
        shading_mix(blend, t, a, b, out);
        return std::vector<float>(out, out + 3);
    };
    auto expect3 = [](std::vector<float> got, float x, float y, float z) {
        EXPECT_FLOAT_EQ(got[0], x);
        EXPECT_FLOAT_EQ(got[1], y);
        EXPECT_FLOAT_EQ(got[2], z);
    };
    expect3(mix(MixBlend::Mix, 0.5f), 0.375f, 0.5f, 0.25f);
    expect3(mix(MixBlend::Add, 0.5f), 0.5f, 0.875f, 0.5f);
    expect3(mix(MixBlend::Multiply, 1.0f), 0.125f, 0.1875f, 0.0f);
    expect3(mix(MixBlend::Subtract, 1.0f), -0.25f, 0.5f, 0.5f);
    expect3(mix(MixBlend::Screen, 1.0f), 1 - 0.5f * 0.75f, 1 - 0.75f * 0.25f, 0.5f);
    expect3(mix(MixBlend::Divide, 1.0f), 0.5f, 3.0f, 0.5f);  // division by 0 keeps a
    expect3(mix(MixBlend::Difference, 1.0f), 0.25f, 0.5f, 0.5f);
    expect3(mix(MixBlend::Darken, 1.0f), 0.25f, 0.25f, 0.0f);
    expect3(mix(MixBlend::Lighten, 1.0f), 0.5f, 0.75f, 0.5f);
    // overlay: a < 0.5 -> a (1 - t + 2 t b); else 1 - (1 - t + 2 t (1 - b)) (1 - a)
    expect3(mix(MixBlend::Overlay, 1.0f), 0.25f, 1 - 1.5f * 0.25f, 1 - 2.0f * 0.5f);
    expect3(mix(MixBlend::LinearLight, 1.0f), 0.25f, 0.25f, -0.5f);
    expect3(mix(MixBlend::Exclusion, 1.0f), 0.5f, 0.625f, 0.5f);
}

TEST(ShadingVm, MixFactorAndResultClamp) {
    // constants: fac 2, a = (0.5, 0.5, 0.5), b = (1, 1, 1); ADD blend
    const std::vector<float> k = {2.0f, 0.5f, 0.5f, 0.5f, 1.0f, 1.0f, 1.0f};
    const int add = int(MixBlend::Add);
    const auto p = make_program(k,
                                {op(ShadingOp::MixColor), add, 0, 7, 0, 1, 4,    // no clamps: 0.5 + 2 x 1
                                 op(ShadingOp::MixColor), add, 1, 10, 0, 1, 4,   // factor clamp: 0.5 + 1
                                 op(ShadingOp::MixColor), add, 3, 13, 0, 1, 4},  // and result clamp
                                9);
    const auto r = run(p);
    EXPECT_FLOAT_EQ(r[7], 2.5f);
    EXPECT_FLOAT_EQ(r[10], 1.5f);
    EXPECT_EQ(r[13], 1.0f);
}

TEST(ShadingVm, MixFloatAndVector) {
    // fac 0.25, a 2, b 6 -> 3; vector non-uniform fac (0, 0.5, 1) between (0,0,0) and (4,4,4)
    const auto p = make_program({0.25f, 2.0f, 6.0f, 0.0f, 0.5f, 1.0f, 0.0f, 0.0f, 0.0f, 4.0f, 4.0f, 4.0f},
                                {op(ShadingOp::MixFloat), 1, 12, 0, 1, 2,  //
                                 op(ShadingOp::MixVector), 1, 1, 13, 3, 6, 9},
                                4);
    const auto r = run(p);
    EXPECT_FLOAT_EQ(r[12], 3.0f);
    EXPECT_FLOAT_EQ(r[13], 0.0f);
    EXPECT_FLOAT_EQ(r[14], 2.0f);
    EXPECT_FLOAT_EQ(r[15], 4.0f);
}

TEST(ShadingVm, ColorRampTableLookup) {
    // a 3-entry table: black, (1, 2, 3, 1), (2, 2, 2, 0.5); fac in register 12
    std::vector<float> k = {0, 0, 0, 0, 1, 2, 3, 1, 2, 2, 2, 0.5f, 0.25f, 1.5f};
    const auto p = make_program(k,
                                {op(ShadingOp::ColorRamp), 1, 0, 3, 14, 17, 12,  // linear at 0.25: half way to entry 1
                                 op(ShadingOp::ColorRamp), 0, 0, 3, 18, 21, 12,  // constant: entry 0
                                 op(ShadingOp::ColorRamp), 1, 0, 3, 22, 25, 13},  // fac > 1: last entry
                                12);
    const auto r = run(p);
    EXPECT_FLOAT_EQ(r[14], 0.5f);
    EXPECT_FLOAT_EQ(r[15], 1.0f);
    EXPECT_FLOAT_EQ(r[16], 1.5f);
    EXPECT_FLOAT_EQ(r[17], 0.5f);
    EXPECT_EQ(r[18], 0.0f);
    EXPECT_EQ(r[21], 0.0f);
    EXPECT_EQ(r[22], 2.0f);
    EXPECT_EQ(r[25], 0.5f);
}

TEST(ShadingVm, ColourAdjustments) {
    // colour (0.25, -1, 0.5), gamma 2, fac 0.5, bright 0.1, contrast 0.2, zero
    const auto p = make_program({0.25f, -1.0f, 0.5f, 2.0f, 0.5f, 0.1f, 0.2f, 0.0f},
                                {op(ShadingOp::Gamma), 8, 0, 3,                 // pow where > 0
                                 op(ShadingOp::Gamma), 11, 0, 7,                // gamma 0 -> white
                                 op(ShadingOp::Invert), 14, 4, 0,               // half way to 1 - c
                                 op(ShadingOp::BrightContrast), 17, 0, 5, 6},  // max(1.2 c + 0, 0)
                                12);
    const auto r = run(p);
    EXPECT_FLOAT_EQ(r[8], 0.0625f);
    EXPECT_EQ(r[9], -1.0f);
    EXPECT_FLOAT_EQ(r[10], 0.25f);
    EXPECT_EQ(r[11], 1.0f);
    EXPECT_EQ(r[13], 1.0f);
    EXPECT_FLOAT_EQ(r[14], 0.5f);
    EXPECT_FLOAT_EQ(r[15], 0.5f);
    EXPECT_FLOAT_EQ(r[17], 0.3f);
    EXPECT_EQ(r[18], 0.0f);
    EXPECT_FLOAT_EQ(r[19], 0.6f);
}

TEST(ShadingVm, ConversionsHairInfoAndAttributes) {
    // weights (0.2, 0.7, 0.1) at 0; colour (1, 2, 3) at 3
    const auto p = make_program({0.2f, 0.7f, 0.1f, 1.0f, 2.0f, 3.0f},
                                {op(ShadingOp::Luminance), 6, 3, 0, op(ShadingOp::Average), 7, 3,
                                 op(ShadingOp::HairInfo), 0, 8, op(ShadingOp::HairInfo), 1, 9,
                                 op(ShadingOp::HairInfo), 2, 10, op(ShadingOp::HairInfo), 3, 11,
                                 op(ShadingOp::Attribute), 1, 12, op(ShadingOp::Copy), 17, 9},
                                12);
    const float attributes[8] = {9, 9, 9, 9, 0.3f, 0.6f, 0.9f, 0.5f};
    ShadingHitContext ctx;
    ctx.random = 0.125f;
    ctx.intercept = 0.75f;
    ctx.length = 2.5f;
    ctx.is_strand = 1.0f;
    ctx.attributes = attributes;
    ctx.attribute_count = 2;
    const auto r = run(p, ctx);
    EXPECT_FLOAT_EQ(r[6], 0.2f + 1.4f + 0.3f);
    EXPECT_FLOAT_EQ(r[7], 2.0f);
    EXPECT_EQ(r[8], 0.125f);
    EXPECT_EQ(r[9], 0.75f);
    EXPECT_EQ(r[10], 2.5f);
    EXPECT_EQ(r[11], 1.0f);
    EXPECT_FLOAT_EQ(r[12], 0.3f);
    EXPECT_FLOAT_EQ(r[14], 0.9f);
    EXPECT_FLOAT_EQ(r[15], 0.6f);  // Fac: the average
    EXPECT_FLOAT_EQ(r[16], 0.5f);  // Alpha
    EXPECT_EQ(r[17], 0.75f);
    // Registers after the constants start at 0 on every run.
    const auto q = make_program({1.0f}, {}, 2);
    const auto z = run(q);
    EXPECT_EQ(z[1], 0.0f);
    EXPECT_EQ(z[2], 0.0f);
}

TEST(ShadingVm, ValidationNamesTheProblem) {
    auto message = [](const ShadingProgram& p, int attributes = 0) -> std::string {
        try {
            validate_program(p, attributes);
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "";
    };
    EXPECT_NE(message(make_program({1.0f}, {op(ShadingOp::Copy), 0, 0}, 1)).find("constants are read-only"),
              std::string::npos);
    EXPECT_NE(message(make_program({1.0f}, {99, 0, 0}, 1)).find("unknown opcode 99"), std::string::npos);
    EXPECT_NE(message(make_program({1.0f}, {op(ShadingOp::Math), 0, 0, 1, 0, 0}, 1)).find("truncated"),
              std::string::npos);
    EXPECT_NE(message(make_program({1.0f}, {op(ShadingOp::Copy), 1, 7}, 1)).find("reads register 7"),
              std::string::npos);
    EXPECT_NE(message(make_program({1.0f}, {op(ShadingOp::Math), 77, 0, 1, 0, 0, 0}, 1)).find("math type 77"),
              std::string::npos);
    EXPECT_NE(message(make_program({}, {op(ShadingOp::Attribute), 2, 0}, 5), 2).find("attribute index 2"),
              std::string::npos);
    EXPECT_NE(message(make_program({0, 0, 0, 0}, {op(ShadingOp::ColorRamp), 1, 0, 2, 4, 7, 0}, 5)).find("ramp table"),
              std::string::npos);
    EXPECT_EQ(message(make_program({1.0f}, {op(ShadingOp::Copy), 1, 0}, 1)), "");
}

TEST(ShadingVm, DeclaredOperandsAreDistinctArgumentsOfTheirInstruction) {
    const auto& ops = shading_instruction_set().ops;
    for (size_t i = 0; i < ops.size(); ++i) {
        const ShadingOpInfo& info = ops[i];
        SCOPED_TRACE(info.name);
        EXPECT_EQ(int32_t(info.op), int32_t(i) + 1);  // in opcode order, from 1
        std::vector<int> args;
        for (const ShadingOperandSpec& o : info.operands) {
            EXPECT_GE(o.arg, 0);
            EXPECT_LT(o.arg, info.argument_count) << o.what;
            args.push_back(o.arg);
            if (o.width_arg < 0) {
                EXPECT_GE(o.width, 1) << o.what;
            } else {
                EXPECT_LT(o.width_arg, info.argument_count) << o.what;
                EXPECT_GE(o.width_per_arg, 1) << o.what;
            }
        }
        std::sort(args.begin(), args.end());
        EXPECT_EQ(std::adjacent_find(args.begin(), args.end()), args.end()) << "an argument declared twice";
        for (const ShadingOperandSpec& o : info.operands)  // a width's argument is a number, not a register
            EXPECT_FALSE(o.width_arg >= 0 && std::binary_search(args.begin(), args.end(), o.width_arg)) << o.what;
    }
}

TEST(ShadingVm, OperandWidthsFollowTheirArguments) {
    const int32_t mix_vector = op(ShadingOp::MixVector);
    auto fac_width = [&](int32_t non_uniform) {
        const std::vector<int32_t> code = {mix_vector, non_uniform, 0, 0, 3, 0, 0};
        for (const ShadingOperand& o : instruction_operands(code.data()))
            if (o.arg == 3) return o.width;
        return 0;
    };
    EXPECT_EQ(fac_width(0), 1);
    EXPECT_EQ(fac_width(1), 3);
    const std::vector<int32_t> ramp = {op(ShadingOp::ColorRamp), 0, 0, 5, 20, 23, 24};
    EXPECT_EQ(instruction_operands(ramp.data()).front().width, 20);  // the table: 4 x size
    // The VM validates with these widths: a non-uniform factor at the last register reads past it.
    EXPECT_THROW(validate_program(make_program({}, {mix_vector, 1, 0, 0, 3, 0, 0}, 4), 0), std::invalid_argument);
    EXPECT_NO_THROW(validate_program(make_program({}, {mix_vector, 0, 0, 0, 3, 0, 0}, 4), 0));
    EXPECT_THROW(validate_program(make_program({}, {mix_vector, 2, 0, 0, 0, 0, 0}, 4), 0), std::invalid_argument);
}

// ---------------------------------------------------------------------------- Image Texture

namespace {

// A 4 x 2 test image: texel (column c, row r from the bottom) = (10 r + c, 1, c, alpha), stored
// top row first as the scene's images are.
struct TestImage {
    std::vector<float> rgba;
    ShadingImage image;
    explicit TestImage(float alpha = 1.0f) {
        for (int row = 0; row < 2; ++row) {
            const int r = 1 - row;  // row 0 of the buffer is the top one (r = 1)
            for (int c = 0; c < 4; ++c) {
                const float texel[4] = {10.0f * float(r) + float(c), 1.0f, float(c), alpha};
                rgba.insert(rgba.end(), texel, texel + 4);
            }
        }
        image = {4, 2, rgba.data()};
    }
};

std::array<float, 4> lookup(const ShadingImage& im, ImageInterpolation i, ImageExtension e, float x, float y) {
    std::array<float, 4> out{};
    shading_image_lookup(im, i, e, x, y, out.data());
    return out;
}

constexpr auto kLinear = ImageInterpolation::Linear;
constexpr auto kClosest = ImageInterpolation::Closest;
constexpr auto kCubic = ImageInterpolation::Cubic;
constexpr auto kRepeat = ImageExtension::Repeat;
constexpr auto kExtend = ImageExtension::Extend;
constexpr auto kClip = ImageExtension::Clip;
constexpr auto kMirror = ImageExtension::Mirror;

}  // namespace

TEST(ShadingVmImage, TexelCentresReadTheTexelExactly) {
    const TestImage t;
    for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 4; ++c) {
            const float x = (float(c) + 0.5f) / 4.0f, y = (float(r) + 0.5f) / 2.0f;
            for (auto interp : {kLinear, kClosest}) {
                const auto v = lookup(t.image, interp, kRepeat, x, y);
                EXPECT_EQ(v[0], 10.0f * float(r) + float(c)) << int(interp) << " " << c << " " << r;
                EXPECT_EQ(v[2], float(c));
            }
        }
}

TEST(ShadingVmImage, LinearBlendsAroundTexelCentres) {
    const TestImage t;
    // Half way between the centres of columns 0 and 1 (x = 1 / 4), on row 0's centre.
    EXPECT_FLOAT_EQ(lookup(t.image, kLinear, kRepeat, 0.25f, 0.25f)[0], 0.5f);
    // A quarter of the way from column 1 to 2 and from row 0 to 1: x = (1.5 + 0.25) / 4, y = (0.5 + 0.25) / 2.
    EXPECT_FLOAT_EQ(lookup(t.image, kLinear, kRepeat, 1.75f / 4.0f, 0.75f / 2.0f)[0], 1.25f + 2.5f);
    // Closest: the texel the point lies in, no blending (x = 0.49 -> column 1, y = 0.26 -> row 0).
    EXPECT_EQ(lookup(t.image, kClosest, kRepeat, 0.49f, 0.26f)[0], 1.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kRepeat, 0.51f, 0.76f)[0], 12.0f);
}

TEST(ShadingVmImage, ExtensionModesAtTheLeftEdge) {
    const TestImage t;
    // x = 0: half texel -1, half texel 0 (row 0). Repeat: texel -1 is column 3; Extend and
    // Mirror: column 0; Clip: zero (green = 1 everywhere shows the weight).
    EXPECT_FLOAT_EQ(lookup(t.image, kLinear, kRepeat, 0.0f, 0.25f)[0], 1.5f);
    EXPECT_FLOAT_EQ(lookup(t.image, kLinear, kExtend, 0.0f, 0.25f)[0], 0.0f);
    EXPECT_FLOAT_EQ(lookup(t.image, kLinear, kExtend, 0.0f, 0.25f)[1], 1.0f);
    EXPECT_FLOAT_EQ(lookup(t.image, kLinear, kMirror, 0.0f, 0.25f)[1], 1.0f);
    EXPECT_FLOAT_EQ(lookup(t.image, kLinear, kClip, 0.0f, 0.25f)[1], 0.5f);
    // Closest one and two texels left of the image: Repeat 3, 2; Extend 0, 0; Mirror 0, 1; Clip 0.
    const float x1 = -0.5f / 4.0f, x2 = -1.5f / 4.0f;
    EXPECT_EQ(lookup(t.image, kClosest, kRepeat, x1, 0.25f)[2], 3.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kRepeat, x2, 0.25f)[2], 2.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kExtend, x2, 0.25f)[2], 0.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kMirror, x1, 0.25f)[2], 0.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kMirror, x2, 0.25f)[2], 1.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kClip, x1, 0.25f)[1], 0.0f);
    // Right / top edges: Extend holds the last texel, Mirror folds back onto it, Repeat wraps.
    EXPECT_EQ(lookup(t.image, kClosest, kExtend, 2.3f, 5.0f)[0], 13.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kMirror, 4.5f / 4.0f, 0.25f)[2], 3.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kRepeat, 4.5f / 4.0f, 0.25f)[2], 0.0f);
    EXPECT_EQ(lookup(t.image, kClosest, kClip, 1.0f, 0.25f)[1], 0.0f);  // x = 1 is texel 4: outside
    // Cycles' frac() at a negative integer: x * width = -1 gives texel -2 (fraction 1).
    EXPECT_EQ(lookup(t.image, kClosest, kRepeat, -0.25f, 0.25f)[2], 2.0f);
}

TEST(ShadingVmImage, CubicIsTheUniformBSpline) {
    const TestImage t;
    // At the centre of texel (1, 0) the B-spline weights are (1, 4, 1) / 6 per axis; Extend
    // repeats row 0 below the image: red = (0 + 4 + 2) / 6 + 10 (0 + 0 + 1) / 6.
    EXPECT_NEAR(lookup(t.image, kCubic, kExtend, 1.5f / 4.0f, 0.25f)[0], 1.0f + 10.0f / 6.0f, 1e-5f);
    // The weights sum to 1 everywhere: green (1 everywhere) stays 1.
    for (float x : {0.1f, 0.37f, 0.9f}) EXPECT_NEAR(lookup(t.image, kCubic, kRepeat, x, 0.6f)[1], 1.0f, 1e-6f);
}

TEST(ShadingVmImage, OpWritesColorAndAlphaAndUnassociates) {
    const TestImage t(0.5f);
    ShadingHitContext ctx;
    ctx.images = &t.image;
    ctx.image_count = 1;
    // constants: vector (x, y, 0) at the centre of texel (2, 1); registers 3..6 RGBA, 7..10 RGBA
    const ShadingProgram p = make_program(
        {2.5f / 4.0f, 0.75f, 0.0f},
        {op(ShadingOp::ImageTexture), 0, 1, 0, 0, 3, 0,
         op(ShadingOp::ImageTexture), 0, 1, 0, kImageUnassociateAlpha, 7, 0}, 8);
    const auto r = run(p, ctx);
    EXPECT_EQ(r[3], 12.0f);
    EXPECT_EQ(r[4], 1.0f);
    EXPECT_EQ(r[6], 0.5f);
    EXPECT_EQ(r[7], 24.0f);  // divided by alpha 0.5
    EXPECT_EQ(r[8], 2.0f);
    EXPECT_EQ(r[10], 0.5f);
    // sRGB decode after the lookup: texel (2, 1) green 1 stays 1, blue 2 -> ((2 + 0.055) / 1.055)^2.4
    const ShadingProgram srgb = make_program(
        {2.5f / 4.0f, 0.75f, 0.0f}, {op(ShadingOp::ImageTexture), 0, 1, 0, kImageSrgbDecode, 3, 0}, 4);
    const auto rs = run(srgb, ctx);
    EXPECT_FLOAT_EQ(rs[4], 1.0f);
    EXPECT_NEAR(rs[5], std::pow(2.055f / 1.055f, 2.4f), 1e-5f);
    EXPECT_EQ(rs[6], 0.5f);  // alpha is not decoded
    // 0.04 is on the linear segment
    const TestImage dark(1.0f);
    std::vector<float> px = dark.rgba;
    for (size_t i = 0; i < px.size(); i += 4) px[i] = 0.04f;
    const ShadingImage dark_image{4, 2, px.data()};
    ctx.images = &dark_image;
    EXPECT_FLOAT_EQ(run(srgb, ctx)[3], 0.04f / 12.92f);
    ctx.images = &t.image;
    // an image index outside the context's images is rejected, as are bad enums
    EXPECT_THROW(validate_program(p, 0, 0), std::invalid_argument);
    ShadingProgram bad = p;
    bad.code[2] = 3;  // interpolation
    EXPECT_THROW(validate_program(bad, 0, 1), std::invalid_argument);
    bad = p;
    bad.code[3] = 4;  // extension
    EXPECT_THROW(validate_program(bad, 0, 1), std::invalid_argument);
    bad = p;
    bad.code[4] = 4;  // flags
    EXPECT_THROW(validate_program(bad, 0, 1), std::invalid_argument);
}

// Constant folding (fold_program): constant outputs take their value at the zero hit, the
// program keeps only the hit-dependent instructions the other outputs need (with the folded
// values they read as constants), and runs to the same values as the whole program.
TEST(ShadingVmFold, KeepsTheHitDependentInstructionsAndFoldsTheRest) {
    const int32_t mul = int32_t(MathType::Multiply), add = int32_t(MathType::Add);
    // constants 0.2, 3, 0.5 at 0..2; temporaries from 3
    const auto p = make_program({0.2f, 3.0f, 0.5f},
                                {op(ShadingOp::Math), mul, 0, 3, 0, 1, 0,      // r3 = 0.2 x 3: constant
                                 op(ShadingOp::HairInfo), 1, 4,                // r4 = Intercept
                                 op(ShadingOp::Math), mul, 0, 5, 4, 3, 0,      // r5 = r4 x r3
                                 op(ShadingOp::Copy), 6, 2,                    // r6..r8 = (0.5, r4, 0.2):
                                 op(ShadingOp::Copy), 7, 4,                    //   a colour, partly
                                 op(ShadingOp::Copy), 8, 0,                    //   hit-dependent
                                 op(ShadingOp::Math), add, 0, 9, 2, 2, 0,      // r9 = 0.5 + 0.5: constant
                                 op(ShadingOp::HairInfo), 0, 10},              // r10 = Random: read by no output
                                8);
    validate_program(p, 0);
    ShadingHitContext zero;
    zero.is_strand = 1.0f;
    const FoldedProgram f = fold_program(p, zero, {{3, 1}, {5, 1}, {6, 3}, {9, 1}});
    ASSERT_TRUE(f.folded);
    EXPECT_FALSE(f.dynamic[3]);
    EXPECT_EQ(f.values[3], 0.2f * 3.0f);
    EXPECT_FALSE(f.dynamic[9]);
    EXPECT_EQ(f.values[9], 1.0f);
    EXPECT_TRUE(f.dynamic[5]);
    EXPECT_TRUE(f.dynamic[7]);
    EXPECT_FALSE(f.dynamic[6]);
    // HairInfo, the multiply and the three copies; not the constant math nor the unread Random
    const ShadingProgram& q = f.program;
    validate_program(q, 0);
    EXPECT_EQ(q.code.size(), size_t(3 + 7 + 3 * 3));
    EXPECT_EQ(f.slot[7], f.slot[6] + 1);
    EXPECT_EQ(f.slot[8], f.slot[6] + 2);
    for (float intercept : {0.0f, 0.3f, 0.9f}) {
        ShadingHitContext hit;
        hit.intercept = intercept;
        hit.random = 0.7f;
        const auto whole = run(p, hit), kept = run(q, hit);
        for (int32_t r : {5, 6, 7, 8}) EXPECT_EQ(kept[size_t(f.slot[size_t(r)])], whole[size_t(r)]) << r;
    }
    // Only constant outputs: no program at all.
    const FoldedProgram none = fold_program(p, zero, {{3, 1}, {9, 1}});
    ASSERT_TRUE(none.folded);
    EXPECT_TRUE(none.program.empty());
    EXPECT_EQ(none.program.register_count, 0);
    // A temporary written twice is not folded: the program stays as it is.
    const auto twice = make_program({1.0f}, {op(ShadingOp::Copy), 1, 0, op(ShadingOp::HairInfo), 1, 1}, 1);
    EXPECT_FALSE(fold_program(twice, zero, {{1, 1}}).folded);
}
