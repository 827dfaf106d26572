// gzip (RFC 1952) of an HTTP response body, with zlib.
#pragma once

#include <string>
#include <string_view>

namespace geoprox::server {

/// `data` gzip-compressed at zlib's fastest level (the bodies are arrays of numbers, sent
/// once). Throws std::bad_alloc when zlib runs out of memory.
std::string gzip_compress(std::string_view data);

}  // namespace geoprox::server
