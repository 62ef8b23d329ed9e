// The shading VM; see render/shading_vm.h. Formulas follow Cycles' SVM nodes (math, map range,
// clamp, ramp, mix, invert, gamma, bright/contrast), in float, written from their definitions.
#include "hairbsdf/render/shading_vm.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <stdexcept>

namespace hairbsdf::render {

namespace {

constexpr float kPiF = 3.14159265358979323846f;

float saturate(float x) { return std::min(std::max(x, 0.0f), 1.0f); }
float clampf(float x, float lo, float hi) { return std::min(std::max(x, lo), hi); }
float safe_divide(float a, float b) { return b != 0.0f ? a / b : 0.0f; }

float smoothstep_edges(float edge0, float edge1, float x) {
    if (x < edge0) return 0.0f;
    if (x >= edge1) return 1.0f;
    const float t = (x - edge0) / (edge1 - edge0);
    return (3.0f - 2.0f * t) * (t * t);
}

float smootherstep_edges(float edge0, float edge1, float x) {
    const float t = clampf(safe_divide(x - edge0, edge1 - edge0), 0.0f, 1.0f);
    return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}

float smooth_min(float a, float b, float k) {
    if (k == 0.0f) return std::fmin(a, b);
    const float h = std::fmax(k - std::fabs(a - b), 0.0f) / k;
    return std::fmin(a, b) - h * h * h * k * (1.0f / 6.0f);
}

// Cycles' colour helpers (rgb <-> hsv) for the Hue / Saturation / Value / Color blends.
void rgb_to_hsv(const float* rgb, float* hsv) {
    const float cmax = std::max(rgb[0], std::max(rgb[1], rgb[2]));
    const float cmin = std::min(rgb[0], std::min(rgb[1], rgb[2]));
    const float delta = cmax - cmin;
    float h = 0.0f, s = 0.0f;
    if (cmax != 0.0f) s = delta / cmax;
    if (s != 0.0f) {
        const float cr = (cmax - rgb[0]) / delta, cg = (cmax - rgb[1]) / delta, cb = (cmax - rgb[2]) / delta;
        if (rgb[0] == cmax) h = cb - cg;
        else if (rgb[1] == cmax) h = 2.0f + cr - cb;
        else h = 4.0f + cg - cr;
        h /= 6.0f;
        if (h < 0.0f) h += 1.0f;
    }
    hsv[0] = h;
    hsv[1] = s;
    hsv[2] = cmax;
}

void hsv_to_rgb(const float* hsv, float* rgb) {
    float h = hsv[0];
    const float s = hsv[1], v = hsv[2];
    if (s == 0.0f) {
        rgb[0] = rgb[1] = rgb[2] = v;
        return;
    }
    if (h == 1.0f) h = 0.0f;
    h *= 6.0f;
    const float i = std::floor(h), f = h - i;
    const float p = v * (1.0f - s), q = v * (1.0f - s * f), t = v * (1.0f - s * (1.0f - f));
    const float table[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
    const int k = std::min(std::max(int(i), 0), 5);
    rgb[0] = table[k][0];
    rgb[1] = table[k][1];
    rgb[2] = table[k][2];
}

// a + t (b - a), Cycles' interp.
float lerp(float a, float b, float t) { return a + t * (b - a); }

void ramp_lookup(const float* table, int size, bool interpolate, float fac, float* rgba) {
    const float f = saturate(fac) * float(size - 1);
    const int i = std::min(std::max(int(f), 0), size - 1);  // NaN: int() is not reached for NaN after saturate
    const float t = f - float(i);
    const float* a = table + 4 * i;
    for (int c = 0; c < 4; ++c) rgba[c] = a[c];
    if (interpolate && t > 0.0f) {
        const float* b = a + 4;
        for (int c = 0; c < 4; ++c) rgba[c] = (1.0f - t) * a[c] + t * b[c];
    }
}


// Integer part and fraction of x as Cycles' frac(): the integer is the truncation, one less
// for negative x (so a negative integer x gives x - 1 and fraction 1).
float texel_frac(float x, int& i) {
    i = int(x) - (x < 0.0f ? 1 : 0);
    return x - float(i);
}

// Texel index i of an axis with n texels under an extension mode; -1 = outside (Clip).
int texel_index(int i, int n, ImageExtension extension) {
    switch (extension) {
        case ImageExtension::Repeat: {
            const int m = i % n;
            return m < 0 ? m + n : m;
        }
        case ImageExtension::Extend: return std::min(std::max(i, 0), n - 1);
        case ImageExtension::Clip: return (i < 0 || i >= n) ? -1 : i;
        case ImageExtension::Mirror: {  // reflected copies, the edge texel repeated at the fold
            int m = i % (2 * n);
            if (m < 0) m += 2 * n;
            return m < n ? m : 2 * n - 1 - m;
        }
    }
    return -1;
}

// Adds weight x texel (column ix, row iy from the bottom) to acc; Clip's outside reads 0.
void add_texel(const ShadingImage& im, ImageExtension extension, int ix, int iy, float weight, float* acc) {
    const int cx = texel_index(ix, im.width, extension), cy = texel_index(iy, im.height, extension);
    if (cx < 0 || cy < 0) return;
    const float* t = im.rgba + (size_t(im.height - 1 - cy) * size_t(im.width) + size_t(cx)) * 4;
    for (int c = 0; c < 4; ++c) acc[c] += weight * t[c];
}

// Uniform cubic B-spline weights of the 4 texels around a sample at fraction t.
void bspline_weights(float t, float* w) {
    const float t2 = t * t, t3 = t2 * t;
    w[0] = (1.0f / 6.0f) * (1.0f - 3.0f * t + 3.0f * t2 - t3);
    w[1] = (1.0f / 6.0f) * (4.0f - 6.0f * t2 + 3.0f * t3);
    w[2] = (1.0f / 6.0f) * (1.0f + 3.0f * t + 3.0f * t2 - 3.0f * t3);
    w[3] = (1.0f / 6.0f) * t3;
}

}  // namespace

void shading_image_lookup(const ShadingImage& im, ImageInterpolation interpolation, ImageExtension extension,
                          float x, float y, float* out) {
    for (int c = 0; c < 4; ++c) out[c] = 0.0f;
    if (im.width <= 0 || im.height <= 0 || im.rgba == nullptr) return;
    // Non-finite or huge coordinates (no texel index fits an int): read as 0 / clamped.
    constexpr float kLimit = 1.0e7f;
    x = std::isfinite(x) ? clampf(x, -kLimit, kLimit) : 0.0f;
    y = std::isfinite(y) ? clampf(y, -kLimit, kLimit) : 0.0f;
    const float fx = x * float(im.width), fy = y * float(im.height);
    int ix, iy;
    switch (interpolation) {
        case ImageInterpolation::Closest:
            texel_frac(fx, ix);
            texel_frac(fy, iy);
            add_texel(im, extension, ix, iy, 1.0f, out);
            return;
        case ImageInterpolation::Linear: {
            const float tx = texel_frac(fx - 0.5f, ix), ty = texel_frac(fy - 0.5f, iy);
            float row0[4] = {0, 0, 0, 0}, row1[4] = {0, 0, 0, 0};
            add_texel(im, extension, ix, iy, 1.0f - tx, row0);
            add_texel(im, extension, ix + 1, iy, tx, row0);
            add_texel(im, extension, ix, iy + 1, 1.0f - tx, row1);
            add_texel(im, extension, ix + 1, iy + 1, tx, row1);
            for (int c = 0; c < 4; ++c) out[c] = (1.0f - ty) * row0[c] + ty * row1[c];
            return;
        }
        case ImageInterpolation::Cubic: {
            const float tx = texel_frac(fx - 0.5f, ix), ty = texel_frac(fy - 0.5f, iy);
            float wx[4], wy[4];
            bspline_weights(tx, wx);
            bspline_weights(ty, wy);
            for (int j = 0; j < 4; ++j) {
                float row[4] = {0, 0, 0, 0};
                for (int i = 0; i < 4; ++i) add_texel(im, extension, ix - 1 + i, iy - 1 + j, wx[i], row);
                for (int c = 0; c < 4; ++c) out[c] += wy[j] * row[c];
            }
            return;
        }
    }
}


float shading_math(MathType type, float a, float b, float c) {
    switch (type) {
        case MathType::Add: return a + b;
        case MathType::Subtract: return a - b;
        case MathType::Multiply: return a * b;
        case MathType::Divide: return safe_divide(a, b);
        case MathType::Power:
            if (a < 0.0f && b != float(int(b))) return 0.0f;  // a negative base needs an integer exponent
            return std::pow(a, b);
        case MathType::Logarithm:
            if (a <= 0.0f || b <= 0.0f) return 0.0f;
            return safe_divide(std::log(a), std::log(b));
        case MathType::Sqrt: return std::sqrt(std::max(a, 0.0f));
        case MathType::InvSqrt: return a > 0.0f ? 1.0f / std::sqrt(a) : 0.0f;
        case MathType::Absolute: return std::fabs(a);
        case MathType::Radians: return a * (kPiF / 180.0f);
        case MathType::Degrees: return a * (180.0f / kPiF);
        case MathType::Minimum: return std::fmin(a, b);
        case MathType::Maximum: return std::fmax(a, b);
        case MathType::LessThan: return a < b ? 1.0f : 0.0f;
        case MathType::GreaterThan: return a > b ? 1.0f : 0.0f;
        case MathType::Round: return std::floor(a + 0.5f);
        case MathType::Floor: return std::floor(a);
        case MathType::Ceil: return std::ceil(a);
        case MathType::Fraction: return a - std::floor(a);
        case MathType::Modulo: return b != 0.0f ? std::fmod(a, b) : 0.0f;
        case MathType::FlooredModulo: return b != 0.0f ? a - std::floor(a / b) * b : 0.0f;
        case MathType::Trunc: return a >= 0.0f ? std::floor(a) : std::ceil(a);
        case MathType::Snap: return std::floor(safe_divide(a, b)) * b;
        case MathType::Wrap: {  // wrap a into [c, b)
            const float range = b - c;
            return range != 0.0f ? a - range * std::floor((a - c) / range) : c;
        }
        case MathType::PingPong: {
            if (b == 0.0f) return 0.0f;
            const float x = (a - b) / (b * 2.0f);
            return std::fabs((x - std::floor(x)) * b * 2.0f - b);
        }
        case MathType::Sine: return std::sin(a);
        case MathType::Cosine: return std::cos(a);
        case MathType::Tangent: return std::tan(a);
        case MathType::Sinh: return std::sinh(a);
        case MathType::Cosh: return std::cosh(a);
        case MathType::Tanh: return std::tanh(a);
        case MathType::Arcsine: return std::asin(clampf(a, -1.0f, 1.0f));
        case MathType::Arccosine: return std::acos(clampf(a, -1.0f, 1.0f));
        case MathType::Arctangent: return std::atan(a);
        case MathType::Arctan2: return (a == 0.0f && b == 0.0f) ? 0.0f : std::atan2(a, b);
        case MathType::Sign: return a == 0.0f ? 0.0f : (a < 0.0f ? -1.0f : 1.0f);
        case MathType::Exponent: return std::exp(a);
        case MathType::Compare: return (a == b || std::fabs(a - b) <= std::fmax(c, FLT_EPSILON)) ? 1.0f : 0.0f;
        case MathType::MultiplyAdd: return a * b + c;
        case MathType::SmoothMin: return smooth_min(a, b, c);
        case MathType::SmoothMax: return -smooth_min(-a, -b, c);
        case MathType::Count: break;
    }
    return 0.0f;
}

float shading_map_range(MapRangeType type, float value, float from_min, float from_max, float to_min, float to_max,
                        float steps) {
    if (from_max == from_min) return 0.0f;
    float factor = value;
    switch (type) {
        case MapRangeType::Linear: factor = (value - from_min) / (from_max - from_min); break;
        case MapRangeType::Stepped:
            factor = (value - from_min) / (from_max - from_min);
            factor = steps > 0.0f ? std::floor(factor * (steps + 1.0f)) / steps : 0.0f;
            break;
        case MapRangeType::SmoothStep:
            factor = from_min > from_max ? 1.0f - smoothstep_edges(from_max, from_min, value)
                                         : smoothstep_edges(from_min, from_max, value);
            break;
        case MapRangeType::SmootherStep:
            factor = from_min > from_max ? 1.0f - smootherstep_edges(from_max, from_min, value)
                                         : smootherstep_edges(from_min, from_max, value);
            break;
    }
    return to_min + factor * (to_max - to_min);
}

void shading_mix(MixBlend blend, float t, const float* a, const float* b, float* out) {
    const float tm = 1.0f - t;
    float r[3] = {a[0], a[1], a[2]};
    switch (blend) {
        case MixBlend::Mix:
            for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], b[i], t);
            break;
        case MixBlend::Add:
            for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], a[i] + b[i], t);
            break;
        case MixBlend::Multiply:
            for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], a[i] * b[i], t);
            break;
        case MixBlend::Subtract:
            for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], a[i] - b[i], t);
            break;
        case MixBlend::Screen:
            for (int i = 0; i < 3; ++i) r[i] = 1.0f - (tm + t * (1.0f - b[i])) * (1.0f - a[i]);
            break;
        case MixBlend::Divide:
            for (int i = 0; i < 3; ++i)
                if (b[i] != 0.0f) r[i] = tm * a[i] + t * a[i] / b[i];
            break;
        case MixBlend::Difference:
            for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], std::fabs(a[i] - b[i]), t);
            break;
        case MixBlend::Darken:
            for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], std::min(a[i], b[i]), t);
            break;
        case MixBlend::Lighten:
            for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], std::max(a[i], b[i]), t);
            break;
        case MixBlend::Overlay:
            for (int i = 0; i < 3; ++i)
                r[i] = a[i] < 0.5f ? a[i] * (tm + 2.0f * t * b[i]) : 1.0f - (tm + 2.0f * t * (1.0f - b[i])) * (1.0f - a[i]);
            break;
        case MixBlend::Dodge:
            for (int i = 0; i < 3; ++i) {
                if (a[i] == 0.0f) continue;
                const float d = 1.0f - t * b[i];
                r[i] = d <= 0.0f ? 1.0f : std::min(a[i] / d, 1.0f);
            }
            break;
        case MixBlend::Burn:
            for (int i = 0; i < 3; ++i) {
                const float d = tm + t * b[i];
                r[i] = d <= 0.0f ? 0.0f : clampf(1.0f - (1.0f - a[i]) / d, 0.0f, 1.0f);
            }
            break;
        case MixBlend::Hue: {
            float hsv_b[3], hsv[3], tmp[3];
            rgb_to_hsv(b, hsv_b);
            if (hsv_b[1] != 0.0f) {
                rgb_to_hsv(a, hsv);
                hsv[0] = hsv_b[0];
                hsv_to_rgb(hsv, tmp);
                for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], tmp[i], t);
            }
            break;
        }
        case MixBlend::Saturation: {
            float hsv[3], hsv_b[3];
            rgb_to_hsv(a, hsv);
            if (hsv[1] != 0.0f) {
                rgb_to_hsv(b, hsv_b);
                hsv[1] = tm * hsv[1] + t * hsv_b[1];
                hsv_to_rgb(hsv, r);
            }
            break;
        }
        case MixBlend::Value: {
            float hsv[3], hsv_b[3];
            rgb_to_hsv(a, hsv);
            rgb_to_hsv(b, hsv_b);
            hsv[2] = tm * hsv[2] + t * hsv_b[2];
            hsv_to_rgb(hsv, r);
            break;
        }
        case MixBlend::Color: {
            float hsv_b[3], hsv[3], tmp[3];
            rgb_to_hsv(b, hsv_b);
            if (hsv_b[1] != 0.0f) {
                rgb_to_hsv(a, hsv);
                hsv[0] = hsv_b[0];
                hsv[1] = hsv_b[1];
                hsv_to_rgb(hsv, tmp);
                for (int i = 0; i < 3; ++i) r[i] = lerp(a[i], tmp[i], t);
            }
            break;
        }
        case MixBlend::SoftLight:
            for (int i = 0; i < 3; ++i) {
                const float screen = 1.0f - (1.0f - b[i]) * (1.0f - a[i]);
                r[i] = tm * a[i] + t * ((1.0f - a[i]) * b[i] * a[i] + a[i] * screen);
            }
            break;
        case MixBlend::LinearLight:
            for (int i = 0; i < 3; ++i) r[i] = a[i] + t * (2.0f * b[i] - 1.0f);
            break;
        case MixBlend::Exclusion:
            for (int i = 0; i < 3; ++i) r[i] = std::max(lerp(a[i], a[i] + b[i] - 2.0f * a[i] * b[i], t), 0.0f);
            break;
        case MixBlend::Count: break;
    }
    out[0] = r[0];
    out[1] = r[1];
    out[2] = r[2];
}

float srgb_to_linear(float c) {
    if (c < 0.04045f) return c < 0.0f ? 0.0f : c * (1.0f / 12.92f);
    return std::pow((c + 0.055f) * (1.0f / 1.055f), 2.4f);
}

const ShadingInstructionSet& shading_instruction_set() {
    static const ShadingInstructionSet set = [] {
        ShadingInstructionSet s;
        // Each op's register blocks: which arguments it reads or writes, and how wide they are.
        auto in = [](int arg, int32_t width, const char* what) { return ShadingOperandSpec{arg, width, false, what}; };
        auto out = [](int arg, int32_t width, const char* what) { return ShadingOperandSpec{arg, width, true, what}; };
        s.ops = {
            {"MATH", ShadingOp::Math, 6, {out(2, 1, "out"), in(3, 1, "a"), in(4, 1, "b"), in(5, 1, "c")}},
            {"MAP_RANGE", ShadingOp::MapRange, 9,
             {out(2, 1, "out"), in(3, 1, "input"), in(4, 1, "input"), in(5, 1, "input"), in(6, 1, "input"),
              in(7, 1, "input"), in(8, 1, "input")}},
            {"CLAMP", ShadingOp::Clamp, 5, {out(1, 1, "out"), in(2, 1, "value"), in(3, 1, "min"), in(4, 1, "max")}},
            {"COLOR_RAMP", ShadingOp::ColorRamp, 6,
             {{1, 0, false, "ramp table", 2, 4}, out(3, 3, "out color"), out(4, 1, "out alpha"), in(5, 1, "fac")}},
            {"MIX_COLOR", ShadingOp::MixColor, 6, {out(2, 3, "out"), in(3, 1, "fac"), in(4, 3, "a"), in(5, 3, "b")}},
            {"MIX_FLOAT", ShadingOp::MixFloat, 5, {out(1, 1, "out"), in(2, 1, "fac"), in(3, 1, "a"), in(4, 1, "b")}},
            {"MIX_VECTOR", ShadingOp::MixVector, 6,
             {out(2, 3, "out"), {3, 1, false, "fac", 0, 2}, in(4, 3, "a"), in(5, 3, "b")}},  // fac 3 wide if non-uniform
            {"INVERT", ShadingOp::Invert, 3, {out(0, 3, "out"), in(1, 1, "fac"), in(2, 3, "color")}},
            {"GAMMA", ShadingOp::Gamma, 3, {out(0, 3, "out"), in(1, 3, "color"), in(2, 1, "gamma")}},
            {"BRIGHT_CONTRAST", ShadingOp::BrightContrast, 4,
             {out(0, 3, "out"), in(1, 3, "color"), in(2, 1, "bright"), in(3, 1, "contrast")}},
            {"COPY", ShadingOp::Copy, 2, {out(0, 1, "out"), in(1, 1, "in")}},
            {"LUMINANCE", ShadingOp::Luminance, 3, {out(0, 1, "out"), in(1, 3, "color"), in(2, 3, "weights")}},
            {"AVERAGE", ShadingOp::Average, 2, {out(0, 1, "out"), in(1, 3, "vector")}},
            {"HAIR_INFO", ShadingOp::HairInfo, 2, {out(1, 1, "out")}},
            {"ATTRIBUTE", ShadingOp::Attribute, 2, {out(1, 5, "out")}},
            {"IMAGE_TEXTURE", ShadingOp::ImageTexture, 6, {out(4, 4, "out"), in(5, 3, "vector")}},
        };
        // Blender's identifiers, in the order of its enums (which Cycles' node types follow).
        const char* math_names[] = {
            "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE",
            "ARCTANGENT", "POWER", "LOGARITHM", "MINIMUM", "MAXIMUM", "ROUND", "LESS_THAN", "GREATER_THAN",
            "MODULO", "ABSOLUTE", "ARCTAN2", "FLOOR", "CEIL", "FRACT", "SQRT", "INVERSE_SQRT", "SIGN", "EXPONENT",
            "RADIANS", "DEGREES", "SINH", "COSH", "TANH", "TRUNC", "SNAP", "WRAP", "PINGPONG", "MULTIPLY_ADD",
            "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "FLOORED_MODULO"};
        static_assert(sizeof(math_names) / sizeof(math_names[0]) == size_t(MathType::Count));
        const char* blend_names[] = {
            "MIX", "ADD", "MULTIPLY", "SUBTRACT", "SCREEN", "DIVIDE", "DIFFERENCE", "DARKEN", "LIGHTEN",
            "OVERLAY", "DODGE", "BURN", "HUE", "SATURATION", "VALUE", "COLOR", "SOFT_LIGHT", "LINEAR_LIGHT",
            "EXCLUSION"};
        static_assert(sizeof(blend_names) / sizeof(blend_names[0]) == size_t(MixBlend::Count));
        auto in_order = [](const char* const* names, size_t n) {
            std::vector<ShadingNamedValue> v;
            for (size_t i = 0; i < n; ++i) v.push_back({names[i], int32_t(i)});
            return v;
        };
        s.enums = {
            {"math_types", in_order(math_names, size_t(MathType::Count))},
            {"map_range_types",
             {{"LINEAR", int32_t(MapRangeType::Linear)}, {"STEPPED", int32_t(MapRangeType::Stepped)},
              {"SMOOTHSTEP", int32_t(MapRangeType::SmoothStep)},
              {"SMOOTHERSTEP", int32_t(MapRangeType::SmootherStep)}}},
            {"clamp_types", {{"MINMAX", int32_t(ClampType::MinMax)}, {"RANGE", int32_t(ClampType::Range)}}},
            {"ramp_interpolations",  // Blender's ColorRamp interpolations -> the lookup in the baked table
             {{"CONSTANT", int32_t(RampLookup::Constant)}, {"LINEAR", int32_t(RampLookup::Linear)},
              {"EASE", int32_t(RampLookup::Linear)}, {"B_SPLINE", int32_t(RampLookup::Linear)},
              {"CARDINAL", int32_t(RampLookup::Linear)}}},
            {"mix_blends", in_order(blend_names, size_t(MixBlend::Count))},
            {"mix_flags", {{"CLAMP_FACTOR", kMixClampFactor}, {"CLAMP_RESULT", kMixClampResult}}},
            {"hair_info_outputs",  // the Hair Info node's output names
             {{"Random", int32_t(HairInfoOutput::Random)}, {"Intercept", int32_t(HairInfoOutput::Intercept)},
              {"Length", int32_t(HairInfoOutput::Length)}, {"Is Strand", int32_t(HairInfoOutput::IsStrand)}}},
            {"image_interpolations",  // Smart is evaluated as Cubic, as Cycles' CPU kernel does
             {{"Linear", int32_t(ImageInterpolation::Linear)}, {"Closest", int32_t(ImageInterpolation::Closest)},
              {"Cubic", int32_t(ImageInterpolation::Cubic)}, {"Smart", int32_t(ImageInterpolation::Cubic)}}},
            {"image_extensions",
             {{"REPEAT", int32_t(ImageExtension::Repeat)}, {"EXTEND", int32_t(ImageExtension::Extend)},
              {"CLIP", int32_t(ImageExtension::Clip)}, {"MIRROR", int32_t(ImageExtension::Mirror)}}},
            {"image_flags", {{"UNASSOCIATE_ALPHA", kImageUnassociateAlpha}, {"SRGB_DECODE", kImageSrgbDecode}}},
        };
        return s;
    }();
    return set;
}

namespace {

// Arguments after the opcode; ColorRamp and MixVector are checked specially (table / fac
// width). -1 for an unknown opcode.
int argument_count(ShadingOp op) {
    const auto& ops = shading_instruction_set().ops;
    const auto index = size_t(int32_t(op) - 1);
    return index < ops.size() ? ops[index].argument_count : -1;
}

}  // namespace

std::vector<ShadingOperand> instruction_operands(const int32_t* code) {
    const auto& ops = shading_instruction_set().ops;
    const auto index = size_t(code[0] - 1);
    if (index >= ops.size()) return {};
    const int32_t* a = code + 1;
    std::vector<ShadingOperand> blocks;
    for (const ShadingOperandSpec& o : ops[index].operands) {
        const int32_t width = o.width + (o.width_arg < 0 ? 0 : o.width_per_arg * a[o.width_arg]);
        blocks.push_back({o.arg, a[o.arg], width, o.write, o.what});
    }
    return blocks;
}

void validate_program(const ShadingProgram& p, int attribute_count, int image_count) {
    const int32_t n_const = int32_t(p.constants.size());
    if (p.register_count < n_const)
        throw std::invalid_argument("program: registers (" + std::to_string(p.register_count) +
                                    ") must be at least the number of constants (" + std::to_string(n_const) + ")");
    const size_t n = p.code.size();
    size_t pc = 0;
    int index = 0;
    while (pc < n) {
        const ShadingOp op = ShadingOp(p.code[pc]);
        const int argc = argument_count(op);
        const std::string where = "program: instruction " + std::to_string(index) + " (code[" + std::to_string(pc) + "])";
        if (argc < 0) throw std::invalid_argument(where + ": unknown opcode " + std::to_string(p.code[pc]));
        if (pc + 1 + size_t(argc) > n) throw std::invalid_argument(where + ": truncated");
        const int32_t* a = &p.code[pc + 1];
        auto in_range = [&](int32_t v, int32_t lo, int32_t hi, const char* what) {
            if (v < lo || v > hi)
                throw std::invalid_argument(where + ": " + what + " " + std::to_string(v) + " outside " +
                                            std::to_string(lo) + ".." + std::to_string(hi));
        };
        switch (op) {  // enum arguments; register blocks below
            case ShadingOp::Math: in_range(a[0], 0, int32_t(MathType::Count) - 1, "math type"); break;
            case ShadingOp::MapRange: in_range(a[0], 0, 3, "map range type"); break;
            case ShadingOp::Clamp: in_range(a[0], 0, int32_t(ClampType::Range), "clamp type"); break;
            case ShadingOp::ColorRamp:
                in_range(a[2], 2, 1 << 16, "ramp table size");
                if (a[1] < 0 || a[1] + 4 * a[2] > n_const)
                    throw std::invalid_argument(where + ": ramp table outside the constants");
                break;
            case ShadingOp::MixColor:
                in_range(a[0], 0, int32_t(MixBlend::Count) - 1, "blend type");
                in_range(a[1], 0, kMixClampFactor | kMixClampResult, "flags");
                break;
            case ShadingOp::MixVector: in_range(a[0], 0, 1, "non-uniform"); break;  // sets fac's width
            case ShadingOp::HairInfo: in_range(a[0], 0, 3, "hair info output"); break;
            case ShadingOp::Attribute: in_range(a[0], 0, attribute_count - 1, "attribute index"); break;
            case ShadingOp::ImageTexture:
                in_range(a[0], 0, image_count - 1, "image index");
                in_range(a[1], 0, 2, "interpolation");
                in_range(a[2], 0, 3, "extension");
                in_range(a[3], 0, kImageUnassociateAlpha | kImageSrgbDecode, "flags");
                break;
            default: break;
        }
        for (const ShadingOperand& o : instruction_operands(&p.code[pc])) {
            if (o.write && (o.slot < n_const || o.slot + o.width > p.register_count))
                throw std::invalid_argument(where + ": " + o.what + " writes register " + std::to_string(o.slot) +
                                            "; allowed " + std::to_string(n_const) + ".." +
                                            std::to_string(p.register_count - o.width) + " (constants are read-only)");
            if (!o.write && (o.slot < 0 || o.slot + o.width > p.register_count))
                throw std::invalid_argument(where + ": " + o.what + " reads register " + std::to_string(o.slot) +
                                            " outside 0.." + std::to_string(p.register_count - 1));
        }
        pc += 1 + size_t(argc);
        ++index;
    }
}

FoldedProgram fold_program(const ShadingProgram& p, const ShadingHitContext& zero_hit,
                           const std::vector<std::pair<int32_t, int32_t>>& outputs) {
    FoldedProgram f;
    const int32_t n_reg = p.register_count, n_const = int32_t(p.constants.size());
    f.values.assign(size_t(n_reg), 0.0f);
    f.dynamic.assign(size_t(n_reg), 0);
    f.slot.assign(size_t(n_reg), -1);
    run_program(p, zero_hit, f.values.data());

    struct Instruction {
        size_t pc;
        std::vector<ShadingOperand> operands;
        bool dynamic = false, kept = false;
    };
    std::vector<Instruction> code;
    std::vector<char> written(size_t(n_reg), 0);
    auto any_dynamic = [&f](const ShadingOperand& o) {
        return std::any_of(f.dynamic.begin() + o.slot, f.dynamic.begin() + o.slot + o.width, [](char d) { return d; });
    };
    // Forward: which registers depend on the hit. Folding assumes each temporary is written once
    // and read after (the exporter's programs); anything else is left as it is.
    for (size_t pc = 0; pc < p.code.size(); pc += 1 + size_t(argument_count(ShadingOp(p.code[pc])))) {
        Instruction ins{pc, instruction_operands(&p.code[pc])};
        const ShadingOp op = ShadingOp(p.code[pc]);
        ins.dynamic = op == ShadingOp::HairInfo || op == ShadingOp::Attribute;
        for (const ShadingOperand& o : ins.operands) {
            if (o.write) continue;
            for (int32_t r = o.slot; r < o.slot + o.width; ++r)
                if (r >= n_const && !written[size_t(r)]) return f;
            ins.dynamic = ins.dynamic || any_dynamic(o);
        }
        for (const ShadingOperand& o : ins.operands) {
            if (!o.write) continue;
            for (int32_t r = o.slot; r < o.slot + o.width; ++r) {
                if (written[size_t(r)]) return f;
                written[size_t(r)] = 1;
                f.dynamic[size_t(r)] = ins.dynamic;
            }
        }
        code.push_back(std::move(ins));
    }
    // Backward: the instructions the dynamic outputs need. A block read partly from dynamic
    // registers (a colour gathered from a dynamic and a constant float) stays whole in registers.
    std::vector<char> live(size_t(n_reg), 0);
    auto keep_block = [&live](int32_t slot, int32_t width) { std::fill(live.begin() + slot, live.begin() + slot + width, 1); };
    for (const auto& [slot, width] : outputs)
        if (any_dynamic(ShadingOperand{0, slot, width, false, ""})) keep_block(slot, width);
    for (auto it = code.rbegin(); it != code.rend(); ++it) {
        for (const ShadingOperand& o : it->operands)
            if (o.write && std::any_of(live.begin() + o.slot, live.begin() + o.slot + o.width, [](char l) { return l; }))
                it->kept = true;
        if (!it->kept) continue;
        for (const ShadingOperand& o : it->operands) {
            if (o.write) keep_block(o.slot, o.width);
            else if (any_dynamic(o)) keep_block(o.slot, o.width);
        }
    }
    if (std::any_of(live.begin(), live.begin() + n_const, [](char l) { return l; })) return f;
    // The kept instructions' constant reads (given or folded) become the new constants, each
    // block once; the kept registers follow, in their old order, so blocks stay contiguous.
    std::vector<std::pair<std::pair<int32_t, int32_t>, int32_t>> placed;  // (slot, width) -> new slot
    auto place = [&](const ShadingOperand& o) {
        for (const auto& [key, at] : placed)
            if (key.first == o.slot && key.second == o.width) return at;
        const int32_t at = int32_t(f.program.constants.size());
        f.program.constants.insert(f.program.constants.end(), f.values.begin() + o.slot,
                                   f.values.begin() + o.slot + o.width);
        placed.push_back({{o.slot, o.width}, at});
        return at;
    };
    for (const Instruction& ins : code)
        if (ins.kept)
            for (const ShadingOperand& o : ins.operands)
                if (!o.write && !any_dynamic(o)) place(o);
    int32_t next = int32_t(f.program.constants.size());
    for (int32_t r = n_const; r < n_reg; ++r)
        if (live[size_t(r)]) f.slot[size_t(r)] = next++;
    for (const Instruction& ins : code) {
        if (!ins.kept) continue;
        const int argc = argument_count(ShadingOp(p.code[ins.pc]));
        std::vector<int32_t> words(p.code.begin() + long(ins.pc), p.code.begin() + long(ins.pc) + 1 + argc);
        for (const ShadingOperand& o : ins.operands)
            words[size_t(o.arg) + 1] = (!o.write && !any_dynamic(o)) ? place(o) : f.slot[size_t(o.slot)];
        f.program.code.insert(f.program.code.end(), words.begin(), words.end());
    }
    f.program.register_count = f.program.code.empty() ? 0 : next;
    if (f.program.code.empty()) f.program.constants.clear();
    f.folded = true;
    return f;
}

void run_program(const ShadingProgram& p, const ShadingHitContext& ctx, float* r) {
    const size_t n_const = p.constants.size();
    std::copy(p.constants.begin(), p.constants.end(), r);
    std::fill(r + n_const, r + p.register_count, 0.0f);
    const int32_t* code = p.code.data();
    const size_t n = p.code.size();
    size_t pc = 0;
    while (pc < n) {
        const ShadingOp op = ShadingOp(code[pc]);
        const int32_t* a = code + pc + 1;
        switch (op) {
            case ShadingOp::Math: {
                float v = shading_math(MathType(a[0]), r[a[3]], r[a[4]], r[a[5]]);
                r[a[2]] = a[1] ? saturate(v) : v;
                break;
            }
            case ShadingOp::MapRange: {
                float v = shading_map_range(MapRangeType(a[0]), r[a[3]], r[a[4]], r[a[5]], r[a[6]], r[a[7]], r[a[8]]);
                if (a[1]) {  // Cycles appends a Clamp node (range mode) to a clamped Map Range
                    const float lo = r[a[6]], hi = r[a[7]];
                    v = lo > hi ? clampf(v, hi, lo) : clampf(v, lo, hi);
                }
                r[a[2]] = v;
                break;
            }
            case ShadingOp::Clamp: {
                const float v = r[a[2]], lo = r[a[3]], hi = r[a[4]];
                r[a[1]] = (ClampType(a[0]) == ClampType::Range && lo > hi) ? clampf(v, hi, lo) : clampf(v, lo, hi);
                break;
            }
            case ShadingOp::ColorRamp: {
                float rgba[4];
                ramp_lookup(p.constants.data() + a[1], a[2], RampLookup(a[0]) != RampLookup::Constant, r[a[5]], rgba);
                r[a[3]] = rgba[0];
                r[a[3] + 1] = rgba[1];
                r[a[3] + 2] = rgba[2];
                r[a[4]] = rgba[3];
                break;
            }
            case ShadingOp::MixColor: {
                float t = r[a[3]];
                if (a[1] & kMixClampFactor) t = saturate(t);
                float out[3];
                shading_mix(MixBlend(a[0]), t, r + a[4], r + a[5], out);
                for (int i = 0; i < 3; ++i) r[a[2] + i] = (a[1] & kMixClampResult) ? saturate(out[i]) : out[i];
                break;
            }
            case ShadingOp::MixFloat: {
                float t = r[a[2]];
                if (a[0]) t = saturate(t);
                r[a[1]] = r[a[3]] * (1.0f - t) + r[a[4]] * t;
                break;
            }
            case ShadingOp::MixVector: {
                float out[3];
                for (int i = 0; i < 3; ++i) {
                    float t = r[a[3] + (a[0] ? i : 0)];
                    if (a[1]) t = saturate(t);
                    out[i] = r[a[4] + i] * (1.0f - t) + r[a[5] + i] * t;
                }
                for (int i = 0; i < 3; ++i) r[a[2] + i] = out[i];
                break;
            }
            case ShadingOp::Invert: {
                const float f = r[a[1]];
                float out[3];
                for (int i = 0; i < 3; ++i) out[i] = lerp(r[a[2] + i], 1.0f - r[a[2] + i], f);
                for (int i = 0; i < 3; ++i) r[a[0] + i] = out[i];
                break;
            }
            case ShadingOp::Gamma: {
                const float g = r[a[2]];
                float out[3];
                for (int i = 0; i < 3; ++i) {
                    const float c = r[a[1] + i];
                    out[i] = g == 0.0f ? 1.0f : (c > 0.0f ? std::pow(c, g) : c);
                }
                for (int i = 0; i < 3; ++i) r[a[0] + i] = out[i];
                break;
            }
            case ShadingOp::BrightContrast: {
                const float contrast = r[a[3]];
                const float scale = 1.0f + contrast, shift = r[a[2]] - contrast * 0.5f;
                float out[3];
                for (int i = 0; i < 3; ++i) out[i] = std::max(scale * r[a[1] + i] + shift, 0.0f);
                for (int i = 0; i < 3; ++i) r[a[0] + i] = out[i];
                break;
            }
            case ShadingOp::Copy: r[a[0]] = r[a[1]]; break;
            case ShadingOp::Luminance:
                r[a[0]] = r[a[2]] * r[a[1]] + r[a[2] + 1] * r[a[1] + 1] + r[a[2] + 2] * r[a[1] + 2];
                break;
            case ShadingOp::Average: r[a[0]] = (r[a[1]] + r[a[1] + 1] + r[a[1] + 2]) * (1.0f / 3.0f); break;
            case ShadingOp::HairInfo: {
                const float values[4] = {ctx.random, ctx.intercept, ctx.length, ctx.is_strand};
                r[a[1]] = values[a[0]];
                break;
            }
            case ShadingOp::Attribute: {
                float rgba[4] = {0, 0, 0, 0};
                if (ctx.attributes && a[0] < ctx.attribute_count)
                    for (int i = 0; i < 4; ++i) rgba[i] = ctx.attributes[4 * a[0] + i];
                r[a[1]] = rgba[0];
                r[a[1] + 1] = rgba[1];
                r[a[1] + 2] = rgba[2];
                r[a[1] + 3] = (rgba[0] + rgba[1] + rgba[2]) * (1.0f / 3.0f);
                r[a[1] + 4] = rgba[3];
                break;
            }
            case ShadingOp::ImageTexture: {
                float rgba[4] = {0, 0, 0, 0};
                if (ctx.images && a[0] < ctx.image_count)
                    shading_image_lookup(ctx.images[a[0]], ImageInterpolation(a[1]), ImageExtension(a[2]), r[a[5]],
                                         r[a[5] + 1], rgba);
                // Cycles' svm_image_texture: unassociate where 0 < alpha != 1.
                if ((a[3] & kImageUnassociateAlpha) && rgba[3] != 1.0f && rgba[3] != 0.0f)
                    for (int c = 0; c < 3; ++c) rgba[c] /= rgba[3];
                if (a[3] & kImageSrgbDecode)
                    for (int c = 0; c < 3; ++c) rgba[c] = srgb_to_linear(rgba[c]);
                for (int c = 0; c < 4; ++c) r[a[4] + c] = rgba[c];
                break;
            }
        }
        pc += 1 + size_t(argument_count(op));
    }
}

}  // namespace hairbsdf::render
