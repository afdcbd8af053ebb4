#include "pslam/core/Error.h"

namespace pslam {

void require(bool condition, const std::string& context, const std::string& message) {
  if (!condition) throw Error(context + ": " + message);
}

namespace {
std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}
}  // namespace

std::string oneLineMessage(const std::string& what) {
  static const std::string kMessage = "Message:";
  std::string firstLine;
  std::size_t begin = 0;
  while (begin <= what.size()) {
    std::size_t end = what.find('\n', begin);
    if (end == std::string::npos) end = what.size();
    const std::string line = trim(what.substr(begin, end - begin));
    begin = end + 1;
    if (line.rfind(kMessage, 0) == 0) {
      const std::string m = trim(line.substr(kMessage.size()));
      if (!m.empty()) return m;
    }
    if (firstLine.empty() && !line.empty() && line.find("MRPT exception") == std::string::npos) firstLine = line;
  }
  return firstLine.empty() ? std::string("unknown error") : firstLine;
}

std::string oneLineMessage(const std::exception& e) { return oneLineMessage(std::string(e.what())); }

}  // namespace pslam
