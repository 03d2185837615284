#include "io/json_io.h"

#include <fstream>
#include <sstream>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::io {

void WriteJsonAtomic(const std::filesystem::path& path, const nlohmann::json& value) {
  WriteFileAtomic(path, value.dump(2) + "\n");
}

nlohmann::json ReadJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path.string() + ": invalid JSON (" + e.what() + ")");
  } catch (const nlohmann::json::exception& e) {
    // e.g. a number beyond a double's range ("1e999"): bad input, named by its file.
    throw InputError(path.string() + ": unusable JSON (" + e.what() + ")");
  }
}

}  // namespace lunarnav::io
