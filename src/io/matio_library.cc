#include "io/matio_library.h"

#include <dlfcn.h>

#include "blmd/error.h"

// The shared library's name (its SONAME) and where the build found it (CMakeLists.txt): the
// name is looked up in the loader's path first, as a linked library would be, then at that
// place (a libmatio installed outside the loader's path, found through pkg-config).
#if !defined(BLMD_MATIO_SONAME) || !defined(BLMD_MATIO_PATH)
#error "BLMD_MATIO_SONAME, BLMD_MATIO_PATH: the build defines them from the libmatio it found"
#endif

namespace blmd::internal {
namespace {

struct Loaded {
  MatioLibrary library;
  std::string error;  // why not loaded; "" when it was
};

template <typename Function>
bool Resolve(void* handle, const char* symbol, Function* out, std::string* error) {
  *out = reinterpret_cast<Function>(dlsym(handle, symbol));
  if (!*out && error->empty()) error->assign(std::string("it has no ") + symbol);
  return *out != nullptr;
}

Loaded Load() {
  Loaded loaded;
  // Never closed: the functions are used until the program ends.
  void* handle = dlopen(BLMD_MATIO_SONAME, RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = dlerror();
    loaded.error = why ? why : "dlopen failed";
    handle = dlopen(BLMD_MATIO_PATH, RTLD_NOW | RTLD_LOCAL);
    if (!handle) return loaded;
    loaded.error.clear();
  }
  MatioLibrary& m = loaded.library;
  std::string& e = loaded.error;
  Resolve(handle, "Mat_Open", &m.Open, &e);
  Resolve(handle, "Mat_Close", &m.Close, &e);
  Resolve(handle, "Mat_GetDir", &m.GetDir, &e);
  Resolve(handle, "Mat_LogInitFunc", &m.LogInitFunc, &e);
  Resolve(handle, "Mat_SizeOfClass", &m.SizeOfClass, &e);
  Resolve(handle, "Mat_VarFree", &m.VarFree, &e);
  Resolve(handle, "Mat_VarGetNumberOfFields", &m.VarGetNumberOfFields, &e);
  Resolve(handle, "Mat_VarGetStructFieldByIndex", &m.VarGetStructFieldByIndex, &e);
  Resolve(handle, "Mat_VarGetStructFieldnames", &m.VarGetStructFieldnames, &e);
  Resolve(handle, "Mat_VarRead", &m.VarRead, &e);
  Resolve(handle, "Mat_VarReadInfo", &m.VarReadInfo, &e);
  return loaded;
}

// Debian's package of a shared library: its name without ".so", with the version appended
// ("libmatio.so.11": libmatio11).
std::string PackageOf(const std::string& soname) {
  const std::size_t so = soname.find(".so");
  if (so == std::string::npos) return soname;
  std::string version = soname.substr(so + 3);
  if (!version.empty() && version.front() == '.') version.erase(0, 1);
  return soname.substr(0, so) + version;
}

}  // namespace

const MatioLibrary& Matio(const std::string& path) {
  static const Loaded loaded = Load();
  if (!loaded.error.empty()) {
    throw InputError(path +
                     ": reading a .mat file needs libmatio (" BLMD_MATIO_SONAME
                     "), which could not be loaded: " +
                     loaded.error + "; install it (Debian: " + PackageOf(BLMD_MATIO_SONAME) +
                     ") or export the trace as CSV");
  }
  return loaded.library;
}

}  // namespace blmd::internal
