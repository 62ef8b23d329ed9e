// The models whose defaults are Blender's Principled Hair node defaults start from the same
// numbers as PrincipledHairInputs (math_hair_defaults.h): a literal written again drifts here.
#include <gtest/gtest.h>

#include "hairbsdf/models/chiang.h"
#include "hairbsdf/models/deon.h"
#include "hairbsdf/models/epic.h"
#include "hairbsdf/models/huang.h"
#include "hairbsdf/models/marschner.h"
#include "hairbsdf/params/deon.h"
#include "hairbsdf/params/principled_hair.h"

using namespace hairbsdf;

namespace {

void expect_rgb_eq(RGB a, RGB b, const char* what) {
    EXPECT_EQ(a.r, b.r) << what;
    EXPECT_EQ(a.g, b.g) << what;
    EXPECT_EQ(a.b, b.b) << what;
}

}  // namespace

TEST(HairDefaults, ModelsStartFromPrincipledHairsDefaults) {
    const PrincipledHairInputs node;
    expect_rgb_eq(EpicHairParams{}.base_color, node.color, "epic base_color");
    expect_rgb_eq(MarschnerHairParams{}.sigma_a, node.absorption_coefficient, "marschner sigma_a");
    expect_rgb_eq(DeonHairParams{}.sigma_a, node.absorption_coefficient, "deon sigma_a");
    EXPECT_EQ(DeonHairParams{}.eta, node.ior);
    EXPECT_EQ(DeonHairParams{}.tilt, node.offset);
    EXPECT_EQ(HuangHairParams{}.eta, node.ior);
    EXPECT_EQ(HuangHairParams{}.offset, node.offset);
    EXPECT_EQ(ChiangHairParams{}.eta, node.ior);
    EXPECT_EQ(ParamTable<DeonHairParams>::kMelanin, node.melanin);
    EXPECT_EQ(ParamTable<DeonHairParams>::kMelaninRedness, node.melanin_redness);
}
