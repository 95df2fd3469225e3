#include "engine/program/csv.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace overlap::engine {

std::string csvField(std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(text);
  std::string field = "\"";
  for (const char c : text) {
    field += c;
    if (c == '"') field += '"';
  }
  return field + '"';
}

std::string csvComment(std::string_view text) {
  std::string line = "# ";
  for (const char c : text) {
    if (c == '\n') {
      line += "\\n";
    } else if (c == '\r') {
      line += "\\r";
    } else {
      line += c;
    }
  }
  return line + '\n';
}

std::string exactNumber(double value) {
  char text[32];
  for (int digits = 1; digits <= 17; ++digits) {  // 17 digits read back as any double
    std::snprintf(text, sizeof(text), "%.*g", digits, value);
    if (std::strtod(text, nullptr) == value) break;
  }
  if (std::strchr(text, 'e') == nullptr) return text;
  // An exponent only where the plain decimal would be long: 1000, not 1e+03.
  char plain[64];
  for (int decimals = 0; decimals <= 20; ++decimals) {
    std::snprintf(plain, sizeof(plain), "%.*f", decimals, value);
    if (std::strtod(plain, nullptr) == value) return std::strlen(plain) <= 24 ? plain : text;
  }
  return text;
}

}  // namespace overlap::engine
