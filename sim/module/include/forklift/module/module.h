// Modules: the parts of a library that bring a heavy shared library with them (FCL, assimp,
// OSMesa), built as shared objects in lib/ beside the programs' bin/ and loaded the first time a
// program needs them. Mapping and relocating such a library costs every program that links it
// 10-20 ms before main (Debian builds them BIND_NOW), needed or not.
#pragma once

namespace forklift::module {

// The entry point `symbol` of the module `file`: the path in the environment variable `env` if
// set, else lib/<file> beside the program's bin/ folder. Loaded once per process (dlopen counts
// the handles) and never unloaded, since objects made by a module outlive every call into it.
// Thread-safe; throws std::runtime_error saying what could not be loaded and why.
void* entry_point(const char* file, const char* env, const char* symbol);

}  // namespace forklift::module
