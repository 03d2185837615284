#include "io/json_io.h"

#include <fstream>
#include <sstream>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::io {

void WriteJsonAtomic(const std::filesystem::path& path, const nlohmann::json& value) {
  WriteFileAtomic(path, value.dump(2) + "\n");
}

nlohmann::json ReadJsonBounded(const std::filesystem::path& path, std::uintmax_t max_bytes, long max_values) {
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  LN_CHECK_INPUT(!ec) << path.string() << ": cannot open (" << ec.message() << ")";
  LN_CHECK_INPUT(size <= max_bytes) << path.string() << ": " << size << " bytes, more than the " << max_bytes
                                    << " such a file may have (docs/reliability.md)";
  std::ifstream in(path);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  long values = 0;
  const nlohmann::json::parser_callback_t count = [&](int, nlohmann::json::parse_event_t event, nlohmann::json&) {
    if (event == nlohmann::json::parse_event_t::value || event == nlohmann::json::parse_event_t::object_start ||
        event == nlohmann::json::parse_event_t::array_start) {
      LN_CHECK_INPUT(++values <= max_values) << path.string() << ": more than " << max_values
                                             << " JSON values, more than such a file may have (docs/reliability.md)";
    }
    return true;
  };
  try {
    return nlohmann::json::parse(in, count);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path.string() + ": invalid JSON (" + e.what() + ")");
  } catch (const nlohmann::json::exception& e) {
    // e.g. a number beyond a double's range ("1e999"): bad input, named by its file.
    throw InputError(path.string() + ": unusable JSON (" + e.what() + ")");
  }
}

nlohmann::json ReadJson(const std::filesystem::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(std::filesystem::is_regular_file(path, ec))
      << path.string() << ": cannot open (" << (std::filesystem::exists(path, ec) ? "not a file" : "no such file") << ")";
  return ReadJsonBounded(path, kMaxJsonBytes, kMaxJsonValues);
}

}  // namespace lunarnav::io
