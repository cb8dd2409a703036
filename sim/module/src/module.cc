#include "forklift/module/module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace forklift::module {
namespace {

std::string module_path(const char* file, const char* env) {
  if (const char* p = std::getenv(env); p && *p) return p;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error(std::string("cannot find this program's folder to load ") + file + ": " + ec.message());
  return (exe.parent_path().parent_path() / "lib" / file).string();
}

}  // namespace

void* entry_point(const char* file, const char* env, const char* symbol) {
  const std::string path = module_path(file, env);
  // RTLD_LOCAL: the module's own copies of our static libraries stay its own.
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) throw std::runtime_error(std::string("cannot load ") + dlerror());
  void* entry = dlsym(handle, symbol);
  if (!entry) throw std::runtime_error("the module " + path + " has no entry point " + symbol);
  return entry;
}

}  // namespace forklift::module
