// The core's layers, read from the #include lines (docs/architecture.md):
// - model files (include/hairbsdf/models, src/models) include only the math utilities, the
//   closure types (closure.h, itself only math.h), sibling models and, for the plugin adapter,
//   the C ABI it wraps; never the factory, params/, render/ or anything else;
// - render/ knows closures through one interface (closures.h): it includes no model header.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <set>
#include <string>

namespace fs = std::filesystem;

namespace {

// Calls `check(file, line number, header, quoted)` for every #include of the files in `dirs`
// (quoted: "..." rather than <...>); returns how many files it read.
using IncludeCheck = std::function<void(const fs::path&, int, const std::string&, bool)>;
int for_each_include(const std::vector<fs::path>& dirs, const IncludeCheck& check) {
    const std::regex include(R"re(^\s*#\s*include\s*([<"])([^">]+)[">])re");
    int files = 0;
    for (const fs::path& dir : dirs) {
        for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
            ++files;
            std::ifstream in(entry.path());
            std::string line;
            for (int number = 1; std::getline(in, line); ++number) {
                std::smatch m;
                if (std::regex_search(line, m, include)) check(entry.path(), number, m[2], m[1] == "\"");
            }
        }
    }
    return files;
}

bool starts_with(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

}  // namespace

TEST(LayerIncludes, ModelFilesIncludeOnlyMathUtilities) {
    const fs::path root = HAIRBSDF_CORE_DIR;
    const std::set<std::string> math = {"hairbsdf/math.h", "hairbsdf/math_quadrature.h", "hairbsdf/math_cubature.h",
                                        "hairbsdf/math_hair_defaults.h",
                                        "hairbsdf/math_simd.h", "hairbsdf/closure.h"};
    const int files = for_each_include(
        {root / "include/hairbsdf/models", root / "src/models"},
        [&](const fs::path& file, int number, const std::string& header, bool quoted) {
            if (!quoted) return;  // the standard library
            if (!starts_with(header, "hairbsdf/")) {
                // A private header beside it, in the model layer's own folder: "../batch/x.h" would
                // reach into another layer past the rule below.
                EXPECT_TRUE(header.find('/') == std::string::npos && fs::exists(file.parent_path() / header))
                    << file << ":" << number << " includes " << header << "; a model's private headers sit beside it";
                return;
            }
            const bool allowed = math.count(header) || starts_with(header, "hairbsdf/models/") ||
                                 (file.filename() == "plugin_hair.h" && header == "hairbsdf/plugin.h");
            EXPECT_TRUE(allowed) << file << ":" << number << " includes " << header
                                 << "; a model depends only on the math utilities and the closure types";
        });
    EXPECT_GT(files, 20);
}

TEST(LayerIncludes, RenderIncludesNoModelHeader) {
    const fs::path root = HAIRBSDF_CORE_DIR;
    bool closures_included = false;
    const int files = for_each_include(
        {root / "include/hairbsdf/render", root / "src/render"},
        [&](const fs::path& file, int number, const std::string& header, bool) {
            closures_included = closures_included || header == "hairbsdf/closures.h";
            EXPECT_FALSE(starts_with(header, "hairbsdf/models/") || starts_with(header, "models/"))
                << file << ":" << number << " includes the model header " << header
                << "; render/ reaches models through hairbsdf/closures.h";
        });
    EXPECT_GT(files, 10);
    EXPECT_TRUE(closures_included);
}
