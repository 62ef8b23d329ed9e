// Loading of hair BSDF plugins (hairbsdf/plugin.h): dlopen, the entry symbol, the ABI
// version, the function pointers and the parameter schema, each with a message that says
// what was found and what is expected.
#include <dlfcn.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <tuple>

#include "hairbsdf/models/plugin_hair.h"

namespace hairbsdf {

namespace {

std::string format_number(double x) {
    std::ostringstream s;
    s.precision(10);
    s << x;
    return s.str();
}

std::string range_text(const PluginParam& p) {
    return "[" + format_number(p.min_value) + ", " + format_number(p.max_value) + "]";
}

bool is_identifier(const char* s) {
    if (!s || !*s) return false;
    auto alpha = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; };
    if (!alpha(s[0])) return false;
    for (const char* c = s; *c; ++c)
        if (!alpha(*c) && !(*c >= '0' && *c <= '9')) return false;
    return true;
}

// Libraries already loaded, by (real path, device, inode, mtime): a rebuilt file loads again.
using Key = std::tuple<std::string, dev_t, ino_t, long long>;
std::mutex g_mutex;
std::map<Key, std::shared_ptr<const PluginLibrary>> g_loaded;
std::set<std::string> g_opened;  // real paths handed to dlopen

// dlopen returns the library already loaded under the same path even when the file has been
// rebuilt since; a rebuilt file is therefore loaded from a private copy (removed once mapped).
void* open_library(const std::string& resolved, std::string& error) {
    std::string file = resolved;
    std::string copy;
    if (g_opened.count(resolved)) {
        const char* tmp = std::getenv("TMPDIR");
        std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/hairbsdf_plugin_XXXXXX";
        std::vector<char> name(pattern.begin(), pattern.end());
        name.push_back('\0');
        const int fd = ::mkstemp(name.data());
        if (fd < 0) {
            error = "cannot create a temporary copy of the rebuilt library";
            return nullptr;
        }
        ::close(fd);
        copy = name.data();
        std::ifstream in(resolved, std::ios::binary);
        std::ofstream out(copy, std::ios::binary | std::ios::trunc);
        out << in.rdbuf();
        out.close();
        if (!in || !out) {
            ::unlink(copy.c_str());
            error = "cannot copy the rebuilt library to " + copy;
            return nullptr;
        }
        file = copy;
    }
    void* handle = ::dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        const char* e = ::dlerror();
        error = e ? e : "unknown dlopen error";
    }
    if (!copy.empty()) ::unlink(copy.c_str());
    if (handle) g_opened.insert(resolved);
    return handle;
}

}  // namespace

void PluginLibrary::check_values(const std::vector<double>& values) const {
    if (values.size() != 3 * params_.size())
        throw PluginError("plugin '" + name_ + "': " + std::to_string(values.size()) + " parameter values given, " +
                          std::to_string(3 * params_.size()) + " expected (3 per parameter)");
    for (size_t i = 0; i < params_.size(); ++i) {
        const PluginParam& p = params_[i];
        for (int c = 0; c < (p.rgb ? 3 : 1); ++c) {
            const double v = values[3 * i + size_t(c)];
            if (!(v >= p.min_value && v <= p.max_value))
                throw PluginError("plugin '" + name_ + "': parameter '" + p.name + "'" +
                                  (p.rgb ? "[" + std::to_string(c) + "]" : std::string()) + " = " + format_number(v) +
                                  " is out of range; allowed " + range_text(p));
        }
    }
}

std::vector<double> PluginLibrary::values(
    const std::vector<std::pair<std::string, std::array<double, 3>>>& given) const {
    std::vector<double> out(3 * params_.size());
    for (size_t i = 0; i < params_.size(); ++i)
        for (int c = 0; c < 3; ++c) out[3 * i + size_t(c)] = params_[i].default_value[size_t(c)];
    for (const auto& [name, value] : given) {
        size_t i = 0;
        while (i < params_.size() && params_[i].name != name) ++i;
        if (i == params_.size()) {
            std::string allowed;
            for (const PluginParam& p : params_) allowed += (allowed.empty() ? "" : ", ") + p.name;
            throw PluginError("plugin '" + name_ + "': unknown parameter '" + name + "'; allowed: " + allowed);
        }
        for (int c = 0; c < 3; ++c) out[3 * i + size_t(c)] = params_[i].rgb ? value[size_t(c)] : value[0];
    }
    check_values(out);
    return out;
}

std::shared_ptr<const PluginLibrary> load_plugin(const std::string& path) {
    const std::string where = "hairbsdf plugin '" + path + "'";
    struct stat st {};
    if (path.empty() || ::stat(path.c_str(), &st) != 0) throw PluginError(where + ": no such file");
    if (!S_ISREG(st.st_mode)) throw PluginError(where + ": not a regular file");
    char* real = ::realpath(path.c_str(), nullptr);
    const std::string resolved = real ? real : path;
    std::free(real);
    const Key key{resolved, st.st_dev, st.st_ino, (long long)st.st_mtime};

    std::lock_guard<std::mutex> lock(g_mutex);
    if (auto it = g_loaded.find(key); it != g_loaded.end()) return it->second;

    // A path without '/' would make dlopen search the library path; use the resolved one.
    std::string dl_error;
    void* handle = open_library(resolved, dl_error);
    if (!handle) throw PluginError(where + ": cannot load the shared library: " + dl_error);
    auto fail = [&](const std::string& message) {
        ::dlclose(handle);
        throw PluginError(message);
    };
    ::dlerror();
    void* symbol = ::dlsym(handle, HAIRBSDF_PLUGIN_ENTRY_NAME);
    if (!symbol)
        fail(where + ": missing symbol '" HAIRBSDF_PLUGIN_ENTRY_NAME
                     "' (define the entry point with HAIRBSDF_PLUGIN_ENTRY from hairbsdf/plugin.h, which gives it C "
                     "linkage and default visibility)");
    const auto entry = reinterpret_cast<hairbsdf_plugin_entry_fn>(symbol);
    const hairbsdf_plugin* d = entry(HAIRBSDF_PLUGIN_ABI_VERSION);
    if (!d)
        fail(where + ": " HAIRBSDF_PLUGIN_ENTRY_NAME "(" + std::to_string(HAIRBSDF_PLUGIN_ABI_VERSION) +
             ") returned NULL: the plugin refused this host's ABI version");
    if (d->abi_version != HAIRBSDF_PLUGIN_ABI_VERSION)
        fail(where + ": ABI version " + std::to_string(d->abi_version) + " found, " +
             std::to_string(HAIRBSDF_PLUGIN_ABI_VERSION) +
             " expected (rebuild the plugin against this version of hairbsdf/plugin.h)");
    if (!is_identifier(d->name)) fail(where + ": the descriptor's 'name' must be an identifier such as \"my_hair\"");
    const std::string named = "hairbsdf plugin '" + std::string(d->name) + "' (" + path + ")";
    const std::pair<const char*, bool> functions[] = {{"create", d->create != nullptr},
                                                      {"destroy", d->destroy != nullptr},
                                                      {"eval", d->eval != nullptr},
                                                      {"sample", d->sample != nullptr},
                                                      {"pdf", d->pdf != nullptr}};
    for (const auto& [fn, present] : functions)
        if (!present) fail(named + ": missing function '" + fn + "' (the descriptor's pointer is NULL)");
    if (d->param_count > 0 && !d->params) fail(named + ": param_count is " + std::to_string(d->param_count) +
                                               " but params is NULL");

    auto library = std::make_shared<PluginLibrary>();
    library->path_ = resolved;
    library->name_ = d->name;
    library->description_ = d->description ? d->description : "";
    library->descriptor_ = d;
    std::set<std::string> names;
    for (uint32_t i = 0; i < d->param_count; ++i) {
        const hairbsdf_param& q = d->params[i];
        const std::string which = named + ": parameter " + std::to_string(i);
        if (!is_identifier(q.name)) fail(which + ": the name must be an identifier");
        PluginParam p;
        p.name = q.name;
        if (!names.insert(p.name).second) fail(which + ": the name '" + p.name + "' is used twice");
        if (q.type != HAIRBSDF_PARAM_FLOAT && q.type != HAIRBSDF_PARAM_RGB)
            fail(which + " ('" + p.name + "'): type " + std::to_string(q.type) +
                 " is not allowed; use HAIRBSDF_PARAM_FLOAT (0) or HAIRBSDF_PARAM_RGB (1)");
        p.rgb = q.type == HAIRBSDF_PARAM_RGB;
        p.min_value = q.min_value;
        p.max_value = q.max_value;
        if (std::isnan(p.min_value) || std::isnan(p.max_value) || p.min_value > p.max_value)
            fail(which + " ('" + p.name + "'): the range " + range_text(p) + " is empty or NaN");
        for (int c = 0; c < 3; ++c) p.default_value[size_t(c)] = p.rgb || c == 0 ? q.default_value[c] : q.default_value[0];
        for (int c = 0; c < (p.rgb ? 3 : 1); ++c)
            if (!(p.default_value[size_t(c)] >= p.min_value && p.default_value[size_t(c)] <= p.max_value))
                fail(which + " ('" + p.name + "'): the default " + format_number(p.default_value[size_t(c)]) +
                     " lies outside its range " + range_text(p));
        p.description = q.description ? q.description : "";
        library->params_.push_back(p);
    }
    g_loaded[key] = library;
    return library;
}

PluginHair::PluginHair(std::shared_ptr<const PluginLibrary> library, const std::vector<double>& values)
    : library_(std::move(library)), values_(values) {
    if (!library_) throw PluginError("PluginHair: no plugin library");
    library_->check_values(values_);
    char error[512] = {0};
    const hairbsdf_plugin& d = library_->descriptor();
    void* instance = d.create(values_.data(), error, sizeof(error));
    if (!instance) {
        error[sizeof(error) - 1] = 0;
        throw PluginError("hairbsdf plugin '" + library_->name() + "': create failed: " +
                          (error[0] ? std::string(error) : std::string("(no message)")));
    }
    auto destroy = d.destroy;
    instance_ = std::shared_ptr<void>(instance, [destroy](void* p) { destroy(p); });
}

}  // namespace hairbsdf
