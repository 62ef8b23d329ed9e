// The zoo's parameter tables (params/<model>.h) and MaterialX's node tables (params/materialx.h):
// names unique, each bound row reads and writes its own field only (so no two rows share a field
// and a row's default is its field's default), and the factory's schema is the table's.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "hairbsdf/model_factory.h"
#include "hairbsdf/params/cycles_hair.h"
#include "hairbsdf/params/deon.h"
#include "hairbsdf/params/epic.h"
#include "hairbsdf/params/huang.h"
#include "hairbsdf/params/kajiya_kay.h"
#include "hairbsdf/params/marschner.h"
#include "hairbsdf/params/materialx.h"
#include "hairbsdf/params/scheuermann.h"
#include "hairbsdf/params/yan_fur.h"

using namespace hairbsdf;

namespace {

// A value of the row other than `v`, inside its range.
ParamValue other_value(const ModelParamSpec& s, const ParamValue& v) {
    ParamValue out = v;
    for (double& x : out) {
        if (s.kind == ParamKind::Choice || s.kind == ParamKind::Bool || s.kind == ParamKind::Int)
            x = x == s.max_value ? s.min_value : x + 1;
        else if (!std::isfinite(s.max_value))
            x += 1;
        else
            x = x == s.max_value ? 0.5 * (s.min_value + s.max_value) : 0.5 * (x + s.max_value);
    }
    if (s.kind == ParamKind::RGB || s.kind == ParamKind::Vector2)  // channels differ
        out[1] = std::isfinite(s.min_value) ? 0.5 * (out[1] + s.min_value) : out[1] + 1;
    if (s.kind == ParamKind::Vector2) out[2] = 0;  // unused
    return out;
}

// `in_factory`: the factory builds P by name (its schema must be the table's).
template <class P>
void check_table(bool in_factory = true) {
    const std::string model = ParamTable<P>::model;
    const std::vector<ParamRow<P>>& rows = ParamTable<P>::rows();
    std::set<std::string> names;
    for (const ParamRow<P>& row : rows) EXPECT_TRUE(names.insert(row.spec.name).second) << model << "." << row.spec.name;
    const P defaults{};
    for (size_t i = 0; i < rows.size(); ++i) {
        if (!rows[i].set) continue;
        if (!rows[i].spec.optional) {  // a bound row's default is its field's default
            EXPECT_EQ(rows[i].spec.default_value, rows[i].get(defaults)) << model << "." << rows[i].spec.name;
        }
        P p;
        const ParamValue v = other_value(rows[i].spec, rows[i].get(defaults));
        rows[i].set(p, v);
        EXPECT_EQ(rows[i].get(p), v) << model << "." << rows[i].spec.name << " does not read back what it wrote";
        for (size_t j = 0; j < rows.size(); ++j) {
            if (j == i || !rows[j].get) continue;
            EXPECT_EQ(rows[j].get(p), rows[j].get(defaults))
                << model << ": setting " << rows[i].spec.name << " changed " << rows[j].spec.name;
        }
    }
    if (!in_factory) return;
    const std::vector<ModelParamSpec>& schema = zoo_model_schema(model);
    ASSERT_EQ(schema.size(), rows.size()) << model;
    for (size_t i = 0; i < rows.size(); ++i) EXPECT_EQ(schema[i].name, rows[i].spec.name) << model;
}

}  // namespace

TEST(ParamTables, EachBoundRowOwnsItsField) {
    check_table<KajiyaKayHairParams>();
    check_table<EpicHairParams>();
    check_table<ScheuermannHairParams>();
    check_table<MarschnerHairParams>();
    check_table<DeonHairParams>();
    check_table<YanFurParams>();
    check_table<CyclesHairParams>();  // built by name outside the zoo
    check_table<HuangHairParams>(false);  // Huang's options, applied by the bindings
    check_table<ChiangHairBsdfInputs>(false);  // MaterialX nodes (hairbsdf.materialx)
    check_table<ChiangHairRoughnessInputs>(false);
    check_table<ChiangHairAbsorptionFromColorInputs>(false);
    check_table<DeonHairAbsorptionFromMelaninInputs>(false);
}

TEST(ParamTables, ZooModelsComeFromTheTables) {
    const std::vector<ZooModel>& models = zoo_models();
    ASSERT_EQ(models.size(), zoo_model_names().size());
    for (size_t i = 0; i < models.size(); ++i) {
        EXPECT_EQ(models[i].name, zoo_model_names()[i]);
        EXPECT_FALSE(models[i].title.empty());
        EXPECT_FALSE(models[i].summary.empty());
    }
    EXPECT_EQ(models[0].title, ParamTable<KajiyaKayHairParams>::title);
}
