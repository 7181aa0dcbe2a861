// The extension module poseonly._core: runs every registered binder in name order.
#include <algorithm>
#include <cstring>

#include "register.h"

namespace poseonly {
std::vector<std::pair<const char*, Binder>>& binders() {
  static std::vector<std::pair<const char*, Binder>> all;
  return all;
}
}  // namespace poseonly

NB_MODULE(_core, m) {
  m.doc() = "poseonly's compiled core (C++17, Eigen): residuals, LiRP, minimal solvers, robust loops, refinement.";
#ifdef POSEONLY_CORE_SOURCE_HASH
  m.attr("SOURCE_HASH") = POSEONLY_CORE_SOURCE_HASH;  // the build's src/core fingerprint (CMakeLists.txt)
#else
  m.attr("SOURCE_HASH") = "";
#endif
  auto& all = poseonly::binders();
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return std::strcmp(a.first, b.first) < 0; });
  for (const auto& [name, bind] : all) bind(m);
}
