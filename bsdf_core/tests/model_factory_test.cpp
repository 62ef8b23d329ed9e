// The model factory (model_factory.h): schemas, defaults equal to the model headers'
// own defaults, named values reaching the models, and errors that name the parameter.
#include <gtest/gtest.h>

#include <string>

#include "hairbsdf/model_factory.h"
#include "hairbsdf/params/principled_hair.h"

using namespace hairbsdf;

namespace {

std::string plugin_path(const std::string& name) { return std::string(HAIRBSDF_TEST_PLUGIN_DIR) + "/test_plugin_" + name + ".so"; }

// The message of the ModelError that `fn` throws ("" when it throws none).
template <class Fn>
std::string model_error(Fn fn) {
    try {
        fn();
    } catch (const ModelError& e) {
        return e.what();
    }
    return "";
}

const ShadingContext kContext = [] {
    ShadingContext c;
    c.wo = normalize(Vec3{0.3, 0.2, 0.9});
    c.h = 0.3;
    return c;
}();
const Vec3 kWi = normalize(Vec3{-0.4, 0.5, 0.6});

RGB value(const HairModel& m) { return eval_model(m, prepare_model(m, kContext), kWi).value(); }

void expect_rgb_eq(RGB a, RGB b) {
    EXPECT_DOUBLE_EQ(a.r, b.r);
    EXPECT_DOUBLE_EQ(a.g, b.g);
    EXPECT_DOUBLE_EQ(a.b, b.b);
}

}  // namespace

TEST(ModelFactory, NamesAndSchemas) {
    EXPECT_EQ(zoo_model_names(), (std::vector<std::string>{"kajiya_kay", "epic", "scheuermann", "marschner", "deon", "yan_fur"}));
    for (const std::string& name : zoo_model_names()) {
        EXPECT_TRUE(is_zoo_model(name));
        for (const ModelParamSpec& p : zoo_model_schema(name)) {
            EXPECT_FALSE(p.description.empty()) << name << "." << p.name;
            if (p.kind == ParamKind::Float || p.kind == ParamKind::RGB) {
                for (int c = 0; c < (p.kind == ParamKind::RGB ? 3 : 1); ++c) {
                    EXPECT_GE(p.default_value[size_t(c)], p.min_value) << name << "." << p.name;
                    EXPECT_LE(p.default_value[size_t(c)], p.max_value) << name << "." << p.name;
                }
            }
        }
    }
    EXPECT_FALSE(is_zoo_model(kPluginModel));
    const std::vector<ModelParamSpec>& epic = zoo_model_schema("epic");
    ASSERT_EQ(epic.back().name, "energy");
    EXPECT_EQ(epic.back().kind, ParamKind::Choice);
    EXPECT_EQ(epic.back().choices, (std::vector<std::string>{"bounded", "published"}));
    EXPECT_EQ(epic.back().default_value[0], 0.0);  // "bounded"
    ASSERT_EQ(epic[epic.size() - 2].name, "variant");
    EXPECT_EQ(epic[epic.size() - 2].choices, (std::vector<std::string>{"direct", "environment"}));
    EXPECT_EQ(zoo_model_schema("marschner").back().name, "energy");
    EXPECT_NE(model_error([] { make_zoo_model("marschner", {{"energy", std::string("clamped")}}); })
                  .find("parameter energy='clamped' is not allowed; choose one of: bounded, published"),
              std::string::npos);
    EXPECT_NE(model_error([] { zoo_model_schema("kajiya"); }).find("unknown model 'kajiya'; allowed: kajiya_kay, epic"),
              std::string::npos);
}

// model_names() is the one list of names: the factory knows each (the plugin from a path; the schema
// lookup is make_model's, without building Yan's tables) and its error for an unknown name lists exactly them.
TEST(ModelFactory, ModelNamesAreThoseTheFactoryBuilds) {
    std::vector<std::string> expected = zoo_model_names();
    expected.push_back("cycles_hair");
    expected.push_back(kPluginModel);
    EXPECT_EQ(model_names(), expected);
    for (const std::string& name : model_names()) {
        if (name == kPluginModel) continue;
        EXPECT_NO_THROW(model_schema(name)) << name;
    }
    std::string all;
    for (const std::string& name : model_names()) all += (all.empty() ? "" : ", ") + name;
    EXPECT_NE(model_error([] { make_model("kajiya", "", {}); }).find("allowed: " + all), std::string::npos);
}

// With no values every model equals the one its header's default parameters make (d'Eon: the
// Python constructor's melanin default).
TEST(ModelFactory, DefaultsAreTheModelDefaults) {
    expect_rgb_eq(value(make_zoo_model("kajiya_kay", {})), value(KajiyaKayHair(KajiyaKayHairParams{})));
    expect_rgb_eq(value(make_zoo_model("epic", {})), value(EpicHair(EpicHairParams{})));
    expect_rgb_eq(value(make_zoo_model("scheuermann", {})), value(ScheuermannHair(ScheuermannHairParams{})));
    expect_rgb_eq(value(make_zoo_model("marschner", {})), value(MarschnerHair(MarschnerHairParams{})));
    expect_rgb_eq(value(make_zoo_model("yan_fur", {})), value(YanFurHair(YanFurParams{})));
    // d'Eon's Python defaults are melanin 0.8, redness 1 (Cycles' pigments), not the header's sigma_a.
    DeonHairParams deon;
    deon.sigma_a = absorption_from_melanin(0.8, 1.0, RGB(1.0), 0.3);
    expect_rgb_eq(value(make_zoo_model("deon", {})), value(DeonHair(deon)));
}

TEST(ModelFactory, NamedValuesReachTheModel) {
    const HairModel kk = make_zoo_model("kajiya_kay", {{"diffuse", std::array<double, 3>{0.1, 0.2, 0.3}},
                                                       {"specular", 0.4}, {"exponent", 7.0}});
    const KajiyaKayHairParams& p = std::get<KajiyaKayHair>(kk).params();
    EXPECT_EQ(p.diffuse.g, 0.2);
    EXPECT_EQ(p.specular.b, 0.4);  // a number is grey
    EXPECT_EQ(p.exponent, 7.0);

    const HairModel epic = make_zoo_model("epic", {{"specular", 0.8}, {"variant", std::string("environment")}});
    EXPECT_DOUBLE_EQ(std::get<EpicHair>(epic).params().r_scale, 1.6);  // specular / 0.5
    EXPECT_EQ(std::get<EpicHair>(epic).params().variant, EpicVariant::Environment);

    // d'Eon: melanin through Cycles' mapping unless sigma_a is given; Bool as 0 / 1.
    const HairModel melanin = make_zoo_model("deon", {{"melanin", 0.5}, {"melanin_redness", 0.0}, {"tabulated", 0.0}});
    const RGB expect = absorption_from_melanin(0.5, 0.0, RGB(1.0), 0.3);
    EXPECT_DOUBLE_EQ(std::get<DeonHair>(melanin).params().sigma_a.b, expect.b);
    EXPECT_FALSE(std::get<DeonHair>(melanin).params().tabulated);
    const HairModel sigma = make_zoo_model("deon", {{"melanin", 0.5}, {"sigma_a", 0.25}, {"tabulated", 0.0}});
    EXPECT_EQ(std::get<DeonHair>(sigma).params().sigma_a.r, 0.25);
    const HairModel pigments = make_zoo_model("deon", {{"pigments", std::string("deon")}, {"tabulated", 0.0}});
    EXPECT_DOUBLE_EQ(std::get<DeonHair>(pigments).params().sigma_a.r,
                     -std::log(1 - 0.8) * 0.187);  // redness 1: pheomelanin only
}

TEST(ModelFactory, ErrorsNameTheParameter) {
    auto kk = [](ModelParams p) { return model_error([&] { make_zoo_model("kajiya_kay", p); }); };
    EXPECT_NE(kk({{"exponent", -1.0}}).find("parameter exponent=-1 is out of range; allowed: [0, 10000]"),
              std::string::npos)
        << kk({{"exponent", -1.0}});
    EXPECT_NE(kk({{"diffuse", std::array<double, 3>{0.2, 1.2, 0.1}}}).find("every channel must lie in [0, 1]"),
              std::string::npos);
    EXPECT_NE(kk({{"diffuse", 0.7}, {"specular", 0.4}}).find("diffuse + specular = (1.1, 1.1, 1.1) is out of range"), std::string::npos);
    EXPECT_NE(kk({{"exponant", 3.0}}).find("model 'kajiya_kay' has no parameter 'exponant'; allowed: diffuse, specular, exponent"),
              std::string::npos);
    EXPECT_NE(kk({{"exponent", std::string("big")}}).find("expected a number"), std::string::npos);
    EXPECT_NE(kk({{"exponent", std::nan("")}}).find("out of range"), std::string::npos);
    EXPECT_NE(model_error([] { make_zoo_model("epic", {{"variant", std::string("ambient")}}); })
                  .find("variant='ambient' is not allowed; choose one of: direct, environment"),
              std::string::npos);
    EXPECT_NE(model_error([] { make_zoo_model("deon", {{"tabulated", 0.5}}); }).find("expected a bool"), std::string::npos);
    EXPECT_NE(model_error([] { make_zoo_model("marschner", {{"eta", 0.9}}); }).find("eta=0.9 is out of range; allowed: [1.1, 3]"),
              std::string::npos);
    EXPECT_NE(model_error([] { make_model("yan", "", {}); }).find("unknown model 'yan'"), std::string::npos);
}

TEST(ModelFactory, Plugins) {
    const std::string path = plugin_path("valid");
    const std::vector<ModelParamSpec> schema = model_schema("plugin", path);
    ASSERT_EQ(schema.size(), 2u);
    EXPECT_EQ(schema[0].name, "albedo");
    EXPECT_EQ(schema[0].kind, ParamKind::RGB);
    EXPECT_EQ(schema[1].kind, ParamKind::Float);
    EXPECT_EQ(schema[1].min_value, -1.0);

    const HairModel m = make_model("plugin", path, {{"albedo", std::array<double, 3>{0.1, 0.2, 0.3}}, {"ripple", -0.25}});
    EXPECT_EQ(std::get<PluginHair>(m).values(), (std::vector<double>{0.1, 0.2, 0.3, -0.25, -0.25, -0.25}));
    const std::string range = model_error([&] { make_plugin_model(path, {{"ripple", 2.0}}); });
    EXPECT_NE(range.find("plugin 'test_ripple': parameter ripple=2 is out of range; allowed: [-1, 1]"), std::string::npos)
        << range;
    EXPECT_NE(model_error([&] { make_plugin_model(path, {{"ripples", 0.0}}); }).find("has no parameter 'ripples'"),
              std::string::npos);
    EXPECT_THROW(make_model("plugin", "/nonexistent/plugin.so", {}), PluginError);
}
