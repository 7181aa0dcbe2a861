// Each binding file registers its own functions with POSEONLY_BIND(name) { ... } so that a new
// component is one .cpp file (CMake globs src/core/*.cpp) and bindings.cpp never changes.
#pragma once

#include <nanobind/nanobind.h>

#include <utility>
#include <vector>

namespace poseonly {

using Binder = void (*)(nanobind::module_&);
std::vector<std::pair<const char*, Binder>>& binders();

struct RegisterBinder {
  RegisterBinder(const char* name, Binder b) { binders().emplace_back(name, b); }
};

}  // namespace poseonly

#define POSEONLY_BIND(name)                                                            \
  static void poseonly_bind_##name(nanobind::module_& m);                              \
  static ::poseonly::RegisterBinder poseonly_register_##name(#name, poseonly_bind_##name); \
  static void poseonly_bind_##name(nanobind::module_& m)
