// render::Bsdf keeps the Principled Hair models it builds from a curve's Random: a kept model must give
// the numbers of one built anew, for any order of curves, materials and models.
#include <gtest/gtest.h>

#include "hairbsdf/render/shading.h"

namespace hairbsdf::render {
namespace {

// A Principled Hair material; `fixed_random` >= 0: the closure's Random is that constant (its model is
// built once, with the material), else the curve's.
MaterialShader hair_material(ClosureDesc::HairModel model, double roughness, double fixed_random = -1.0) {
    MaterialDesc m;
    ClosureDesc c;
    if (fixed_random >= 0) {
        c.random_from_curve = false;
        c.hair.random = fixed_random;
    }
    c.type = ClosureDesc::Type::PrincipledHair;
    c.hair_model = model;
    c.hair.parametrization = Parametrization::Melanin;
    c.hair.roughness = roughness;
    c.hair.random_roughness = 0.4;  // the model depends on the curve's Random: built per hit
    c.hair.random_color = 0.3;
    m.closures.push_back(c);
    return MaterialShader(m, TiltConvention::Blender42);
}

ShadingGeometry fibre_hit(double random, double h) {
    ShadingGeometry g;
    g.wo = normalize(Vec3{0.3, 0.8, 0.5});
    g.n = g.wo;
    g.ng = g.wo;
    g.tangent = Vec3{1, 0, 0};
    g.curve_normal = Vec3{0, 1, 0};
    g.h = h;
    g.random = random;
    return g;
}

// Evaluates the hits in order with one Bsdf (its kept models), and each with the material whose Random
// is the curve's as a constant (a model built for it): equal bits.
void expect_kept_models_exact(const std::vector<std::pair<ClosureDesc::HairModel, double>>& kinds, int curves = 3000) {
    std::vector<MaterialShader> materials;
    for (const auto& [model, roughness] : kinds) materials.push_back(hair_material(model, roughness));
    Bsdf kept;
    const Vec3 wi = normalize(Vec3{-0.2, -0.6, 0.7});
    int compared = 0;
    // The curves, visited twice, with every material: more hits than a slot keeps, so entries are
    // replaced, found again and shared by materials and Randoms that land on the same entry.
    for (int round = 0; round < 2; ++round) {
        for (int curve = 0; curve < curves; ++curve) {
            const double random = double(float((curve * 7919 % curves) / double(curves)));
            for (size_t k = 0; k < kinds.size(); ++k) {
                const ShadingGeometry g = fibre_hit(random, 0.3);
                const MaterialShader constant = hair_material(kinds[k].first, kinds[k].second, random);
                Bsdf reference;
                kept.set_seeded(materials[k], g, 0.0, 7u);
                reference.set_seeded(constant, g, 0.0, 7u);
                const BsdfValue a = kept.eval(wi), b = reference.eval(wi);
                ASSERT_EQ(a.pdf, b.pdf) << "curve " << curve << ", round " << round;
                for (int c = 0; c < 3; ++c) ASSERT_EQ(a.value[c], b.value[c]) << "curve " << curve << ", round " << round;
                ++compared;
            }
        }
    }
    EXPECT_EQ(compared, 2 * curves * int(kinds.size()));
}

TEST(RenderShading, KeptCurveModelsEqualNewOnesChiang) {
    expect_kept_models_exact({{ClosureDesc::HairModel::Chiang, 0.2}, {ClosureDesc::HairModel::Chiang, 0.6}});
}

// Many materials with the same Randoms: an entry found by another material's model must not be used.
TEST(RenderShading, KeptCurveModelsEqualNewOnesManyMaterials) {
    std::vector<std::pair<ClosureDesc::HairModel, double>> kinds;
    for (int k = 0; k < 40; ++k) kinds.push_back({ClosureDesc::HairModel::Chiang, 0.2 + 0.01 * k});
    expect_kept_models_exact(kinds, 300);
}

TEST(RenderShading, KeptCurveModelsEqualNewOnesHuangAndChiang) {
    expect_kept_models_exact({{ClosureDesc::HairModel::Huang, 0.3}, {ClosureDesc::HairModel::Chiang, 0.3}});
}

}  // namespace
}  // namespace hairbsdf::render
