// Loading of libvolcl's optional modules (dlopen beside libvolcl, then on the search path) and finding its
// helper programs (beside libvolcl).
#include "core/runtime/RuntimeModule.hpp"

#include "core/Error.hpp"

#include <filesystem>
#include <string>
#include <vector>

#include <dlfcn.h>
#include <unistd.h>

namespace volcl {

namespace {

// The directory libvolcl.so was loaded from (empty when unknown).
std::filesystem::path libraryDirectory() {
    Dl_info self{};
    if (dladdr(reinterpret_cast<void*>(&libraryDirectory), &self) && self.dli_fname)
        return std::filesystem::path(self.dli_fname).parent_path();
    return {};
}

} // namespace

const void* loadRuntimeModule(const char* file, const char* entry, const char* purpose) {
    std::string tried;
    std::vector<std::string> candidates;
    if (const std::filesystem::path dir = libraryDirectory(); !dir.empty())
        candidates.push_back((dir / file).string());
    candidates.push_back(file);
    for (const std::string& name : candidates) {
        if (void* handle = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL)) {
            using Entry = const void* (*)();
            if (auto fn = reinterpret_cast<Entry>(dlsym(handle, entry))) return fn();
            throw IoError(name + ": not a volcl module (no " + entry + ")");
        }
        const char* why = dlerror();
        tried += (tried.empty() ? "" : "; ") + std::string(why ? why : name);
    }
    throw IoError(std::string(purpose) + " needs " + file + ", which did not load: " + tried);
}

std::filesystem::path findRuntimeHelper(const char* file, const char* purpose) {
    const std::filesystem::path dir = libraryDirectory();
    if (dir.empty())
        throw IoError(std::string(purpose) + " needs " + file + ", but libvolcl's directory is unknown");
    const std::filesystem::path helper = dir / file;
    if (::access(helper.c_str(), X_OK) != 0)
        throw IoError(std::string(purpose) + " needs " + helper.string() +
                      ", which is missing or not executable");
    return helper;
}

} // namespace volcl
