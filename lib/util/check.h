// Throwing checks. The library never aborts: it throws and main decides.
//
//   LN_CHECK(i < n) << "index " << i;        // internal invariant -> std::logic_error (exit 1)
//   LN_CHECK_ARG(w > 0) << "window must be positive";  // option -> std::invalid_argument (exit 2)
//   LN_CHECK_INPUT(ok) << path << ": truncated";        // bad data -> InputError (exit 3)
//
// Only LN_CHECK adds the source location: the other two are messages for users.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

#include "util/errors.h"

namespace lunarnav::util::internal {

/// Collects a message with operator<< and throws `E` from its destructor.
template <typename E>
class Thrower {
 public:
  Thrower(const char* file, int line, const char* expr) {
    if (file != nullptr) stream_ << file << ":" << line << ": check failed: " << expr << ": ";
  }
  Thrower(const Thrower&) = delete;
  Thrower& operator=(const Thrower&) = delete;
  ~Thrower() noexcept(false) { throw E(::lunarnav::EscapeControlBytes(stream_.str())); }

  template <typename T>
  Thrower& operator<<(const T& value) {
    stream_ << value;
    return *this;
  }

 private:
  std::ostringstream stream_;
};

}  // namespace lunarnav::util::internal

#define LN_CHECK(cond) \
  if (cond) {          \
  } else               \
    ::lunarnav::util::internal::Thrower<std::logic_error>(__FILE__, __LINE__, #cond)

#define LN_CHECK_ARG(cond) \
  if (cond) {              \
  } else                   \
    ::lunarnav::util::internal::Thrower<std::invalid_argument>(nullptr, 0, nullptr)

#define LN_CHECK_INPUT(cond) \
  if (cond) {                \
  } else                     \
    ::lunarnav::util::internal::Thrower<::lunarnav::InputError>(nullptr, 0, nullptr)
