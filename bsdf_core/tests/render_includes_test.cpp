// render/ knows closures through one interface (closures.h): no render source or header
// includes a model header. Allowed from models/: the factory that builds a HairModel by name
// and the plain-data parameter schema (neither holds model code).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <string>

namespace fs = std::filesystem;

TEST(RenderIncludes, NoModelHeader) {
    const fs::path root = HAIRBSDF_CORE_DIR;
    const std::set<std::string> allowed = {"hairbsdf/models/model_factory.h", "hairbsdf/models/model_params.h"};
    const std::regex include(R"re(^\s*#\s*include\s*[<"]([^">]+)[">])re");
    int files = 0;
    bool closures_included = false;
    for (const fs::path& dir : {root / "include/hairbsdf/render", root / "src/render"}) {
        for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
            ++files;
            std::ifstream in(entry.path());
            std::string line;
            for (int number = 1; std::getline(in, line); ++number) {
                std::smatch m;
                if (!std::regex_search(line, m, include)) continue;
                const std::string header = m[1];
                closures_included = closures_included || header == "hairbsdf/closures.h";
                const bool model_header = header.rfind("hairbsdf/models/", 0) == 0 || header.find("models/") == 0;
                EXPECT_FALSE(model_header && !allowed.count(header))
                    << entry.path() << ":" << number << " includes the model header " << header
                    << "; render/ reaches models through hairbsdf/closures.h";
            }
        }
    }
    EXPECT_GT(files, 10);
    EXPECT_TRUE(closures_included);
}
