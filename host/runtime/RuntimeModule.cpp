// Loading of libvolcl's optional modules (dlopen beside libvolcl, then on the search path).
#include "host/runtime/RuntimeModule.hpp"

#include "host/Error.hpp"

#include <filesystem>
#include <string>
#include <vector>

#include <dlfcn.h>

namespace volcl {

const void* loadRuntimeModule(const char* file, const char* entry, const char* purpose) {
    std::string tried;
    Dl_info self{};
    std::vector<std::string> candidates;
    if (dladdr(reinterpret_cast<void*>(&loadRuntimeModule), &self) && self.dli_fname)
        candidates.push_back((std::filesystem::path(self.dli_fname).parent_path() / file).string());
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

} // namespace volcl
