#include "pslam/core/Error.h"

namespace pslam {

void require(bool condition, const std::string& context, const std::string& message) {
  if (!condition) throw Error(context + ": " + message);
}

}  // namespace pslam
